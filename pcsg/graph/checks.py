"""Static checks over the cyclic graph (notation §7 and §9)."""
from __future__ import annotations

import functools
import math
from collections import Counter, deque

import numpy as np

from ..language import ast
from ..language.errors import Diagnostic, PcsgError
from ..language.names import FLAT_PRIMITIVES, FRACTAL_PRIMITIVES, PIXELS, UNION_ONLY_PRIMITIVES
from ..limits import DEEPEST_DEFAULT
from .expr import PIXELS_ONLY_IN_SELECTIONS
from ..trace import vm
from .derive import Deriver, names_in
from .model import (CALC, DIFFERENCE, INTERSECTION, MATERIAL, PAINT, PRIMITIVE, SELECT, TRANSFORM,
                    UNION, Graph)

PROBE_NODES = 2_000           # node visits of the contraction probe (every compile runs it)
PROBE_REPEATS = 8             # a non-contracting cycle taken this often on one path is reported


def reachable(graph: Graph, start: int | None = None) -> list[bool]:
    """Per node, whether the walk from `start` (the axiom's root) reaches it."""
    start = graph.root if start is None else start
    seen = [False] * len(graph.nodes)
    stack = [start]
    seen[start] = True
    while stack:
        for c in graph.nodes[stack.pop()].children:
            if not seen[c]:
                seen[c] = True
                stack.append(c)
    return seen


def run_checks(graph: Graph) -> list[Diagnostic]:
    """Errors raise PcsgError; warnings are returned (and added to graph.warnings)."""
    errors = (definite_assignment(graph) + flat_under_solid_operators(graph)
              + pixels_outside_selections(graph))
    if errors:
        raise PcsgError(errors)
    warnings = (unused_modules(graph) + unselected_rules(graph) + endless_cycles(graph)
                + non_contracting_cycles(graph) + glass_on_shells(graph))
    graph.warnings.extend(warnings)
    return warnings


CHECK_STATES = 2_000     # the derivation `pcsg check` follows: under 0.1 s, however large


def derivation_faults(graph: Graph, max_states: int = CHECK_STATES):
    """(errors, warnings) of the derivation's first `max_states` states, for `pcsg
    check`: the compile knows the initial values, but not what the selections make of
    them. An invalid selection is an error (notation §6, with the module and its
    parameter values); a render empties such an instance and says so, stats and expand
    fail on it. A state met again on its own path is a warning: that derivation never
    ends (`{c = 1/0}`, or a count that never reaches its end: stats failed, check said
    ok), and a render draws it to pixel size only. Deeper than the budget, in a graftal
    (warned of already) or where `pixels` ends the derivation, nothing is said.
    The warnings begin with the transformations that empty their instances (map_faults)."""
    from .stats import count_primitives
    from .volumes import graftal_nodes
    faults: set = set()
    try:
        count_primitives(graph, max_states, faults=faults)
    except PcsgError as e:
        errors = [d for d in e.diagnostics if d.code == "selection"]
        # a graftal, or a system whose selections read `pixels` (+inf here), ends where
        # the render's pixels end it, a graftal only where its maps contract
        if errors or graph.pixels >= 0:
            return errors, map_faults(graph, faults)
        if graftal_nodes(graph):
            return [], map_faults(graph, faults) + _unbounded_graftal(graph)
        repeats = [Diagnostic("warning", d.message + ": a render refines it to pixel size "
                              "where its transformations shrink it, else to --max-depth",
                              d.span, d.source, code=d.code)
                   for d in e.diagnostics if d.code == "repeats"]
        return [], map_faults(graph, faults) + (repeats or _runaway(graph))
    return [], map_faults(graph, faults) + _deeper_than_a_render_follows(graph)


def _deeper_than_a_render_follows(graph: Graph) -> list[Diagnostic]:
    """A derivation that ends, but deeper than the levels a render follows without
    --max-depth (it is cut there): render's warning, said by `check` too (it said ok of
    5,000 levels, where only a count past 10,000 was warned of: QA). Its depth from the
    memoised walk the render takes, only where the check's own derivation went deep."""
    from ..recursion import recursion_limit
    from .bounds import DoesNotContract, TooManyStates, _memoised_walk, deep_derivation
    from .stats import MAX_LEVELS
    if graph.pixels >= 0:
        return []           # +inf here: the render's pixels end it
    stopped = _from_axiom(graph)
    if stopped is None or not stopped.deep:
        return []
    try:
        with recursion_limit(20 * MAX_LEVELS):
            _, deepest, ends = _memoised_walk(graph, None, False)
    except (TooManyStates, DoesNotContract, PcsgError):
        return []           # too many states to tell: the render says it, as it walks
    if not ends or deepest <= DEEPEST_DEFAULT:
        return []
    return [deep_derivation(graph, deepest, stopped.diagnostic.span)]


def map_faults(graph: Graph, faults: set) -> list[Diagnostic]:
    """`check`'s word for the transformations that empty their operand, singular or not
    finite (notation §4), as render's bounding walk says it: in every instance where the
    arguments are constant (constant_map_warning), else "in some instances", for those
    that the derivation check follows met (`faults`: (kind, T-node), count_primitives').
    A parameter set by a block below the axiom's head is no constant (`{d = 0} S ∪ cube`,
    `S → scale(1, d, 1) sphere`): check said nothing where render warned."""
    from .bounds import fault_warnings
    found = fault_warnings(graph, graph, [(k, 0, n) for k, n in sorted(faults)],
                           counted=False)
    met = {n for _, n in faults}
    live = reachable(graph)
    return found + [d for i in range(len(graph.nodes)) if live[i] and i not in met
                    if (d := constant_map_warning(graph, i)) is not None]


def _unbounded_graftal(graph: Graph) -> list[Diagnostic]:
    """The render's warning for a graftal whose maps do not contract (bounds.bound), from
    the same walk: a few rounds of its states' boxes, 50 ms where it does not contract."""
    from ..recursion import recursion_limit
    from .bounds import (DoesNotContract, TooManyStates, _memoised_walk, not_contracting,
                         voids_of)
    from .stats import MAX_LEVELS
    try:
        with recursion_limit(20 * MAX_LEVELS):
            _memoised_walk(graph, None, False)
    except DoesNotContract as found:
        return not_contracting(graph, found, bool(voids_of(graph, found.nodes)))
    except (TooManyStates, PcsgError):
        pass                # too many states to tell, or the render's to report
    return []


def _runaway(graph: Graph) -> list[Diagnostic]:
    """A derivation that counts away from its end (`R if(i < 8, 2, 1)` with `{i = i - 1}`
    on a cycle that shrinks): within the check's states, but deeper than ENDS_LEVELS.
    A graftal's or a `pixels` system's the render ends by design: the caller leaves them."""
    try:
        stopped = _from_axiom(graph)
    except PcsgError:
        return []       # an invalid selection, which the caller reports
    if stopped is None or not stopped.deep:
        return []
    found = stopped.diagnostic
    return [Diagnostic("warning", f"{found.message}: a count running away from its end? a "
                       f"render refines it to pixel size or --max-depth", found.span,
                       found.source, code="runaway")]


def constant_map_warning(graph: Graph, i: int) -> Diagnostic | None:
    """The warning for node i if it is a transformation or paint of constant arguments
    that empties its operand; None otherwise (render's bounding walk says it so too, not
    "in some instances")."""
    from .bounds import FAULTS
    from .linear import singular
    from ..trace.transforms import matrix
    n = graph.nodes[i]
    if n.kind not in (TRANSFORM, PAINT):
        return None
    args = [graph.exprs.constant(e) for e in n.exprs]
    if any(a is None for a in args):
        return None
    if n.kind == PAINT:         # a colour that is not a number: the tracer empties it
        if all(math.isfinite(a) for a in args):
            return None
        return _diag(graph, "warning", "the colour of this paint is not finite: it empties "
                     "its operand", n.span, FAULTS[0][1])
    with np.errstate(all="ignore"):
        m = matrix(n.name, args)
    kind = 0 if not np.isfinite(m).all() else 1 if singular(m) else None
    if kind is None:
        return None
    what, code = FAULTS[kind]
    if kind == 0 and all(math.isfinite(a) for a in args):
        what = "the axis or the normal of this transformation is zero"
    return _diag(graph, "warning", f"{what}: it empties its operand", n.span, code)


def _diag(graph, severity, message, span, code, notes=()):
    return Diagnostic(severity, message, span, graph.source, list(notes), code)


def _first_var(node, name):
    """The first read of `name` in an arithmetic AST, for its position."""
    return next(iter(ast.reads_of(node, name)), node)


def definite_assignment(graph: Graph) -> list[Diagnostic]:
    """Parameters read before they are assigned on some path from the axiom.
    must[n] = ∩ over edges p→n of (must[p] ∪ assigned(p)): a forward data flow,
    iterated to its greatest fixed point over the cycles. Sets are bitmasks."""
    nodes, table, names = graph.nodes, graph.exprs, graph.param_names
    everything = (1 << len(names)) - 1
    must = [everything] * len(nodes)
    given = 1 << graph.pixels if graph.pixels >= 0 else 0   # by the tracer
    must[graph.root] = given
    live = reachable(graph)
    work = deque([graph.root])
    while work:
        i = work.popleft()
        n = nodes[i]
        out = must[i]
        if n.kind == CALC:
            for slot in n.targets:
                out |= 1 << slot
        for c in n.children:
            new = must[c] & out if c != graph.root else given
            if new != must[c]:
                must[c] = new
                work.append(c)
    errors = []
    grouped = _OperandBlocks(graph)
    for i, n in enumerate(nodes):
        if not live[i]:
            continue
        have = must[i]
        for k, expr in enumerate(n.exprs):
            for name in sorted(table.reads(expr)):
                if not have >> graph.params[name] & 1:
                    var = _first_var(graph.expr_ast[expr], name)
                    block = grouped.block(graph.params[name], i)
                    notes = [] if block is None else [(
                        block, f"'{name}' is assigned here for this operand only: a block "
                               f"applies to the operand after it; '{{...}} (A ∪ B)' gives it "
                               f"to both")]
                    errors.append(_diag(graph, "error", f"parameter '{name}' may be read before it "
                                        f"is assigned: some path from the axiom reaches this "
                                        f"without assigning it", var.span, "unassigned", notes))
            if n.kind == CALC:
                have |= 1 << n.targets[k]
    return errors


class _OperandBlocks:
    """The calculation block that assigns a parameter as one operand of a CSG operator
    (`{x = 0} ground ∪ ROW`, where the block meant for both binds to `ground`), for a
    read of it in a sibling operand's derivation: the likely slip where that read finds
    it unassigned. Worked out only where such an error is."""

    def __init__(self, graph: Graph):
        self.graph = graph
        self._reach: dict[int, list[bool]] = {}
        self._blocks = None

    def block(self, slot: int, reader: int):
        if self._blocks is None:
            self._blocks = self._find()
        for span, siblings in self._blocks.get(slot, ()):
            if any(self._reached(s)[reader] for s in siblings):
                return span
        return None

    def _find(self) -> dict[int, list]:
        g, names = self.graph, self.graph.param_names
        out: dict[int, list] = {}
        for n in g.nodes:
            if n.kind not in (UNION, INTERSECTION, DIFFERENCE):
                continue
            for c in n.children:
                block = g.nodes[c]
                if block.kind != CALC or block.span is None:
                    continue
                siblings = [s for s in n.children if s != c]
                for slot, expr in zip(block.targets, block.exprs):
                    entry = (block.span, siblings)
                    # a first value ({x = 0}) before an update ({x = x + 1})
                    if names[slot] in g.exprs.reads(expr):
                        out.setdefault(slot, []).append(entry)
                    else:
                        out.setdefault(slot, []).insert(0, entry)
        return out

    def _reached(self, start: int) -> list[bool]:
        if start not in self._reach:
            self._reach[start] = reachable(self.graph, start)
        return self._reach[start]


def pixels_outside_selections(graph: Graph) -> list[Diagnostic]:
    """`pixels` has a value only while a selection is evaluated (the tracer computes it
    for the instance being selected); anywhere else it would be a stale number."""
    if graph.pixels < 0:
        return []
    errors = []
    for n in graph.nodes:
        if n.kind == SELECT:
            continue
        for expr in n.exprs:
            if PIXELS in graph.exprs.reads(expr):
                var = _first_var(graph.expr_ast[expr], PIXELS)
                errors.append(_diag(graph, "error", PIXELS_ONLY_IN_SELECTIONS, var.span,
                                    "pixels"))
    return errors


def flat_under_solid_operators(graph: Graph) -> list[Diagnostic]:
    """tri1/tri2 have no inside and a fractal gives only its first surface, so nothing
    below ∩ or \\ may derive them."""
    nodes = graph.nodes
    flat_below: dict[int, int | None] = {}

    def find_flat(start):
        seen, stack = {start}, [start]
        while stack:
            i = stack.pop()
            if nodes[i].kind == PRIMITIVE and nodes[i].name in UNION_ONLY_PRIMITIVES:
                return i
            for c in nodes[i].children:
                if c not in seen:
                    seen.add(c)
                    stack.append(c)
        return None

    errors = []
    for i, n in enumerate(nodes):
        if n.kind not in (INTERSECTION, DIFFERENCE):
            continue
        for side, c in enumerate(n.children):
            if c not in flat_below:
                flat_below[c] = find_flat(c)
            f = flat_below[c]
            if f is not None:
                op = "∩" if n.kind == INTERSECTION else "\\"
                prim = nodes[f].name
                what = ("is flat (it has no inside)" if prim in FLAT_PRIMITIVES else
                        "is a fractal (traced to its first surface only)")
                kinds = "flat" if prim in FLAT_PRIMITIVES else "fractal"
                errors.append(_diag(graph, "error", f"'{prim}' {what} but the "
                                    f"{'left' if side == 0 else 'right'} operand of '{op}' derives "
                                    f"it; {kinds} primitives may only be combined by '∪'",
                                    n.edge_spans[side], "flat-primitive",
                                    # where the operand is not the primitive as written
                                    [(nodes[f].span, f"'{prim}' used here")]
                                    if nodes[f].span and nodes[f].span != n.edge_spans[side]
                                    else []))
    return errors


def glass_on_shells(graph: Graph) -> list[Diagnostic]:
    """A material that lets light through (transmit > 0) on a fractal or a graftal: both
    are traced to their first surface only, so nothing passes through them and they are
    drawn opaque (trace/walk.py, HIT_SHELL). A material below it decides for what is below;
    under ∩ or \\ a graftal's volume is a solid's interval, and lets light through."""
    from .volumes import graftal_nodes
    nodes = graph.nodes
    graftals = set(graftal_nodes(graph))
    out = []
    for i, n in enumerate(nodes):
        if n.kind != MATERIAL or graph.scene.materials.get(n.name, {}).get("transmit", 0) <= 0:
            continue
        seen, stack, found = set(n.children), list(n.children), None
        while stack and found is None:
            j = stack.pop()
            if (nodes[j].kind == PRIMITIVE and nodes[j].name in FRACTAL_PRIMITIVES) or \
                    j in graftals:
                found = j
            elif nodes[j].kind not in (MATERIAL, INTERSECTION, DIFFERENCE):
                for c in nodes[j].children:
                    if c not in seen:
                        seen.add(c)
                        stack.append(c)
        if found is not None:
            what = (f"the fractal '{nodes[found].name}'" if nodes[found].kind == PRIMITIVE
                    else f"the graftal '{nodes[found].name}'")
            out.append(_diag(graph, "warning", f"material '{n.name}' lets light through "
                             f"(transmit), but {what} is traced to its first surface only: "
                             f"nothing passes through it, and it is drawn opaque", n.span,
                             "opaque", [(nodes[found].span, f"'{nodes[found].name}' here")]
                             if nodes[found].span else []))
    return out


def unused_modules(graph: Graph) -> list[Diagnostic]:
    live = reachable(graph)
    return [_diag(graph, "warning", f"module '{name}' is never used: the axiom does not reach it",
                  graph.nodes[i].span, "unused")
            for name, i in graph.modules.items() if not live[i]]


def unselected_rules(graph: Graph) -> list[Diagnostic]:
    """Rules a selection as written can never name: a number (`S 1` with two rules), or
    an if() whose every branch is one (`if(c > 0, 2, 1)` with a rule 3). Not a selection
    that reads a parameter the axiom sets (`S style`: --set style=1 picks the other),
    nor the rule that finishes the module's instances at pixel size."""
    from .terminating import terminating_rules
    finishing = None            # worked out where a selection is written as numbers only
    out = []
    for i, s in enumerate(graph.nodes):
        if s.kind != SELECT or len(s.children) < 2:
            continue
        named = _named_rules(graph, i)
        if named is None:
            continue
        finishing = terminating_rules(graph) if finishing is None else finishing
        for k in range(1, len(s.children) + 1):
            if k not in named and k - 1 != finishing.get(i):
                out.append(_diag(graph, "warning", f"rule {k} of '{s.name}' is never selected: "
                                 f"its selection only gives {_listed(sorted(named))}",
                                 s.edge_spans[k - 1], "unselected"))
    return out


def _named_rules(graph: Graph, i: int) -> set[int] | None:
    """The rule numbers S-node i's selection can give where it is written as numbers (a
    number, or an if() of numbers); None where it computes them."""
    picks = _branches(graph.expr_ast[graph.nodes[i].exprs[0]])
    if picks is None:
        return None
    return {int(vm.round_half_away(v)) for v in picks if math.isfinite(v)}


def _branches(node) -> set[float] | None:
    """The values an if() tree of constant leaves can give; None for anything else."""
    if isinstance(node, ast.Num):
        return {float(node.value)}
    if isinstance(node, ast.Call) and node.name == "if" and len(node.args) == 3:
        a, b = _branches(node.args[1]), _branches(node.args[2])
        return None if a is None or b is None else a | b
    return None


def _listed(values: list[int]) -> str:
    return " or ".join(map(str, values)) if values else "no rule"


def endless_cycles(graph: Graph) -> list[Diagnostic]:
    """A module that can reach itself along a cycle on which no parameter that its
    selection reads is assigned picks the same rule forever: it never terminates."""
    nodes, table, names = graph.nodes, graph.exprs, graph.param_names
    live = reachable(graph)
    component = components(graph)
    counters = _counters(graph, component)
    size = Counter(component)
    reads_parameters = functools.lru_cache(maxsize=None)(
        lambda i: _reads_parameters(graph, nodes[i]))
    named_rules = functools.lru_cache(maxsize=None)(lambda i: _named_rules(graph, i))
    out = []
    for m, s in enumerate(nodes):
        if s.kind != SELECT or not live[m] or table.uses_rand(s.exprs[0]):
            continue
        if size[component[m]] == 1 and m not in s.children:
            continue             # on no cycle: it cannot call itself
        if graph.pixels >= 0 and PIXELS in table.reads(s.exprs[0]):
            continue             # it ends where the instances become small enough
        reads = {graph.params[p] for p in table.reads(s.exprs[0])}
        # a module whose rule is fixed (one rule, a graftal's, or a number) recurs only as
        # far as the modules on its cycles let it: where one of them reads parameters, that
        # one's own check decides (S → T → S, where T's block counts down what S reads,
        # made T "a graftal"). A module that reads parameters is endless where they never
        # change on a cycle, whatever the modules between choose on the way round.
        fixed_rule = not reads_parameters(m)
        # a module between that reads a counter of the cycle (n = n - 1 and never set
        # afresh on it) ends it whatever m reads; one that reads a parameter the cycle
        # sets afresh ({d = 20000} ... {d = d - 1}) only delays the way round
        counted = counters[component[m]]
        closing = []             # (parent, child number) of edges that close such a cycle
        # within m's component: every way back to m runs through it (a chain of 3,000
        # modules walked all that lay below each one, 50 s)
        seen, stack = {m}, [m]
        while stack:
            i = stack.pop()
            n = nodes[i]
            if n.kind == CALC and i != m and reads & set(n.targets):
                continue         # this path changes what the selection reads
            if n.kind == SELECT and i != m and (
                    (fixed_rule and reads_parameters(i))
                    or {graph.params[p] for p in table.reads(n.exprs[0])} & counted):
                continue
            named = named_rules(i) if n.kind == SELECT else None
            for k, c in enumerate(n.children):
                if named is not None and k + 1 not in named:
                    continue     # a rule the selection never names: no cycle through it
                if c == m:
                    closing.append((i, k))
                elif c not in seen and component[c] == component[m]:
                    seen.add(c)
                    stack.append(c)
        if not closing or not (reads or _written(graph, s)):
            # no block can end a cycle whose selection reads no parameter: a graftal,
            # which `render` refines to pixel size where its maps contract (else
            # _unbounded_graftal warns), and `check` counts
            continue
        spans = sorted((nodes[p].edge_spans[k] for p, k in closing), key=lambda sp: sp[0])
        notes = [(sp, "another such cycle closes here") for sp in spans[1:]]
        if reads:
            what = ", ".join(sorted(names[r] for r in reads))
            message = (f"'{s.name}' can call itself here without changing {what}, which its "
                       f"selection reads: this cycle never terminates (group operands with "
                       f"parentheses, e.g. '{{...}} (A ∪ B)', if a calculation block should "
                       f"apply to all of them)")
        else:
            # read as written, folded to a constant: the axiom sets them once and nothing
            # on the cycle changes them (a decrement left out), not a graftal by design
            written = _written(graph, s)
            what = ", ".join(written)
            message = (f"'{s.name}' can call itself here and nothing changes {what}, which its "
                       f"selection reads (the axiom sets {'it' if len(written) == 1 else 'them'} "
                       f"once): this cycle never terminates; a block on it such as "
                       f"'{{{written[0]} = {written[0]} - 1}}' would end it")
        out.append(_diag(graph, "warning", message, spans[0], "endless", notes))
    if out and _axiom_ends(graph):
        # the cycles are there, but the derivation never takes them round (a module
        # reached only where its count is spent: B if(n > 0, ...) met with n = 0)
        return []
    return out


def _written(graph: Graph, s) -> list[str]:
    """The parameters a selection names as written (folded away where the axiom alone
    sets them)."""
    return sorted(n for n in names_in(graph.expr_ast[s.exprs[0]]) if n in graph.params)


def _axiom_ends(graph: Graph) -> bool:
    try:
        return _from_axiom(graph) is None
    except PcsgError:
        return False        # an invalid selection: check's to say


def _from_axiom(graph: Graph):
    """stats.derivation_end of the whole derivation, within check's states and
    ENDS_LEVELS levels."""
    from .stats import derivation_end
    state, h = Deriver(graph).initial()
    return derivation_end(graph, graph.root, state, h, CHECK_STATES, ENDS_LEVELS)


def _reads_parameters(graph: Graph, s) -> bool:
    """Whether S-node s's selection is written with parameters (folded to a constant or
    not: where nothing changes them, its own check says so). rand() alone is no such
    module: it is not checked itself, so a cycle through it must not stop the others'."""
    sel = s.exprs[0]
    return bool(graph.exprs.reads(sel)) or any(
        name in graph.params for name in names_in(graph.expr_ast[sel]))


def components(graph: Graph) -> list[int]:
    """The strongly connected component of each node (Tarjan's, without recursion): the
    nodes on the cycles through a node are its component."""
    nodes = graph.nodes
    n = len(nodes)
    index, low, comp = [-1] * n, [0] * n, [-1] * n
    on_stack, stack, counter, found = [False] * n, [], 0, 0
    for root in range(n):
        if index[root] >= 0:
            continue
        work = [(root, 0)]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack[root] = True
        while work:
            v, k = work[-1]
            children = nodes[v].children
            if k < len(children):
                work[-1] = (v, k + 1)
                w = children[k]
                if index[w] < 0:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    on_stack[w] = True
                    work.append((w, 0))
                elif on_stack[w]:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                while True:
                    w = stack.pop()
                    on_stack[w] = False
                    comp[w] = found
                    if w == v:
                        break
                found += 1
    return comp


def _counters(graph: Graph, component: list[int]) -> dict[int, set[int]]:
    """Per component, the parameter slots its C-nodes only update (`n = n - 1`, reading
    themselves) and never set afresh: counters that run one way round its cycles."""
    updated: dict[int, set[int]] = {}
    fresh: dict[int, set[int]] = {}
    names = graph.param_names
    for i, n in enumerate(graph.nodes):
        if n.kind != CALC:
            continue
        for slot, expr in zip(n.targets, n.exprs):
            reads_itself = names[slot] in graph.exprs.reads(expr)
            (updated if reads_itself else fresh).setdefault(component[i], set()).add(slot)
    return {c: updated.get(c, set()) - fresh.get(c, set())
            for c in set(component)}


def non_contracting_cycles(graph: Graph) -> list[Diagnostic]:
    # a parameter that overflows makes maps non-finite; those are handled, not warned about
    with np.errstate(all="ignore"):
        return _probe(graph)


def _least_scale(rel) -> float:
    """The smallest singular value of the linear map rel, or where that is below 1 a
    bound above it below 1 (the Frobenius norm bounds every singular value, the length of
    each column the smallest, and neither costs an SVD; most cycles contract well below
    1); 0 where rel is not finite: such a map empties the instance, so there is no
    cycle."""
    squares = rel * rel
    frobenius = np.sqrt(squares.sum())
    if not np.isfinite(frobenius):
        return 0.0
    if frobenius < 1 - 1e-9:
        return float(frobenius)
    # the shortest image of an axis bounds it too (the terrain's scale(0.5, 0.5, 1): the
    # Frobenius norm is 1.22, an axis shrinks to 0.5); an SVD cost 15 µs a cycle
    column = float(np.sqrt(squares.sum(axis=0).min()))
    if column < 1 - 1e-9:
        return column
    return float(np.linalg.svd(rel, compute_uv=False)[-1])


# the derivation from a repeating instance, followed to see whether it ends
# (the levels are the render's: deeper than that, a derivation that ends is cut at
# --max-depth's 64 by default, shallower it is drawn whole)
ENDS_STATES, ENDS_LEVELS = 2_000, DEEPEST_DEFAULT


def _ends_from(graph: Graph, node: int, state, h) -> bool:
    """A count that runs to its end (`R if(i < 8, 2, 1)` with `{i = i + 1}`: a row of
    boxes) ends what boxes and the level of detail could not, and was warned of as if
    they had to; one that never does (`{i = i - 1}`, or growth with `{c = c + 1}`), or
    not within ENDS_LEVELS, is still reported."""
    from .stats import ends_from
    return ends_from(graph, node, state, h, ENDS_STATES, ENDS_LEVELS)


def _relative(before, lin):
    """The map from an earlier instance's frame to a later one's."""
    return np.linalg.solve(before, lin) if np.linalg.det(before) != 0 else lin


def _spectral_radius(m) -> float:
    with np.errstate(all="ignore"):
        values = np.linalg.eigvals(m) if np.isfinite(m).all() else np.array([np.inf])
    return float(np.abs(values).max())


def _most_scale(rel) -> float:
    """The largest singular value of rel (where its Frobenius norm, which bounds it, is
    over 1: most cycles shrink in every direction and cost no SVD)."""
    frobenius = float(np.sqrt((rel * rel).sum()))
    if not frobenius > 1 + 1e-9:
        return frobenius
    return float(np.linalg.svd(rel, compute_uv=False)[0])


def _probe(graph: Graph) -> list[Diagnostic]:
    """Walk the derivation for a while with real parameter values; a module instance
    nested PROBE_REPEATS times in itself with transformations that shrink it in no
    direction (smallest singular value ≥ 1 between successive instances: moves,
    rotations, growth), or that grow it over the run (the spectral radius of the run's
    map above 1: scale(1.5, 0.5, 0.5), whose bounds reach 1e12 and whose picture, framed
    to them, came out empty), is reported where the derivation from there is not seen to
    end, since neither hyper-bounding boxes nor the pixel-size level of detail can cut it. A cycle that shrinks along some axes only (the terrain's
    scale(0.5,0.5,1)) is not: its boxes narrow along those, and whether the probe's
    few thousand visits went deep enough to see it repeat eight times was a matter of
    the order it walked in (the terrain was reported at cnt 12, not at 8 to 11)."""
    d = Deriver(graph)
    nodes = graph.nodes
    reported: dict[int, Diagnostic] = {}
    budget = [PROBE_NODES]
    state, h = d.initial()
    # stack items: (node, state, hash, world-from-local linear map, {module: (map, repeats,
    # map where the run began, whether its derivation was seen to end)}, edge). An instance
    # below one whose derivation ends ends too: a row of 800 followed its rest from every
    # instance, 7.8 s of every check
    stack = [(graph.root, state, h, np.eye(3), {}, None)]
    while stack and budget[0] > 0:
        i, state, h, lin, seen, edge = stack.pop()
        budget[0] -= 1
        n = nodes[i]
        try:
            if n.kind == SELECT:
                prev = seen.get(i)
                repeats, first = 0, lin
                ended = prev is not None and prev[3]
                if prev is not None:
                    rel = _relative(prev[0], lin)
                    least = _least_scale(rel)
                    grows = least < 1 - 1e-9 and _most_scale(rel) > 1 + 1e-9
                    repeats = prev[1] + 1 if grows or not least < 1 - 1e-9 else 0
                    first = prev[2] if repeats else lin
                    if grows and repeats >= PROBE_REPEATS:
                        # a turn with an uneven scale, or a shear, grows one direction per
                        # cycle and still shrinks every one in the long run: the spectral
                        # radius of the run's whole map decides (rotz(90) scale(1.5, 0.5,
                        # 0.5) is 0.75 in x and y per two; rotz(30) of it 0.866 per one)
                        most = _spectral_radius(_relative(first, lin))
                        grows = most > 1 + 1e-9
                    if repeats >= PROBE_REPEATS and i not in reported and edge is not None \
                            and (grows or not least < 1 - 1e-9) and not ended:
                        ended = _ends_from(graph, i, state, h)
                        if not ended:
                            how = (f"that grow it in some direction (by {most:.3g} over "
                                   f"the {repeats} cycles followed):" if grows else
                                   f"that shrink it in no direction (each cycle scales it "
                                   f"by {least:.3g} or more, in the {repeats} followed):")
                            reported[i] = _diag(
                                graph, "warning", f"'{n.name}' calls itself here, instance "
                                f"in instance, through transformations {how} bounding "
                                f"boxes and the level of detail cannot stop it, and its "
                                f"derivation does not end within {ENDS_LEVELS:,} levels from "
                                f"here", edge, "non-contracting")
                seen = {**seen, i: (lin, repeats, first, ended)}
                r = d.select(i, state, h)
                stack.append((n.children[r], state, d.edge(h, i, r), lin, seen, n.edge_spans[r]))
                continue
            if n.kind == CALC:
                state = d.calc(i, state, h)
            elif n.kind == TRANSFORM:
                lin = lin @ d.matrix(i, state, h)[:3, :3]
            for k, c in enumerate(n.children):
                child_h = d.edge(h, i, k) if len(n.children) > 1 else h
                stack.append((c, state, child_h, lin, seen, n.edge_spans[k]))
        except PcsgError:
            continue     # runtime errors are the renderer's to report, not a static check's
    return list(reported.values())
