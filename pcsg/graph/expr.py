"""Arithmetic expressions -> bytecode for the njit machine in pcsg.trace.vm.

Compilation runs in three steps on a small tuple form:
  resolve  AST -> ('const', v) | ('load', name) | ('rand',) | ('op', opcode, args)
           | ('if', c, a, b) | ('and', a, b) | ('or', a, b); errors are reported here
           and the offending node becomes ('const', nan)
  fold     every subexpression that reads no parameter and calls no rand() is run
           once through the same VM and replaced by its value; an `if`, `&&` or
           `||` whose condition is constant keeps only the branch that runs
  emit     rows of (opcode, argument) with jumps relative to the jump's own row
"""
from __future__ import annotations

import copy
import functools
import math
import struct

import numpy as np

from ..language import ast
from ..language.names import PIXELS, RESERVED
from ..language.suggest import did_you_mean
from ..trace import vm

PIXELS_ONLY_IN_SELECTIONS = ("'pixels' (the instance's size in pixels) can only be read in a "
                             "module's selection")

# name -> (opcode, min args, max args or None for "any number")
FUNCTIONS = {
    'if': (None, 3, 3),
    'min': (vm.MIN, 2, None), 'max': (vm.MAX, 2, None),
    'abs': (vm.ABS, 1, 1), 'sqrt': (vm.SQRT, 1, 1), 'pow': (vm.POW, 2, 2),
    'exp': (vm.EXP, 1, 1), 'ln': (vm.LN, 1, 1), 'log': (vm.LN, 1, 1),
    'log10': (vm.LOG10, 1, 1),
    'sin': (vm.SIN, 1, 1), 'cos': (vm.COS, 1, 1), 'tan': (vm.TAN, 1, 1),
    'asin': (vm.ASIN, 1, 1), 'acos': (vm.ACOS, 1, 1), 'atan': (vm.ATAN, 1, 1),
    'atan2': (vm.ATAN2, 2, 2), 'deg': (vm.DEG, 1, 1), 'rad': (vm.RAD, 1, 1),
    'floor': (vm.FLOOR, 1, 1), 'ceil': (vm.CEIL, 1, 1), 'round': (vm.ROUND, 1, 1),
    'clamp': (vm.CLAMP, 3, 3),
    'rand': (vm.RAND_SEED, 0, 1),          # rand() with no argument is RAND
}

BINARY = {
    '+': vm.ADD, '-': vm.SUB, '*': vm.MUL, '/': vm.DIV, '%': vm.MOD, '^': vm.POW,
    '<': vm.LT, '<=': vm.LE, '>': vm.GT, '>=': vm.GE, '==': vm.EQ, '!=': vm.NE,
}
_BOOLEAN = {vm.LT, vm.LE, vm.GT, vm.GE, vm.EQ, vm.NE, vm.NOT, vm.TRUTH}
_NAN = ('const', math.nan)


def _arity_text(name, lo, hi, got):
    if hi is None:
        want = f"at least {lo} arguments"
    elif lo == hi:
        want = f"{lo} argument" + ("" if lo == 1 else "s")
    else:
        want = f"{lo} or {hi} arguments"
    return f"'{name}' takes {want}, got {got}"


class ExprTable:
    """All compiled expressions of one graph, sharing a code array and constant pool.

    params maps parameter names to slots of the params array given to the VM.
    report(span, message, code) receives every error, code being one of
    'undefined-name', 'unknown-function', 'arity'; the offending node compiles
    to nan so that compilation goes on and collects them all.
    """

    def __init__(self, params: dict[str, int], report, constants: dict[str, float] | None = None,
                 unknown=lambda name, used, hint: hint, operand=lambda name: None):
        self.params = params
        self.report = report
        # what to say of an undefined name read at an expanded offset, beside a guess
        self.unknown = unknown
        self.operand = operand          # what a CSG operand's name is, or None
        # parameters known to hold one value everywhere (the caller may still add to them)
        self.constants = {} if constants is None else constants
        self._code: list[tuple[int, int]] = []
        self._consts: list[float] = []
        self._const_index: dict[bytes, int] = {}
        self._exprs: list[tuple] = []          # (folded form, start, end, depth)
        self._need: list[int] = []             # the highest slot each expression reads
        self._arrays = None

    # ---- public ------------------------------------------------------------

    def add(self, node) -> int:
        return self.add_form(self._resolve(node))

    def add_form(self, form) -> int:
        """An expression given in the resolved tuple form (as form() returns them)."""
        form = self._fold(form)
        start = len(self._code)
        depth = _emit(form, self._code, self._const, self.params.__getitem__)
        self._exprs.append((form, start, len(self._code), depth))
        self._need.append(max((self.params[f[1]] for f in _walk(form) if f[0] == 'load'),
                              default=-1))
        self._arrays = None
        return len(self._exprs) - 1

    def form(self, idx):
        """Expression idx in the folded tuple form (see the module's docstring)."""
        return self._exprs[idx][0]

    def copy(self) -> "ExprTable":
        """A table with the same expressions, to which expressions can be added without
        changing this one's code (and so the kernels compiled from it)."""
        other = copy.copy(self)
        other._code, other._consts = list(self._code), list(self._consts)
        other._const_index = dict(self._const_index)
        other._exprs, other._need = list(self._exprs), list(self._need)
        other._arrays = None
        return other

    def __len__(self):
        return len(self._exprs)

    def reads(self, idx) -> frozenset[str]:
        return frozenset(f[1] for f in _walk(self._exprs[idx][0]) if f[0] == 'load')

    def uses_rand(self, idx) -> bool:
        return any(f[0] == 'rand' for f in _walk(self._exprs[idx][0]))

    def draws(self, idx) -> bool:
        """Whether the expression calls rand, with a seed or without."""
        return any(f[0] == 'rand' or (f[0] == 'op' and f[1] == vm.RAND_SEED)
                   for f in _walk(self._exprs[idx][0]))

    def constant(self, idx) -> float | None:
        form = self._exprs[idx][0]
        return form[1] if form[0] == 'const' else None

    def instructions(self, idx) -> list[tuple[str, int]]:
        """The expression's rows as (opcode name, argument), for tests and debugging."""
        _, start, end, _ = self._exprs[idx]
        return [(vm.OPCODE_NAMES[op], arg) for op, arg in self._code[start:end]]

    def arrays(self) -> dict:
        if self._arrays is None:
            self._arrays = {
                'code': np.array(self._code, dtype=np.int32).reshape(-1, 2),
                'consts': np.array(self._consts, dtype=np.float64),
                'start': np.array([e[1] for e in self._exprs], dtype=np.int32),
                'end': np.array([e[2] for e in self._exprs], dtype=np.int32),
                'max_stack': max([1] + [e[3] for e in self._exprs]),
            }
        return self._arrays

    def evaluate(self, idx, params, inst_hash: int = 0) -> float:
        a = self.arrays()
        _, start, end, depth = self._exprs[idx]
        values = np.ascontiguousarray(params, dtype=np.float64)
        # kept from add(): walking the form on every call was most of a probe's time
        need = self._need[idx]
        if values.ndim != 1 or values.size <= need:
            raise ValueError(f"expression {idx} reads slot {need}; got {values.shape} values")
        return float(vm.eval_expr(a['code'], a['consts'], start, end, values,
                                  np.uint64(int(inst_hash) & 0xFFFFFFFFFFFFFFFF),
                                  np.empty(max(depth, 1))))

    # ---- resolve: AST -> tuple form, reporting errors ---------------------------

    def _resolve(self, n):
        if isinstance(n, ast.Num):
            return ('const', float(n.value))
        if isinstance(n, ast.Var):
            if n.name in self.constants:
                return ('const', float(self.constants[n.name]))
            if n.name in self.params:
                return ('load', n.name)
            if n.name == 'pi':
                return ('const', math.pi)
            if n.name == PIXELS:
                self.report(n.span, PIXELS_ONLY_IN_SELECTIONS, 'pixels')
                return _NAN
            if n.name in RESERVED:
                self.report(n.span, f"'{n.name}' is {RESERVED[n.name]}, not a number",
                            'undefined-name')
                return _NAN
            if kind := self.operand(n.name):
                self.report(n.span, f"'{n.name}' is {kind}, a CSG operand, not a number",
                            'undefined-name')
                return _NAN
            hint = self.unknown(n.name, n.span[0],
                                did_you_mean(n.name, [*self.params, *self.constants, 'pi']))
            self.report(n.span, f"undefined name '{n.name}'{hint}", 'undefined-name')
            return _NAN
        if isinstance(n, ast.Unary):
            x = self._resolve(n.operand)
            return x if n.op == '+' else ('op', vm.NEG if n.op == '-' else vm.NOT, (x,))
        if isinstance(n, ast.Binary):
            a, b = self._resolve(n.left), self._resolve(n.right)
            if n.op == '&&':
                return ('and', a, b)
            if n.op == '||':
                return ('or', a, b)
            return ('op', BINARY[n.op], (a, b))
        if isinstance(n, ast.Call):
            return self._resolve_call(n)
        raise TypeError(f"not an arithmetic node: {n!r}")

    def _resolve_call(self, n):
        args = [self._resolve(a) for a in n.args]
        if n.name not in FUNCTIONS:
            known = ', '.join(sorted(FUNCTIONS))
            hint = did_you_mean(n.name, FUNCTIONS)
            self.report(n.name_span, f"unknown function '{n.name}'{hint} (the functions: "
                                     f"{known})", 'unknown-function')
            return _NAN
        opcode, lo, hi = FUNCTIONS[n.name]
        if len(args) < lo or (hi is not None and len(args) > hi):
            self.report(n.span, _arity_text(n.name, lo, hi, len(args)), 'arity')
            return _NAN
        if n.name == 'if':
            return ('if', *args)
        if n.name == 'rand' and not args:
            return ('rand',)
        if opcode in (vm.MIN, vm.MAX):            # min(a, b, c) = min(min(a, b), c)
            return functools.reduce(lambda a, b: ('op', opcode, (a, b)), args)
        return ('op', opcode, tuple(args))

    # ---- fold -------------------------------------------------------------------

    def _fold(self, f):
        kind = f[0]
        if kind == 'op':
            args = tuple(self._fold(a) for a in f[2])
            f = ('op', f[1], args)
            return ('const', _run(f)) if all(a[0] == 'const' for a in args) else f
        if kind == 'if':
            c = self._fold(f[1])
            if c[0] == 'const':
                return self._fold(f[2] if _run(('op', vm.TRUTH, (c,))) else f[3])
            return ('if', c, self._fold(f[2]), self._fold(f[3]))
        if kind in ('and', 'or'):
            a = self._fold(f[1])
            if a[0] == 'const':
                decided = bool(_run(('op', vm.TRUTH, (a,)))) == (kind == 'or')
                if decided:                       # 0 && x -> 0, 1 || x -> 1
                    return ('const', 1.0 if kind == 'or' else 0.0)
                return self._fold(_as_boolean(f[2]))
            return (kind, a, self._fold(f[2]))
        return f

    def _const(self, value: float) -> int:
        key = struct.pack('<d', value)
        if key not in self._const_index:
            self._const_index[key] = len(self._consts)
            self._consts.append(value)
        return self._const_index[key]


def _as_boolean(f):
    if f[0] in ('and', 'or') or (f[0] == 'op' and f[1] in _BOOLEAN):
        return f
    return ('op', vm.TRUTH, (f,))


def _walk(f):
    yield f
    if f[0] == 'op':
        for a in f[2]:
            yield from _walk(a)
    elif f[0] in ('if', 'and', 'or'):
        for a in f[1:]:
            yield from _walk(a)


def _emit(f, code, const, slot) -> int:
    """Append f's rows to code; return its maximum stack depth.

    const(value) and slot(name) give the argument of CONST and LOAD.
    """
    kind = f[0]
    if kind == 'const':
        code.append((vm.CONST, const(f[1])))
        return 1
    if kind == 'load':
        code.append((vm.LOAD, slot(f[1])))
        return 1
    if kind == 'rand':
        code.append((vm.RAND, 0))
        return 1
    if kind == 'op':
        depth = max(i + _emit(a, code, const, slot) for i, a in enumerate(f[2]))
        code.append((f[1], 0))
        return depth
    if kind == 'if':
        depth = _emit(f[1], code, const, slot)
        skip_then = _jump(code, vm.JUMP_IF_FALSE)
        depth = max(depth, _emit(f[2], code, const, slot))
        skip_else = _jump(code, vm.JUMP)
        _land(code, skip_then)
        depth = max(depth, _emit(f[3], code, const, slot))
        _land(code, skip_else)
        return depth
    # 'and' / 'or': the left value decides, or is popped and the right one converted
    depth = _emit(f[1], code, const, slot)
    done = _jump(code, vm.AND_JUMP if kind == 'and' else vm.OR_JUMP)
    depth = max(depth, _emit(_as_boolean(f[2]), code, const, slot))
    _land(code, done)
    return depth


def _jump(code, op):
    code.append((op, 0))
    return len(code) - 1


def _land(code, row):
    code[row] = (code[row][0], len(code) - row)


def _run(f) -> float:
    """Evaluate a parameter-free, rand()-free form with the VM itself."""
    code, consts = [], []

    def const(v):
        consts.append(v)
        return len(consts) - 1

    depth = _emit(f, code, const, slot=None)   # f has no 'load'
    return float(vm.eval_expr(np.array(code, dtype=np.int32).reshape(-1, 2),
                              np.array(consts, dtype=np.float64), 0, len(code),
                              np.zeros(1), vm.ROOT_HASH, np.empty(depth)))
