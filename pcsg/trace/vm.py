"""The expression machine: evaluates compiled arithmetic inside njit kernels.

Bytecode
--------
All expressions of a graph share one ``code`` array of shape (n, 2), dtype
int32: row ``i`` is the instruction ``(code[i, 0], code[i, 1])`` = (opcode,
argument), and one ``consts`` pool of float64. An expression is the row range
``[start, end)``; evaluation runs a value stack (the caller's ``stack``, at
least the expression's max depth long) and returns the single value left on it.

The argument is a constant index (CONST), a parameter slot (LOAD, STORE), a
salt slot (SALT) or a jump distance *relative to the jump's own row* (so code
can be moved without relocation); it is 0 for every other opcode. See
``OPCODE_NAMES``. A calculation block runs as one program: each assignment's
rows, preceded by SALT when they draw rand() and followed by STORE, so that the
block costs one call of the machine instead of one per assignment.

Truth: a value is true when it is non-zero and not nan. ``if``, ``&&``, ``||``
and ``!`` all use this one test, so ``if(nan, a, b)`` = b, ``nan && 1`` = 0,
``nan || 1`` = 1 and ``!nan`` = 1 (``!x`` is ``x == 0`` for every x but nan).
Comparisons follow IEEE: ``nan == nan`` is 0, ``nan != nan`` is 1.
Arithmetic is IEEE throughout (``error_model='numpy'``): 1/0 = inf,
0/0 = nan, ln(0) = -inf, sqrt(-1) = nan; nothing raises. ``a % b`` is
``a - b*floor(a/b)`` (sign of b; x % 0 = nan). ``min``/``max`` return nan if
either operand is nan. ``round`` rounds half away from zero.

Random numbers (the contract shared by expand/stats and the tracer)
-------------------------------------------------------------------
- ``splitmix64(x)``: the SplitMix64 output for state x (add 0x9E3779B97F4A7C15,
  then the Stafford 13 finaliser), on uint64 with wrap-around.
- ``hash_to_unit(h) = (h >> 11) / 2**53`` in [0, 1).
- ``rand(seed) = hash_to_unit(splitmix64(bits(seed)))`` where ``bits`` is the
  IEEE bit pattern of the float64 seed, with -0.0 taken as 0.0 and every nan
  as the canonical quiet nan 0x7FF8000000000000.
- ``mix(h, v) = splitmix64(h ^ splitmix64(v))`` (v a non-negative integer).
- ``edge_hash(h, node, child) = mix(mix(h, node), child)``: the instance hash
  one level down, when the walk goes from node id ``node`` to its child
  number ``child``. The axiom's instance starts from ``ROOT_HASH`` (0).
- ``salt(h, slot) = mix(h ^ SALT_KEY, slot)``: the ``inst_hash`` passed to
  ``eval_expr`` for a node's selection (slot 0) and for the i-th assignment
  of a calculation block (slot i + 1), so their draws are independent.
- ``rand()``: the k-th call *executed* within one evaluation (k = 0, 1, ...;
  calls in an untaken ``if`` branch do not count) returns
  ``hash_to_unit(mix(inst_hash, k))``.
"""
from __future__ import annotations

import math

import numpy as np

from .dispatch import cached_jit, declared
from .jit import inline, kernel

# ---- opcodes -------------------------------------------------------------
# Stack effects in brackets: [a b -> r] pops b (top) then a and pushes r.
CONST = 0          # [-> consts[arg]]
LOAD = 1           # [-> params[arg]]
NEG = 2            # [a -> -a]
NOT = 3            # [a -> 1 if a is not true else 0]
TRUTH = 4          # [a -> 1 if a is true else 0]
ADD = 5
SUB = 6
MUL = 7
DIV = 8
MOD = 9            # a - b*floor(a/b)
POW = 10           # a ** b (C pow: pow(nan, 0) = 1, pow(-8, 1/3) = nan)
LT = 11
LE = 12
GT = 13
GE = 14
EQ = 15
NE = 16
JUMP = 17          # pc += arg
JUMP_IF_FALSE = 18 # [c ->] ; pc += arg if c is not true
AND_JUMP = 19      # if top is not true: top = 0, pc += arg; else pop it
OR_JUMP = 20       # if top is true: top = 1, pc += arg; else pop it
MIN = 21           # [a b -> min]
MAX = 22
ATAN2 = 23         # [y x -> atan2(y, x)]
CLAMP = 24         # [x lo hi -> min(max(x, lo), hi)]
ABS = 25
SQRT = 26
EXP = 27
LN = 28
LOG10 = 29
SIN = 30
COS = 31
TAN = 32
ASIN = 33
ACOS = 34
ATAN = 35
DEG = 36
RAD = 37
FLOOR = 38
CEIL = 39
ROUND = 40         # half away from zero
RAND_SEED = 41     # [seed -> rand(seed)]
RAND = 42          # [-> rand()] ; the per-evaluation call counter advances
STORE = 43         # [a ->] ; params[arg] = a
SALT = 44          # rand() draws from the instance hash salted with arg; counter reset
BIN_LOAD = 45      # [a -> a op params[arg >> 6]], op = arg & 63: LOAD then a binary op
BIN_CONST = 46     # [a -> a op consts[arg >> 6]]: CONST then a binary op
FUSABLE = (ADD, SUB, MUL, DIV, MOD, POW, LT, LE, GT, GE, EQ, NE, MIN, MAX, ATAN2)

OPCODE_NAMES = {v: k for k, v in globals().items()
                if k.isupper() and isinstance(v, int) and not k.startswith('_')}
OP_BITS = 6
OP_MASK = (1 << OP_BITS) - 1

ROOT_HASH = np.uint64(0)
SALT_KEY = np.uint64(0x5DEECE66D2545F49)

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_CANON_NAN = np.uint64(0x7FF8000000000000)
_S11 = np.uint64(11)
_S27 = np.uint64(27)
_S30 = np.uint64(30)
_S31 = np.uint64(31)
_INV_2_53 = 1.0 / 9007199254740992.0
_DEG = 180.0 / math.pi
_RAD = math.pi / 180.0
_NAN = math.nan

_jit = cached_jit(error_model='numpy', nogil=True)


def _jit_sig(signature, inline="never"):
    # Fixed signatures for the small helpers: Python callers may pass plain ints
    # of any size (a lazily typed int64 version would overflow on h >= 2**63).
    # The hashes the walks take at every node are inlined by numba ("always"): left to
    # LLVM, whether they were depended on the size of the walk that called them, and
    # the packet walk called them once it had grown a little (tools/profile_trace.py)
    return declared(signature, error_model='numpy', nogil=True, inline=inline)


# ---- hashing ---------------------------------------------------------------

@_jit_sig('uint64(uint64)', "always")
def splitmix64(x):
    z = np.uint64(x) + _GOLDEN
    z = (z ^ (z >> _S30)) * _M1
    z = (z ^ (z >> _S27)) * _M2
    return z ^ (z >> _S31)


def splitmix64_array(x: np.ndarray) -> np.ndarray:
    """splitmix64 of each element of an integer array, in numpy (same bits)."""
    z = x.astype(np.uint64) + _GOLDEN
    z = (z ^ (z >> _S30)) * _M1
    z = (z ^ (z >> _S27)) * _M2
    return z ^ (z >> _S31)


def hash_to_unit_array(h: np.ndarray) -> np.ndarray:
    return (h >> _S11).astype(np.float64) * _INV_2_53


@_jit_sig('float64(uint64)')
def hash_to_unit(h):
    return np.float64(np.uint64(h) >> _S11) * _INV_2_53


@_jit_sig('uint64(uint64, uint64)', "always")
def mix(h, v):
    return splitmix64(np.uint64(h) ^ splitmix64(np.uint64(v)))


@_jit_sig('uint64(uint64, uint64, uint64)', "always")
def edge_hash(h, node, child):
    return mix(mix(h, node), child)


@_jit_sig('uint64(uint64, uint64, uint64)', "always")
def operand_key(h, node, k):
    """The instance table's key of operand k of the instance h of operator `node`: the
    keys of one instance's operands are consecutive, so their entries lie in
    neighbouring slots and a ray that tests them all loads them from one run of memory
    rather than from one random place each (instance_table.append, windows.operand_entry)."""
    return mix(h, node) + np.uint64(k)


@_jit_sig('uint64(uint64, uint64)')
def salt(h, slot):
    return mix(np.uint64(h) ^ SALT_KEY, slot)


@_jit_sig('uint64(float64)')
def float_bits(x):
    """The bit pattern of x, with -0.0 -> 0.0 and every nan -> one quiet nan."""
    if x != x:
        return _CANON_NAN
    if x == 0.0:
        return np.uint64(0)
    return np.float64(x).view(np.uint64)


@_jit_sig('float64(float64)')
def rand_seed(seed):
    return hash_to_unit(splitmix64(float_bits(seed)))


# ---- scalar helpers ----------------------------------------------------------

@_jit
def truth(x):
    return x < 0.0 or x > 0.0


@_jit
def round_half_away(x):
    t = np.trunc(x)                     # x - t is exact
    if abs(x - t) >= 0.5:
        t += math.copysign(1.0, x)
    return t


@_jit
def fmin(a, b):
    if a != a or b != b:
        return _NAN
    return a if a < b else b


@_jit
def fmax(a, b):
    if a != a or b != b:
        return _NAN
    return a if a > b else b


@_jit_sig('int64(float64, int64)')
def select_rule(x, nrules):
    """The rule number 1..nrules that x rounds to, or 0 if none does."""
    if not math.isfinite(x):
        return 0
    r = round_half_away(x)
    if r < 1.0 or r > nrules:
        return 0
    return int(r)


@inline
def binary(op, a, b):
    """a op b for the binary opcodes (ADD .. ATAN2 but the jumps)."""
    if op == ADD:
        return a + b
    if op == SUB:
        return a - b
    if op == MUL:
        return a * b
    if op == DIV:
        return a / b
    if op == MOD:
        return a - b * np.floor(a / b)
    if op == POW:
        return a ** b
    if op == LT:
        return 1.0 if a < b else 0.0
    if op == LE:
        return 1.0 if a <= b else 0.0
    if op == GT:
        return 1.0 if a > b else 0.0
    if op == GE:
        return 1.0 if a >= b else 0.0
    if op == EQ:
        return 1.0 if a == b else 0.0
    if op == NE:
        return 1.0 if a != b else 0.0
    if op == MIN:
        return fmin(a, b)
    if op == MAX:
        return fmax(a, b)
    return math.atan2(a, b)


# ---- the evaluator -------------------------------------------------------------

@_jit
def eval_expr(code, consts, start, end, params, inst_hash, stack):
    """Run rows [start, end) of code; return the value left on top of the stack.

    params: float64 parameter values by slot; inst_hash: uint64 instance hash
    for rand(), already salted; stack: float64 scratch of the expression's depth.
    Allocates nothing and never raises on any input value.
    """
    return eval_row(code, consts, start, end, params.reshape((1, params.shape[0])), 0,
                    inst_hash, -1, stack)


@kernel
def eval_row(code, consts, start, end, params, row, inst_hash, salt_slot, stack):
    """eval_expr with the parameters in params[row], and inst_hash salted with
    salt_slot at the first rand() (salt_slot < 0: already salted). The tracer calls
    this: a 2-D table needs no view, and expressions without rand() skip the hash."""
    sp = 0            # number of values on the stack
    nrand = 0         # rand() calls made so far
    h0 = inst_hash
    need_salt = salt_slot >= 0
    pc = start
    while pc < end:
        op = code[pc, 0]
        arg = code[pc, 1]
        pc += 1
        # the fused operators, the loads and the stores first: they are most rows of
        # calculation blocks (the terrain's: 29 %, 22 % and 20 %), and the branches are
        # tested in turn. The terrain at 9 rendered in 2.17 s against 2.24 s with them
        # last (6 rounds alternating, medians; tools/performance_notes.md)
        if op == BIN_LOAD:
            stack[sp - 1] = binary(arg & OP_MASK, stack[sp - 1], params[row, arg >> OP_BITS])
        elif op == BIN_CONST:
            stack[sp - 1] = binary(arg & OP_MASK, stack[sp - 1], consts[arg >> OP_BITS])
        elif op == LOAD:
            stack[sp] = params[row, arg]
            sp += 1
        elif op == STORE:
            sp -= 1
            params[row, arg] = stack[sp]
        elif op == CONST:
            stack[sp] = consts[arg]
            sp += 1
        elif op == RAND:
            if need_salt:
                inst_hash = salt(h0, salt_slot)
                need_salt = False
            stack[sp] = hash_to_unit(mix(inst_hash, nrand))
            nrand += 1
            sp += 1
        elif op == SALT:
            salt_slot = arg
            need_salt = True
            nrand = 0
        elif op == JUMP:
            pc += arg - 1
        elif op == JUMP_IF_FALSE:
            sp -= 1
            if not truth(stack[sp]):
                pc += arg - 1
        elif op == AND_JUMP:
            if truth(stack[sp - 1]):
                sp -= 1
            else:
                stack[sp - 1] = 0.0
                pc += arg - 1
        elif op == OR_JUMP:
            if truth(stack[sp - 1]):
                stack[sp - 1] = 1.0
                pc += arg - 1
            else:
                sp -= 1
        elif op <= TRUTH:                         # unary logic (CONST, LOAD are above)
            a = stack[sp - 1]
            if op == NEG:
                stack[sp - 1] = -a
            elif op == NOT:
                stack[sp - 1] = 0.0 if truth(a) else 1.0
            else:
                stack[sp - 1] = 1.0 if truth(a) else 0.0
        elif op <= ATAN2:                         # binary (the jumps are above)
            sp -= 1
            stack[sp - 1] = binary(op, stack[sp - 1], stack[sp])
        elif op == CLAMP:
            sp -= 2
            stack[sp - 1] = fmin(fmax(stack[sp - 1], stack[sp]), stack[sp + 1])
        else:                                     # unary functions
            a = stack[sp - 1]
            if op == ABS:
                r = abs(a)
            elif op == SQRT:
                r = math.sqrt(a)
            elif op == EXP:
                r = math.exp(a)
            elif op == LN:
                r = math.log(a)
            elif op == LOG10:
                r = math.log10(a)
            elif op == SIN:
                r = math.sin(a)
            elif op == COS:
                r = math.cos(a)
            elif op == TAN:
                r = math.tan(a)
            elif op == ASIN:
                r = math.asin(a)
            elif op == ACOS:
                r = math.acos(a)
            elif op == ATAN:
                r = math.atan(a)
            elif op == DEG:
                r = a * _DEG
            elif op == RAD:
                r = a * _RAD
            elif op == FLOOR:
                r = np.floor(a)                   # math.floor returns int64 in numba
            elif op == CEIL:
                r = np.ceil(a)
            elif op == ROUND:
                r = round_half_away(a)
            elif op == RAND_SEED:
                r = rand_seed(a)
            else:
                r = _NAN                          # unknown opcode
            stack[sp - 1] = r
    return stack[sp - 1] if sp > 0 else _NAN
