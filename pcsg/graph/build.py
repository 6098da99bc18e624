"""AST -> cyclic CSG graph: names resolved, one S-node per module, named
expressions built once and shared, every semantic error collected."""
from __future__ import annotations

import math
import sys
from collections import defaultdict

from ..language import ast
from ..language.errors import Diagnostic, PcsgError, sort_key
from ..language.names import FRACTAL_PRIMITIVES, FREE, PIXELS, PRIMITIVES, RESERVED, TRANSFORMS
from ..language.mistakes import axiom_slip
from ..language.unparse import unparse_arith
from ..language.suggest import did_you_mean
from ..overrides import underflows
from ..trace.fractals import check_arguments
from ..scene import build_scene
from .derive import names_in
from .expr import ExprTable
from .model import (CALC, MATERIAL, OPERATORS, PAINT, PRIMITIVE, SELECT, TRANSFORM, Graph, Node)


COMPARISONS = {"<", "<=", ">", ">=", "==", "!="}


class _Builder:
    def __init__(self, program: ast.Program, source, overrides: dict[str, float]):
        self.program = program
        self.source = source
        self.overrides = dict(overrides)
        self.errors: list[Diagnostic] = []
        self.warnings: list[Diagnostic] = list(source.warnings)   # the macros'
        self.nodes: list[Node] = []
        self.expr_ast: list = []
        self.primitive_nodes: dict[str, int] = {}
        self.named_nodes: dict[str, int] = {}
        self.named_building: list[str] = []
        self.named_read: set[str] = set()
        self.ruleless: set[str] = set()     # declared modules without rules (said there)

    # ---- reporting
    def error(self, span, message, code, notes=()):
        self.errors.append(Diagnostic("error", message, span, self.source, list(notes), code))

    def warn(self, span, message, code, notes=()):
        self.warnings.append(Diagnostic("warning", message, span, self.source, list(notes), code))

    def add(self, node: Node) -> int:
        self.nodes.append(node)
        return len(self.nodes) - 1

    def expr(self, node) -> int:
        self._chained_comparisons(node)
        idx = self.exprs.add(node)
        self.expr_ast.append(node)
        return idx

    def _chained_comparisons(self, node):
        """`1 < c < 3` is (1 < c) < 3, 0 or 1 against 3: true whatever c is. Legal, and
        never what it reads as."""
        stack = [node]
        while stack:
            n = stack.pop()
            if isinstance(n, ast.Binary):
                if n.op in COMPARISONS and isinstance(n.left, ast.Binary) and \
                        n.left.op in COMPARISONS and not self._bracketed(n, n.left):
                    a, b = unparse_arith(n.left.left), unparse_arith(n.left.right)
                    c = unparse_arith(n.right)
                    self.warn(n.span, f"'{a} {n.left.op} {b} {n.op} {c}' compares ({a} "
                                      f"{n.left.op} {b}), 0 or 1, with {c}; for both, write "
                                      f"'{a} {n.left.op} {b} && {b} {n.op} {c}'", "chained")
                stack += [n.left, n.right]
            elif isinstance(n, ast.Unary):
                stack.append(n.operand)
            elif isinstance(n, ast.Call):
                stack += n.args
            elif isinstance(n, ast.Num) and math.isinf(n.value):
                # a number past what a double holds reads as inf, where `--set c=1e999` is
                # refused: legal (1/0 is inf too), and most likely a slip
                text = self.source.expanded[n.span[0]:n.span[1]]
                self.warn(n.span, f"the number {text} is too large for a double (at most "
                                  f"{sys.float_info.max:.2g}): it reads as inf", "huge-number")
            elif isinstance(n, ast.Num) and n.value == 0.0 and \
                    underflows(text := self.source.expanded[n.span[0]:n.span[1]]):
                # as written: a --set of 0 keeps the place of the number it replaces
                self.warn(n.span, f"the number {text} is too small for a double (at least "
                                  f"{5e-324:.2g} in size): it reads as 0", "tiny-number")

    def _bracketed(self, n, left) -> bool:
        """Whether `left`, n's left operand, is written in brackets: `(1 < c) < 3` says
        what it means."""
        text = self.source.expanded[left.span[0]:left.span[1]]
        depth = 0
        for i, ch in enumerate(text):       # the bracket it opens with closes at its end
            depth += (ch == "(") - (ch == ")")
            if depth == 0:
                return i == len(text) - 1 and text[0] == "("
        return False

    # ---- the whole file
    def build(self) -> Graph:
        stmts = self.program.statements
        axioms = [s for s in stmts if isinstance(s, ast.Axiom)]
        decls = [s for s in stmts if isinstance(s, ast.ModuleDecl)]
        rules = [s for s in stmts if isinstance(s, ast.Rule)]
        self.named = {}
        for s in stmts:
            if isinstance(s, ast.Named):
                if s.name in self.named:
                    first = self.source.locate(self.named[s.name].name_span[0])
                    self.error(s.name_span, f"'{s.name}' is defined twice (first at {first})",
                               "duplicate")
                else:
                    self.named[s.name] = s
        decls, slipped = self._axiom_slips(decls, rules, axioms)
        self.rules = self._check_rules(rules, decls)
        if not slipped:
            self._check_axiom(axioms, decls)
        self.params = self._collect_params(stmts)
        self.pixels = self.params[PIXELS] if self._pixels_builtin else -1
        self._apply_overrides(axioms)
        self.exprs = ExprTable(self.params, self.error, self._initial_constants(axioms, stmts),
                               self._unknown_number, self._operand_kind)
        self.material_names: list[str] = []
        self.scene = build_scene([s for s in stmts if isinstance(s, ast.Directive)],
                                 self._constant, self.error, self.warn, self.source.locate)

        # S-nodes first, so that rule bodies can point at them before they are filled.
        self.modules = {}
        for name, (decl, _rules) in self.rules.items():
            span = decl.name_span if decl else _rules[0].module_span
            self.modules[name] = self.add(Node(SELECT, name=name, span=span))
        for name, (decl, by_number) in self.rules.items():
            s = self.nodes[self.modules[name]]
            sel = decl.selection if decl else ast.Num(1.0, s.span)
            s.exprs = [self.expr(sel)]
            for rule in by_number:
                s.children.append(self.csg(rule.body))
                # where the child is written: a rule `S -> S` put "calls itself here"
                # under the whole rule, where `S -> move(1,0,0) S` put it under the S
                s.edge_spans.append(rule.body.span)
        for name, named in self.named.items():
            if name not in self.modules:
                self.named_ref(name, named.name_span)
        root = self.csg(axioms[0].expr) if axioms else -1
        for name, named in self.named.items():
            if name not in self.named_read and name not in self.modules and axioms:
                self.warn(named.name_span, f"named expression '{name}' is never used", "unused")
        if self.errors:
            # `#define light lamp`: "unknown directive '#lamp'", and why
            raise PcsgError(self.source.explaining() + sorted(self.errors, key=sort_key))
        return Graph(self.source, self.nodes, root, self.params, self.modules, self.exprs,
                     self.expr_ast, self.scene, self.material_names, self.warnings,
                     axioms[0].span if axioms else None, pixels=self.pixels)

    # ---- statements
    def _check_rules(self, rules, decls):
        by_module = defaultdict(list)
        for r in rules:
            by_module[r.module].append(r)
        declared = {}
        for d in decls:
            if d.name in declared:
                first = self.source.locate(declared[d.name].name_span[0])
                self.error(d.name_span, f"module '{d.name}' is declared twice (first at {first})",
                           "duplicate")
            elif self._reserved(d.name, d.name_span, "a module"):
                # `if 1` was told to write rules for 'if', which then were refused
                self.ruleless.add(d.name)
            elif d.name not in by_module:
                self.error(d.name_span, f"'{d.name}' is declared as a module but has no rules "
                                        f"(write them as '1: {d.name} → ...')", "no-rules")
                self.ruleless.add(d.name)
            declared.setdefault(d.name, d)
        out = {}
        for name, rs in by_module.items():
            self._reserved(name, rs[0].module_span, "a module")
            if name in self.named:
                # notation §2: a name resolves to a module before a named expression
                self.warn(self.named[name].name_span,
                          f"'{name}' is both a module and a named expression: it names the "
                          f"module, and the named expression is never used", "shadowed")
            numbers = defaultdict(list)
            for r in rs:
                numbers[r.number].append(r)
            for n, same in numbers.items():
                for r in same[1:]:
                    first = self.source.locate(same[0].number_span[0])
                    self.error(r.number_span, f"rule {n} of '{name}' is given twice "
                                              f"(first at {first})", "rule-number")
            expected = set(range(1, len(numbers) + 1))
            decl = declared.get(name)
            # a rule whose head misspells a module (`2: Ss → ...` for S): said as a gap or
            # a missing selection, with no word of S
            hint = "" if decl is not None else did_you_mean(
                name, [m for m in declared if m != name])
            for n in sorted(set(numbers) - expected):
                missing = sorted(expected - set(numbers))
                if n < 1:
                    self.error(numbers[n][0].number_span, f"rules are numbered from 1, and "
                               f"'{name}' has a rule {n}", "rule-number")
                    continue
                self.error(numbers[n][0].number_span,
                           f"rules of '{name}' must be numbered 1..{len(numbers)}; "
                           f"rule {n} leaves a gap (missing: {', '.join(map(str, missing))})"
                           + hint, "rule-number")
            if decl is None and len(numbers) > 1:
                self.error(rs[0].module_span,
                           f"module '{name}' has {len(numbers)} rules but no selection; declare "
                           f"one, e.g. '{name} if(..., 2, 1)'" + hint, "no-selection")
            out[name] = (decl, [numbers[n][0] for n in sorted(numbers)])
        return out

    def _axiom_slips(self, decls, rules, axioms):
        """(the declarations that are ones, whether an axiom slip was said). A line
        `NAME selection` declares a module, so `sphere - cube` or, in a file without an
        axiom, `S - cube` did too: "declared as a module but has no rules", or "no
        axiom" and "undefined name 'cube'" for a slip of one character."""
        modules = {r.module for r in rules}
        kept, slipped = [], False
        for d in decls:
            operands = {n for n in names_in(d.selection) if n in PRIMITIVES or n in modules}
            slip = None
            if (d.name in PRIMITIVES and d.name not in modules) or \
                    (not axioms and not slipped and operands):
                slip = axiom_slip(self.source.expanded, d.name, d.name_span[1])
            if slip is None:
                kept.append(d)
                continue
            # `Y sphere` above `#define Y move(1,0,0)`: the macro is not replaced there
            self.error(slip[1], slip[0] + self.source.defined_below(d.name, d.name_span[0]),
                       "syntax")
            slipped = True
            if d.name in modules:
                # it stays the module's declaration, of a selection that says nothing
                # more: "has 2 rules but no selection" followed it
                kept.append(ast.ModuleDecl(d.name, ast.Num(1.0, d.selection.span), d.span,
                                           d.name_span))
        return kept, slipped

    def _check_axiom(self, axioms, decls):
        if not axioms:
            # `S 1` meant as the axiom is a declaration of S with the selection 1: said
            # where the module has one rule, which needs no declaration
            notes = [(d.span, f"'{self.source.expanded[d.span[0]:d.span[1]]}' is read as the "
                              f"declaration of module '{d.name}' (a name and its selection); "
                              f"as the axiom, write a CSG expression alone, e.g. '{d.name}'")
                     for d in decls if len(self.rules.get(d.name, (None, ()))[1]) == 1]
            self.errors.append(Diagnostic(
                "error", "no axiom: a file needs one CSG expression to start from, "
                         "e.g. '{c = 6} S'", None, self.source, notes=notes, code="axiom"))
        for extra in axioms[1:]:
            first = self.source.locate(axioms[0].span[0])
            self.error(extra.span, f"a second axiom; a file has exactly one (the first is at "
                                   f"{first}). A module declaration needs a selection "
                                   f"expression after its name.", "axiom")

    def _reserved(self, name, span, what) -> bool:
        if name in RESERVED and name not in FREE:
            self.error(span, f"'{name}' is a reserved name ({RESERVED[name]}) and cannot "
                             f"name {what}", "reserved")
            return True
        return False

    def _collect_params(self, stmts) -> dict[str, int]:
        params: dict[str, int] = {}
        first: dict[str, tuple] = {}
        for assign in _assignments(stmts):
            if assign.name not in params and not self._reserved(assign.name, assign.name_span,
                                                                 "a parameter"):
                params[assign.name] = len(params)
                first[assign.name] = assign.name_span
        for name in self.rules:
            if name in params:
                # allowed (notation §2 forbids only reserved names; operands and numbers are
                # apart), and most often a slip
                self.warn(first[name], f"'{name}' is both a module and a parameter: it is the "
                                       f"module where an operand stands, the parameter in "
                                       f"arithmetic", "shadowed")
        for name, named in self.named.items():
            if not self._reserved(name, named.name_span, "a named expression") and \
                    name in params:
                # allowed (operands and numbers are apart), and most often a slip:
                # `{segment = segments - 1}` for the parameter `segments`
                self.warn(named.name_span, f"'{name}' is both a named expression and a "
                                           f"parameter", "shadowed")
        self._pixels_builtin = PIXELS not in params and any(
            decl is not None and PIXELS in names_in(decl.selection)
            for decl, _ in self.rules.values())
        if self._pixels_builtin:
            params[PIXELS] = len(params)     # a slot that the tracer fills before selecting
        return params

    def _apply_overrides(self, axioms):
        """--set NAME=VALUE replaces NAME's value in the axiom's initialisation blocks."""
        if not self.overrides:
            return
        initial = []
        node = axioms[0].expr if axioms else None
        stack = [node] if node is not None else []
        while stack:
            n = stack.pop()
            if isinstance(n, ast.Calc):
                initial += n.assigns
            for child in _csg_children(n):
                stack.append(child)
        known = {a.name for a in initial}
        read = _reads(self.program.statements)
        for name, value in self.overrides.items():
            if name not in known:
                listed = ", ".join(sorted(known)) or "none: the axiom has no calculation block"
                self.errors.append(Diagnostic(
                    "error", f"cannot set '{name}': it is not an initial parameter "
                             f"(initial parameters: {listed})", None, self.source, code="set"))
            elif name not in read:
                # an expanded file keeps its axiom's block, and `--set c=5` on it drew the
                # same object as c=2 without a word
                self.warnings.append(Diagnostic(
                    "warning", f"'{name}' is set to {float(value):g}, but nothing in the file "
                               f"reads it: the object is the same whatever its value", None,
                    self.source, code="set-unread"))
            for a in initial:
                if a.name == name:
                    a.value = ast.Num(float(value), a.value.span)

    def _initial_constants(self, axioms, stmts) -> dict[str, float]:
        """Parameters assigned once, in a calculation block at the head of the axiom (so on
        every path), from constants, and never again: their reads fold to that value, so
        that e.g. the tree's rotx(alpha1) becomes a fixed matrix. The blocks still assign
        them, so parameter states (expand, stats) are unchanged."""
        if not axioms or self.errors:
            return {}
        head, e = [], axioms[0].expr
        # a paint's arguments read what the blocks above it assigned, not those below:
        # `paint(c, 1, 0) {c = 1} sphere` read c = 1, and passed as assigned
        paint_reads: dict[int, set[str]] = {}
        while isinstance(e, (ast.Calc, ast.Paint, ast.Material)):
            if isinstance(e, ast.Calc):
                head += e.assigns
            elif isinstance(e, ast.Paint):
                paint_reads.setdefault(len(head), set()).update(
                    *(names_in(a) for a in e.args))
            e = e.operand
        counts = defaultdict(int)
        for a in _assignments(stmts):
            counts[a.name] += 1
        # the head's values so far: a parameter assigned again later (the tree's
        # `segments`) still has its head value where the head reads it (`dSG =
        # 1/segments`), and what is computed from it there is a constant
        now: dict[str, float] = {}
        read_before: set[str] = set()        # a read before the assignment must stay an error
        probe = ExprTable(self.params, lambda *_: None, now)
        for k, a in enumerate(head):
            read_before |= paint_reads.get(k, set()) | names_in(a.value)
            value = None if a.name in read_before else probe.constant(probe.add(a.value))
            if value is None:
                now.pop(a.name, None)
            else:
                now[a.name] = value
        return {name: v for name, v in now.items() if counts[name] == 1}

    def _constant(self, node) -> float | None:
        """A directive value: numbers and pi only; None where it is an error (reported)."""
        errors = len(self.errors)
        table = ExprTable({}, self.error)
        value = float(table.evaluate(table.add(node), _EMPTY))
        return None if len(self.errors) > errors else value

    # ---- CSG expressions
    def csg(self, e) -> int:
        if isinstance(e, ast.Ref):
            return self.ref(e)
        if isinstance(e, ast.Fractal):
            return self.fractal(e)
        if isinstance(e, ast.CsgOp):
            # A chain A ∪ B ∪ C (or A \ B \ C = A \ (B ∪ C)) is one n-ary node: no
            # recursion along long chains such as expand's output, and one place where
            # the tracer can order the operands front to back.
            operands = []
            head = e
            while isinstance(head, ast.CsgOp) and head.op == e.op:
                operands.append(head.right)
                head = head.left
            operands.append(head)
            operands.reverse()
            children = [self.csg(x) for x in operands]
            return self.add(Node(OPERATORS[e.op], children=children, span=e.op_span,
                                 edge_spans=[x.span for x in operands]))
        if isinstance(e, ast.Transform):
            want = TRANSFORMS[e.name]
            if len(e.args) != want:
                self.error(e.head_span, f"'{e.name}' takes {want} argument"
                                        f"{'' if want == 1 else 's'}, got {len(e.args)}", "arity")
            args = [self.expr(a) for a in e.args]
            return self._unary(TRANSFORM, e, e.name, args)
        if isinstance(e, ast.Calc):
            node = Node(CALC, span=e.head_span)
            for a in e.assigns:
                node.targets.append(self.params.get(a.name, -1))
                node.exprs.append(self.expr(a.value))
            node.children = [self.csg(e.operand)]
            node.edge_spans = [e.operand.span]
            return self.add(node)
        if isinstance(e, ast.Paint):
            if len(e.args) != 3:
                self.error(e.head_span, f"'paint' takes 3 arguments (r, g, b), got {len(e.args)}",
                           "arity")
            exprs = [self.expr(a) for a in e.args]
            self._paint_range(e, exprs)
            return self._unary(PAINT, e, "paint", exprs)
        if isinstance(e, ast.Material):
            if e.name not in self.scene.materials:
                known = ", ".join(sorted(self.scene.materials)) or "none defined"
                hint = did_you_mean(e.name, self.scene.materials)
                self.error(e.name_span, f"unknown material '{e.name}'{hint} (define it with "
                                        f"'#material {e.name} ...'; known: {known})", "undefined")
            if e.name not in self.material_names:
                self.material_names.append(e.name)
            return self._unary(MATERIAL, e, e.name, [])
        raise TypeError(f"not a CSG node: {e!r}")

    def _unary(self, kind, e, name, exprs) -> int:
        child = self.csg(e.operand)
        return self.add(Node(kind, name=name, children=[child], exprs=exprs, span=e.head_span,
                             edge_spans=[e.operand.span]))

    def _paint_range(self, e: ast.Paint, exprs: list[int]):
        """A warning for a constant colour outside 0..1: paint(255, 0, 0), written as
        bytes, drew a colour 255 times too bright, silently (a negative one, black)."""
        values = [self.exprs.constant(x) for x in exprs]
        # the constant ones, where others are computed: paint(255, 200 - 3*i, 120)
        known = [v for v in values if v is not None]
        # not finite: the render empties the instance and reports it as a runtime error
        if len(values) != 3 or not known or not all(math.isfinite(v) for v in known) \
                or all(0 <= v <= 1 for v in known):
            return
        shown = ", ".join("…" if v is None else f"{v:g}" for v in values)
        # each fault said: paint(2, -1, 0.5) said only "above 1"
        faults = ((["above 1 shades brighter than the light allows (from bytes 0..255, "
                    "divide by 255)"] if max(known) > 1 else [])
                  + (["a negative one is drawn as 0"] if min(known) < 0 else []))
        why = ("; " if max(known) > 1 else ": ") + "; ".join(faults)
        self.warn(e.head_span, f"paint({shown}): colours are fractions from 0 to 1{why}",
                  "paint-range")

    def ref(self, e: ast.Ref) -> int:
        if e.name in self.modules:
            return self.modules[e.name]
        if e.name in self.named:
            self.named_read.add(e.name)
            return self.named_ref(e.name, e.span)
        if e.name in FRACTAL_PRIMITIVES:
            names = FRACTAL_PRIMITIVES[e.name]
            self.error(e.span, f"'{e.name}' takes its argument{'' if len(names) == 1 else 's'}"
                               f": {e.name}({', '.join(names)}); or define '{e.name}' as a "
                               f"module or named expression", "arity")
            return self.primitive_node_for_errors()
        if e.name in PRIMITIVES:
            if e.name not in self.primitive_nodes:
                self.primitive_nodes[e.name] = self.add(Node(PRIMITIVE, name=e.name, span=e.span))
            return self.primitive_nodes[e.name]
        if e.name in self.ruleless:
            return self.primitive_node_for_errors()     # its declaration's error says why
        if e.name in self.params:
            what = f"'{e.name}' is a parameter; a CSG operand must be a module, a named " \
                   f"expression or a primitive"
        elif e.name in RESERVED:
            what = f"'{e.name}' is {RESERVED[e.name]}, not an operand"
        else:
            hint = did_you_mean(e.name, [*self.modules, *self.named, *PRIMITIVES])
            what = f"undefined name '{e.name}'{hint} (not a module, named expression or " \
                   f"primitive: {', '.join(PRIMITIVES)})"
            if below := self.source.defined_below(e.name, e.span[0]):
                what = f"undefined name '{e.name}'{below}"
        self.error(e.span, what, "undefined")
        return self.primitive_node_for_errors()

    def fractal(self, e: ast.Fractal) -> int:
        """A fractal primitive: one node per use, its arguments constants (the parameters
        the axiom alone assigns count; the bounds and the kernels take them as numbers)."""
        names = FRACTAL_PRIMITIVES[e.name]
        exprs = [self.expr(a) for a in e.args]
        if len(exprs) != len(names):
            self.error(e.span, f"'{e.name}' takes {len(names)} argument"
                               f"{'' if len(names) == 1 else 's'} ({', '.join(names)}), "
                               f"got {len(exprs)}", "arity")
            return self.primitive_node_for_errors()
        values = [self.exprs.constant(x) for x in exprs]
        if any(v is None for v in values):
            self.error(e.span, f"the arguments of '{e.name}' must be constants: numbers, pi, "
                               f"#define names and parameters that only the axiom assigns",
                       "fractal-arguments")
            return self.primitive_node_for_errors()
        why = check_arguments(e.name, values)
        if why is not None:
            self.error(e.span, why, "fractal-arguments")
            return self.primitive_node_for_errors()
        return self.add(Node(PRIMITIVE, name=e.name, exprs=exprs, span=e.span))

    def _unknown_number(self, name: str, used: int, hint: str) -> str:
        """What to say of an undefined name in arithmetic, read at expanded offset `used`:
        a macro defined below, else the guess `hint`, else for t, where it comes from."""
        below = self.source.defined_below(name, used)
        if name == "t" and not below and not hint:
            # the time an animation sets: only where the file assigns it
            return (" (`pcsg animate` sets t only where the axiom assigns it: write "
                    "'{t = 0} ...' there, and read t below)")
        return below or hint

    def _operand_kind(self, name: str) -> str | None:
        """What a CSG operand's name read as a number is (`move(N, 0, 0)`, N a named
        expression, was an "undefined name")."""
        if name in self.rules or name in self.ruleless:
            return "a module"
        return "a named expression" if name in self.named else None

    def primitive_node_for_errors(self) -> int:
        return self.add(Node(PRIMITIVE, name="sphere"))

    def named_ref(self, name: str, use_span) -> int:
        if name in self.named_nodes:
            return self.named_nodes[name]
        if name in self.named_building:
            cycle = self.named_building[self.named_building.index(name):] + [name]
            self.error(use_span, f"named expression '{name}' refers to itself through "
                                 f"{' → '.join(cycle)}; recursion must go through a module",
                       "named-recursion")
            return self.primitive_node_for_errors()
        self.named_building.append(name)
        node = self.csg(self.named[name].body)
        self.named_building.pop()
        self.named_nodes[name] = node
        return node


_EMPTY = __import__("numpy").zeros(0)


def _csg_children(n):
    if isinstance(n, ast.CsgOp):
        return [n.left, n.right]
    if isinstance(n, (ast.Transform, ast.Calc, ast.Paint, ast.Material)):
        return [n.operand]
    return []


def _csg_nodes(stmts):
    """Every node of the CSG expressions of the file: axiom, rules and named ones."""
    stack = [s.expr if isinstance(s, ast.Axiom) else s.body for s in stmts
             if isinstance(s, (ast.Axiom, ast.Rule, ast.Named))]
    while stack:
        n = stack.pop()
        yield n
        stack.extend(_csg_children(n))


def _assignments(stmts):
    """Every assignment in every calculation block of the file."""
    found = [a for n in _csg_nodes(stmts) if isinstance(n, ast.Calc) for a in n.assigns]
    return sorted(found, key=lambda a: a.span[0])


def _reads(stmts) -> set[str]:
    """Every name an expression of the file reads: selections, blocks' values, arguments
    and directives' values."""
    values = [s.selection for s in stmts if isinstance(s, ast.ModuleDecl)]
    for s in stmts:
        if isinstance(s, ast.Directive):
            for item in s.items:
                values += item.value.items if isinstance(item.value, ast.Tuple) else \
                    [item.value]
    for n in _csg_nodes(stmts):
        if isinstance(n, ast.Calc):
            values += [a.value for a in n.assigns]
        elif isinstance(n, (ast.Transform, ast.Paint, ast.Fractal)):
            values += n.args
    return set().union(*(names_in(v) for v in values if v is not None))


def build_graph(program: ast.Program, source, overrides: dict[str, float] | None = None) -> Graph:
    """Build the graph or raise PcsgError with every error found."""
    return _Builder(program, source, overrides or {}).build()
