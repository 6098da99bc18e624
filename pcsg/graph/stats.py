"""`pcsg stats`: node counts, parameters, modules, and the number of
primitives of the complete derivation, counted without expanding it."""
from __future__ import annotations

import math
from collections import Counter

import numpy as np

from ..language.errors import Diagnostic, PcsgError
from ..recursion import recursion_limit
from .cut import NO_VOLUME, VOLUME_NAMES, Cut
from .dependence import StateKey
from .derive import Deriver, readable
from .linear import map_fault
from .model import CALC, KIND_NAMES, OPERATORS, PRIMITIVE, SELECT, TRANSFORM, Graph

MAX_LEVELS = 10_000         # derivation levels (S-node nesting) before we call it endless
MAX_STATES = 2_000_000      # distinct (node, relevant state) pairs before giving up

# a derivation that never ends: one state on its own path again, or still going at the limit
# (or too many states to count)
ENDLESS = ("repeats", "endless", "states")
TOO_MANY = "too many different instances to count"


class Endless(Exception):
    def __init__(self, diagnostic: Diagnostic, deep: bool = False):
        self.diagnostic = diagnostic
        self.deep = deep        # past the levels it may follow (not its states)


def count_primitives(graph: Graph, max_states: int = MAX_STATES, cut: Cut | None = None,
                     faults: set | None = None) -> int:
    """Primitives in the complete derivation of the axiom (cut where `cut` says). With
    `faults`, a set, the maps met that empty their instances go into it as (kind,
    T-node), kind as graph/linear.py's map_fault gives it."""
    return sum(count_by_primitive(graph, max_states, cut, faults).values())


def ends_from(graph: Graph, node: int, state, h, max_states: int, max_levels: int) -> bool:
    """Whether the derivation from (node, state, h) ends within max_states states and
    max_levels levels (and without an invalid selection on the way)."""
    try:
        return derivation_end(graph, node, state, h, max_states, max_levels) is None
    except PcsgError:
        return False        # a selection that names no rule: check's to say, not this


def derivation_end(graph: Graph, node: int, state, h, max_states: int, max_levels: int):
    """None where the derivation from (node, state, h) ends within max_states states and
    max_levels levels, else the Endless that stopped it; PcsgError for an invalid
    selection on the way."""
    try:
        with recursion_limit(12 * max_levels + 1000):
            _Counter(graph, max_states, max_levels=max_levels).count(node, state, h, 0)
    except Endless as e:
        return e
    return None


def count_by_primitive(graph: Graph, max_states: int = MAX_STATES,
                       cut: Cut | None = None, faults: set | None = None) -> dict[str, int]:
    """Primitives of each kind in the complete derivation of the axiom (memoised on node
    and the parameters that can change its derivation). PcsgError if it never ends, or
    passes max_states distinct states (a system that draws its rules at random has one
    per instance: counting it costs about what deriving it does). With a cut
    (graph/cut.py), the derivation flatten.instances writes: S-node instances deeper than
    its depth end as the tracer ends them, a cut graftal instance as its volume."""
    # a cut at the deepest level the count follows ends its instances one level below it:
    # `expand -n 10000` counted past the limit, and wrote 50 million characters to refuse
    levels = MAX_LEVELS if cut is None else max(MAX_LEVELS, cut.depth + 2)
    counter = _Counter(graph, max_states, cut, max_levels=levels, faults=faults)
    try:
        with recursion_limit(12 * MAX_LEVELS + 1000):
            state, h = counter.d.initial()
            totals = counter.count(graph.root, state, h, 0)
        return {name: n for name, n in zip(counter.kinds, totals) if n}
    except Endless as e:
        raise PcsgError([e.diagnostic]) from None


class _Counter:
    def __init__(self, graph: Graph, max_states: int = MAX_STATES, cut: Cut | None = None,
                 max_levels: int = MAX_LEVELS, faults: set | None = None):
        self.g = graph
        self.max_states = max_states
        self.max_levels = max_levels
        self.cut = cut
        self.d = Deriver(graph)
        self.key = StateKey(graph)
        kinds = {n.name for n in graph.nodes if n.kind == PRIMITIVE}
        self.kinds = sorted(kinds | (set(VOLUME_NAMES.values()) if cut is not None else set()))
        self.unit = {k: tuple(int(k == j) for j in self.kinds) for k in self.kinds}
        self.none = (0,) * len(self.kinds)
        self.memo: dict = {}
        self.active: set = set()
        self.faults = faults                # count_primitives' faults

    def count(self, node_id: int, state, h: int, level: int) -> tuple:
        """Counts per primitive kind, in the order of self.kinds."""
        node = self.g.nodes[node_id]
        if node.kind == PRIMITIVE:
            return self.unit[node.name]
        key = self.key(node_id, state, h)
        if self.cut is not None:        # the levels down to the cut derive differently
            key = (key, min(level, self.cut.depth + 1))
        hit = self.memo.get(key)
        if hit is not None:
            return hit
        if key in self.active:
            raise Endless(self._endless(node_id, state, "the derivation never ends",
                                        "repeats with the same parameters", "repeats"))
        if node.kind == SELECT and level >= self.max_levels:
            # deep, or endless: a count that ends after 20 000 levels is not endless
            raise Endless(self._endless(
                node_id, state, f"the derivation goes deeper than {self.max_levels} "
                                f"levels", "is still being rewritten there"), deep=True)
        if node.kind == SELECT and len(self.memo) > self.max_states:
            # not the depth: the states its parameters take (rand() makes each instance
            # one); it said "deeper than 30 levels" of a system that ends at 30
            why = (f"; rand() makes each instance of '{node.name}' differ"
                   if self.key.rand[node_id] else "")
            raise Endless(Diagnostic(
                "error", f"{TOO_MANY}, more than {self.max_states:,}{why}", node.span,
                self.g.source, code="states"))
        self.active.add(key)
        if node.kind == SELECT:
            cut = self.cut is not None and level + 1 > self.cut.depth
            r = int(self.cut.term[node_id]) if cut else self.d.select(node_id, state, h)
            if r >= 0:
                total = self.count(node.children[r], state, self.d.edge(h, node_id, r),
                                   level + 1)
            elif self.cut.kind[node_id] == NO_VOLUME:
                total = self.none
            else:
                total = self.unit[VOLUME_NAMES[int(self.cut.kind[node_id])]]
        elif node.kind == CALC:
            total = self.count(node.children[0], self.d.calc(node_id, state, h), h, level)
        elif node.kind in OPERATORS.values():
            parts = [self.count(c, state, self.d.edge(h, node_id, i), level)
                     for i, c in enumerate(node.children)]
            total = tuple(map(sum, zip(*parts)))
        else:       # T, paint, material: one child, same instance
            if self.faults is not None and node.kind == TRANSFORM:
                with np.errstate(all="ignore"):
                    fault = map_fault(self.d.matrix(node_id, state, h))
                if fault is not None:
                    self.faults.add((fault, node_id))
            total = self.count(node.children[0], state, h, level)
        self.active.discard(key)
        self.memo[key] = total
        return total

    def _endless(self, node_id, state, lead, what, code="endless") -> Diagnostic:
        node = self.g.nodes[node_id]
        name = node.name if node.kind == SELECT else KIND_NAMES[node.kind]
        values = ", ".join(f"{k} = {readable(v)}" for k, v in state.items(self.g))
        return Diagnostic("error", f"{lead}: '{name}' {what} ({values or 'no parameters'})",
                          node.span, self.g.source, code=code)


# Python writes integers of up to 4,300 digits (sys.get_int_max_str_digits), as text and
# as JSON: Sierpinski's count at c=9999 has 6,020 digits, and stats failed to print it
PRINTABLE = 10 ** 4000


def _too_many(n: int, digits: int) -> str:
    """A count too long to write, by its size: its leading digits and its digits."""
    lead = n // 10 ** (digits - 3)
    return (f"about {lead / 100:.2f}e{digits - 1} primitives, a number of {digits:,} digits "
            f"(counted, but longer than pcsg writes one)")


def graph_stats(graph: Graph, count: bool = True) -> dict:
    kinds = Counter(KIND_NAMES[n.kind] for n in graph.nodes)
    out = {
        "file": graph.source.file,
        "nodes": len(graph.nodes),
        "node_kinds": {k: kinds.get(k, 0) for k in KIND_NAMES},
        "modules": {name: len(graph.nodes[i].children) for name, i in graph.modules.items()},
        # pixels has a slot, but no one assigns it: the tracer fills it
        "parameters": [p for p in graph.param_names if graph.params[p] != graph.pixels],
        "expressions": len(graph.exprs),
        "bytecode_instructions": int(len(graph.exprs.arrays()["code"])),
        "primitives": None,
        "primitives_by_kind": None,
    }
    from .volumes import bounding_volumes, graftal_nodes, report
    graftal = bool(graftal_nodes(graph))
    if count:
        out["endless"] = False      # always there: `d["endless"]` was a KeyError if counted
        try:
            by_kind = count_by_primitive(graph, MAX_STATES)
            total = sum(by_kind.values())
            if total >= PRINTABLE:
                out["count_digits"] = digits = math.floor(math.log10(total)) + 1
                out["not_counted"] = _too_many(total, digits)
            else:
                out["primitives"] = total
                out["primitives_by_kind"] = by_kind
        except PcsgError as e:
            # a derivation that never ends (a graftal's by design) is a valid system: the
            # tracer refines it to pixel size (notation §9); stats says why it has no count
            if not all(d.code in ENDLESS for d in e.diagnostics):
                raise
            # deeper than the count follows is not endless: a count of 30 000 levels ends
            out["endless"] = graftal or any(d.code == "repeats" for d in e.diagnostics)
            if not graftal:
                out["not_counted"] = e.diagnostics[0].message
    if graftal:
        out["bounding_volumes"] = report(bounding_volumes(graph))
    return out
