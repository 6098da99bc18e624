"""Which parameters can change what a node derives (its selections), so that
memoised walks key on those alone and not on the whole parameter state."""
from __future__ import annotations

import functools

from .model import CALC, SELECT, TRANSFORM, Graph

RAND = "<rand>"     # stands for the instance hash: a rand() decides a selection


def structural_params(graph: Graph, geometry: bool = False, selections: bool = True
                      ) -> list[frozenset]:
    """For each node, the parameters (and RAND) whose values on entry decide its
    derivation: its selections (unless not `selections`: a walk that takes every rule
    of each selection), and with `geometry` also its transformations."""
    table = graph.exprs
    nodes = graph.nodes
    rel = [frozenset()] * len(nodes)
    # each expression's reads once: the rounds below ask again until nothing changes (the
    # terrain's 947 asks walked its expression trees 37 000 steps, 5 ms of every render)
    seen: dict[int, frozenset] = {}

    def reads(expr):
        r = seen.get(expr)
        if r is None:
            r = seen[expr] = table.reads(expr) | ({RAND} if table.uses_rand(expr) else set())
        return r

    changed = True
    while changed:          # monotone over a finite lattice: ends
        changed = False
        for i, n in enumerate(nodes):
            live = set()
            for c in n.children:
                live |= rel[c]
            if n.kind == SELECT and selections:
                live |= reads(n.exprs[0])
            elif n.kind == TRANSFORM and geometry:
                for e in n.exprs:
                    live |= reads(e)
            elif n.kind == CALC:
                names = graph.param_names
                for slot, expr in reversed(list(zip(n.targets, n.exprs))):
                    if names[slot] in live:
                        live.discard(names[slot])
                        live |= reads(expr)
            new = frozenset(live)
            if new != rel[i]:
                rel[i] = new
                changed = True
    return rel


def drawn_params(graph: Graph) -> frozenset:
    """The parameters that can hold a value drawn from rand(), with a seed or without:
    assigned from an expression that calls it or that reads such a parameter, in any
    block, whatever the order the blocks run in (so a superset)."""
    table, names = graph.exprs, graph.param_names
    # each expression's tree walked once, not again at every round (the terrain's 233
    # assignments: 0.8 ms against 1.0 ms)
    assigned = [(names[slot], table.draws(expr), table.reads(expr)) for n in graph.nodes
                if n.kind == CALC for slot, expr in zip(n.targets, n.exprs)]
    drawn: set = set()
    changed = True
    while changed:          # grows within the finite set of names: ends
        changed = False
        for name, draws, reads in assigned:
            if name not in drawn and (draws or not drawn.isdisjoint(reads)):
                drawn.add(name)
                changed = True
    return frozenset(drawn)


class StateKey:
    """Memo keys: a node and the values of only those parameters that can change what it
    derives (bytes, so that nan equals nan), plus the instance hash if a rand() decides.
    `random`: some node's key holds the instance hash or a parameter drawn from rand(),
    so that its instances' states are likely all different (the terrain's heights)."""

    def __init__(self, graph: Graph, geometry: bool = False, selections: bool = True):
        import numpy as np
        rel = structural_params(graph, geometry, selections)
        self.rand = [RAND in r for r in rel]
        self._graph, self._rel = graph, rel
        slots = [sorted(graph.params[p] for p in r if p != RAND) for r in rel]
        self.slots = [np.array(x, dtype=np.int64) for x in slots]
        self.masks = [sum(1 << i for i in x) for x in slots]

    @functools.cached_property
    def random(self) -> bool:
        """Asked by the memoised bounding walk only: stats and check key their counts
        with a StateKey too, and never need the drawn parameters' fixed point."""
        drawn = drawn_params(self._graph)
        return any(RAND in r or not drawn.isdisjoint(r) for r in self._rel)

    def __call__(self, node: int, state, h: int) -> tuple:
        return (node, state.values[self.slots[node]].tobytes(), state.assigned & self.masks[node],
                h if self.rand[node] else 0)
