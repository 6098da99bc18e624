"""Walking the derivation in Python: parameter states, selections, T-node
matrices and instance hashes exactly as the tracer computes them."""
from __future__ import annotations

import math

import numpy as np

from ..language import ast
from ..language.errors import Diagnostic, PcsgError
from ..trace import vm
from ..trace.transforms import matrix
from . import hashes
from .flat import calc_programs
from .model import Graph, SELECT


class State:
    """Parameter values of one instance plus which of them are assigned."""
    __slots__ = ("values", "assigned")

    def __init__(self, values: np.ndarray, assigned: int):
        self.values, self.assigned = values, assigned

    def items(self, graph: Graph):
        for name, slot in graph.params.items():
            if self.assigned >> slot & 1 and slot != graph.pixels:
                yield name, float(self.values[slot])


def format_value(v: float) -> str:
    """A float as notation text that reads back bit-exactly."""
    if math.isnan(v):
        return "(0/0)"
    if math.isinf(v):
        return "(1/0)" if v > 0 else "(-1/0)"
    if v == int(v) and abs(v) < 1e16:
        return str(int(v)) if v != 0 or math.copysign(1, v) > 0 else "-0"
    return repr(v)


def readable(v: float) -> str:
    """A value in a message: 'nan' and 'inf' as such (format_value's '(0/0)' reads back
    as notation, and read as a message like a formula)."""
    return repr(v) if not math.isfinite(v) else format_value(v)


def too_deep(graph: Graph, node_id: int, levels: int) -> PcsgError:
    n = graph.nodes[node_id]
    return PcsgError([Diagnostic("error", f"the derivation is deeper than {levels} levels at "
                                 f"'{n.name}': give --max-depth N to cut it at depth N, as "
                                 f"`pcsg render` does", n.span, graph.source,
                                 code="endless")])


def names_in(node) -> set[str]:
    """The names an arithmetic AST reads."""
    found, stack = set(), [node]
    while stack:
        n = stack.pop()
        if isinstance(n, ast.Var):
            found.add(n.name)
        elif isinstance(n, ast.Call):
            stack.extend(n.args)
        elif isinstance(n, ast.Unary):
            stack.append(n.operand)
        elif isinstance(n, ast.Binary):
            stack.extend([n.left, n.right])
    return found


def _salt(h: int, slot: int) -> int:
    return hashes.salt(h, slot)


class Deriver:
    def __init__(self, graph: Graph):
        self.g = graph
        self.table = graph.exprs
        self._blocks = None
        self._fixed: dict[int, np.ndarray] = {}
        # the nodes whose arguments are all constants: matrix() keeps their maps
        self._constant_maps = {i for i, n in enumerate(graph.nodes)
                               if all(self.table.constant(e) is not None for e in n.exprs)}

    def initial(self) -> tuple[State, int]:
        """No parameter assigned yet, except `pixels`: +inf, as no camera sees the
        derivation here (every instance is large)."""
        values = np.full(len(self.g.params), np.nan)
        given = 0
        if self.g.pixels >= 0:
            values[self.g.pixels] = np.inf
            given = 1 << self.g.pixels
        return State(values, given), int(vm.ROOT_HASH)

    def value(self, expr: int, state: State, inst_hash: int) -> float:
        return float(self.table.evaluate(expr, state.values, inst_hash))

    def _draw(self, expr: int, state: State, h: int, slot: int) -> float:
        """Expression `expr` of an instance, its rand() salted with `slot`. A constant is
        its value without a call of the machine: most arguments and many selections
        are, and the checks' derivation probe of every compile made thousands of calls."""
        c = self.table.constant(expr)
        return c if c is not None else self.value(expr, state, _salt(h, slot))

    def select(self, node_id: int, state: State, h: int) -> int:
        """The 0-based rule index an S-node picks, or PcsgError naming module and parameters."""
        node = self.g.nodes[node_id]
        x = self._draw(node.exprs[0], state, h, 0)
        rule = hashes.select_rule(x, len(node.children))
        if rule == 0:
            raise PcsgError([self.selection_error(node_id, state, x)])
        return rule - 1

    def selection_error(self, node_id: int, state: State, x: float) -> Diagnostic:
        node = self.g.nodes[node_id]
        reads = names_in(self.g.expr_ast[node.exprs[0]])     # as written, not as folded
        values = ", ".join(f"{k} = {readable(v)}" for k, v in state.items(self.g) if k in reads)
        if math.isfinite(x):
            rule = vm.round_half_away(x)
            # rule 1e300 as such, not as its 301 digits (QA)
            named = f"{int(rule)}" if abs(rule) < 1e15 else readable(rule)
            what = f"names rule {named}, but '{node.name}' has rules 1..{len(node.children)}"
        else:
            what = "is not a finite number"
        # at the selection as written, so that one from a macro names the macro too
        return Diagnostic("error", f"the selection of module '{node.name}' gives {readable(x)}, "
                                   f"which {what} (with {values or 'no parameters read'})",
                          self.g.expr_ast[node.exprs[0]].span, self.g.source, code="selection")

    def calc(self, node_id: int, state: State, h: int) -> State:
        """The block as one program of the machine (flat.calc_programs: assignment i
        draws rand() with salt(h, i + 1)), so one call per block and not per
        assignment: the terrain's blocks have up to 25, and a render probes hundreds."""
        if self._blocks is None:
            a = self.table.arrays()
            code, start, end = calc_programs(self.g, a)
            self._blocks = code, a["consts"], start, end, np.empty(a["max_stack"])
        code, consts, start, end, stack = self._blocks
        node = self.g.nodes[node_id]
        values, assigned = state.values.copy(), state.assigned
        vm.eval_expr(code, consts, int(start[node_id]), int(end[node_id]), values,
                     np.uint64(int(h) & 0xFFFFFFFFFFFFFFFF), stack)
        for slot in node.targets:
            assigned |= 1 << slot
        return State(values, assigned)

    def args(self, node_id: int, state: State, h: int) -> list[float]:
        """T-node and paint arguments; the k-th draws rand() with salt(h, k + 1)."""
        return [self._draw(e, state, h, k + 1)
                for k, e in enumerate(self.g.nodes[node_id].exprs)]

    def matrix(self, node_id: int, state: State, h: int) -> np.ndarray:
        """The T-node's 4x4 matrix; one read-only array per node whose arguments are
        all constants."""
        m = self._fixed.get(node_id)
        if m is not None:
            return m
        node = self.g.nodes[node_id]
        m = matrix(node.name, self.args(node_id, state, h))
        if node_id in self._constant_maps:
            m.flags.writeable = False
            self._fixed[node_id] = m
        return m

    @staticmethod
    def edge(h: int, node_id: int, child: int) -> int:
        return hashes.edge_hash(h, node_id, child)

    def is_select(self, node_id: int) -> bool:
        return self.g.nodes[node_id].kind == SELECT
