"""Which C-nodes and paint nodes the first-hit walks may pass and leave to a hit
(trace/deferred.py): those on a chain of T-, paint and material nodes that ends at a
primitive, so that nothing between them and the surface branches, selects or reads
what they compute. A paint node qualifies unless its colour is constant; a C-node
when no T-node after it reads a parameter it assigns (only paint may read its
results) and no other C-node follows it."""
from __future__ import annotations

import numpy as np

from ..language.names import FRACTAL_PRIMITIVES
from ..trace.vm import LOAD
from .model import CALC, MATERIAL, PAINT, PRIMITIVE, TRANSFORM, Graph


def deferrable(graph: Graph, vm: dict, fixed: np.ndarray, starts: np.ndarray,
               children: np.ndarray) -> np.ndarray:
    """int8 per node: 1 where the walks may pass it (see above). `vm`: the expressions'
    code before operand fusion; `starts`, `children`: the flat graph's."""
    nodes = graph.nodes
    code = np.asarray(vm["code"], dtype=np.int64).reshape(-1, 2)

    def reads(i: int) -> set:
        out = set()
        for e in nodes[i].exprs:
            rows = code[vm["start"][e]:vm["end"][e]]
            out.update(rows[rows[:, 0] == LOAD, 1].tolist())
        return out

    defer = np.zeros(len(nodes), dtype=np.int8)
    for i, node in enumerate(nodes):
        if not (node.kind == CALC or (node.kind == PAINT and not fixed[i])):
            continue
        chain = []
        j = int(children[starts[i]])
        while nodes[j].kind in (TRANSFORM, PAINT, MATERIAL):
            chain.append(j)
            j = int(children[starts[j]])
        if nodes[j].kind != PRIMITIVE or nodes[j].name in FRACTAL_PRIMITIVES:
            continue
        if node.kind == CALC:
            assigned = set(node.targets)
            if any(nodes[c].kind == TRANSFORM and not fixed[c] and reads(c) & assigned
                   for c in chain):
                continue
        defer[i] = 1
    return defer
