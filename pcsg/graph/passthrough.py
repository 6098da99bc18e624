"""The graph as the bounding walk needs it: without the nodes that cannot change a box.

A paint or material node only colours, and so does a C-node on a chain of T-, paint and
material nodes down to a primitive whose T-nodes read none of what it assigns
(graph/defer.py's rule). Each instance of such a node has its child's box, so the walk
that visits every instance (trace/boxwalk.py) may step over it: the terrain's final
triangles are an S-node, a C-node (the colour from the heights), a paint node, a matrix
and the triangle, and two of the five visits of each of its 33 million final instances
at order 12 go. None of these nodes adds to an instance's hash (one child), selects or
counts a level, so the walk sees the same instances.

Stepped over only where the child has no other parent, so that the child's hyper box,
filled in after the walk as the skipped node's, holds that node's instances and no
others: the same boxes as a walk through it. Operators keep their operands as written:
the instance table names each operand's node as its entry's owner."""
from __future__ import annotations

import dataclasses

import numpy as np

from .defer import colours_only
from .model import CALC, MATERIAL, OPERATORS, PAINT, TRANSFORM, Graph


def without_passable(graph: Graph) -> tuple[Graph, dict[int, int]]:
    """The graph whose edges from nodes other than operators step over the passable
    nodes (which stay in the node list, so that every node keeps its index), and node ->
    the node it leads to, for fill_boxes."""
    nodes = graph.nodes
    parents = _parents(graph)
    skip = {i: nodes[i].children[0] for i in parents
            if _passable(graph, i) and parents.get(nodes[i].children[0]) == 1}
    # not between two T-nodes: the walk would compose two fixed maps that the tracer
    # keeps apart (graph/flat.py, _compose_fixed_chains) and never visit the lower one,
    # whose box stayed empty where the tracer enters it (`rotx(1) paint(...) move(...)
    # uscale(0.5) S` missed every ray of that operand)
    below_map = {c for i in parents if nodes[i].kind == TRANSFORM for c in nodes[i].children}
    for i in [i for i in skip if i in below_map and nodes[_past(skip, i)].kind == TRANSFORM]:
        del skip[i]
    if not skip:
        return graph, {}
    target = {i: _past(skip, i) for i in skip}
    out = [n if n.kind in OPERATORS.values() or not n.children else
           dataclasses.replace(n, children=[target.get(c, c) for c in n.children])
           for n in nodes]
    return dataclasses.replace(graph, nodes=out,
                               root=target.get(graph.root, graph.root)), target


def fill_boxes(boxes: np.ndarray, target: dict[int, int]) -> None:
    """Each stepped-over node's hyper box: the one of the node it leads to."""
    for i, t in target.items():
        boxes[i] = boxes[t]


def _parents(graph: Graph) -> dict[int, int]:
    """The edges into each node reachable from the root, from reachable nodes (fuse_runs
    leaves the runs it replaced in the list, unreached)."""
    count = {graph.root: 0}
    todo = [graph.root]
    while todo:
        for c in graph.nodes[todo.pop()].children:
            if c not in count:
                count[c] = 0
                todo.append(c)
            count[c] += 1
    return count


def _passable(graph: Graph, i: int) -> bool:
    kind = graph.nodes[i].kind
    return kind in (PAINT, MATERIAL) or (kind == CALC and colours_only(graph, i))


def _past(skip: dict[int, int], i: int) -> int:
    while i in skip:
        i = skip[i]
    return i
