"""Which C-nodes and paint nodes the first-hit walks may pass and leave to a hit
(trace/deferred.py): those on a chain of T-, paint and material nodes that ends at a
primitive, so that nothing between them and the surface branches, selects or reads
what they compute. A paint node qualifies unless its colour is constant; a C-node
when no T-node after it reads a parameter it assigns (only paint may read its
results) and no other C-node follows it."""
from __future__ import annotations

import numpy as np

from ..language.names import FRACTAL_PRIMITIVES
from .model import CALC, MATERIAL, PAINT, PRIMITIVE, TRANSFORM, Graph


def deferrable(graph: Graph, fixed: np.ndarray) -> np.ndarray:
    """int8 per node: 1 where the walks may pass it (see above); fixed: the flat graph's
    constant paints."""
    defer = np.zeros(len(graph.nodes), dtype=np.int8)
    for i, node in enumerate(graph.nodes):
        if node.kind == CALC or (node.kind == PAINT and not fixed[i]):
            defer[i] = colours_only(graph, i)
    return defer


def colours_only(graph: Graph, i: int) -> bool:
    """Whether C-node or paint node i is followed by a chain of T-, paint and material
    nodes that ends at a primitive (not a fractal), none of whose T-nodes reads what a
    C-node i assigns: what it computes can then only colour that primitive."""
    nodes = graph.nodes
    assigned = frozenset(name for name, slot in graph.params.items()
                         if slot in nodes[i].targets) if nodes[i].kind == CALC else frozenset()
    j = nodes[i].children[0]
    while nodes[j].kind in (TRANSFORM, PAINT, MATERIAL):
        if nodes[j].kind == TRANSFORM and any(graph.exprs.reads(e) & assigned
                                             for e in nodes[j].exprs):
            return False
        j = nodes[j].children[0]
    return nodes[j].kind == PRIMITIVE and nodes[j].name not in FRACTAL_PRIMITIVES
