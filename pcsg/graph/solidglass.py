"""Glass made of overlapping parts, traced as one solid.

The graph tracer's union is the nearest surface of any operand: right for a ray that
starts outside every operand, where that surface is where the ray enters the union.
A ray that starts inside (one refracted into glass, a shadow ray that crossed a
surface) stops at the inner faces where the operands overlap: the picture showed a
lens where two glass balls overlap, and their shadow took the light through four
surfaces instead of two, where the reference (`--reference`, which combines the
intervals of the expanded primitives) shows one clear body (QA). The tracer evaluates
an `∩` or `\\` subtree as sorted interval lists, in which a union is the merged set
itself; so a union that glass is made of goes under a difference of one operand,
`\\(U)`, which is U, traced as intervals.

Only where that is cheap and safe: a union with no S-node below it (a fixed tree of at
most MAX_PRIMITIVES primitives; an interval list over a recursive operand walks every
instance the ray passes) and no flat triangle or fractal (they have no inside), that a
transmitting material reaches (below one, or one below it), in a system without rand(),
whose values hash the path of every instance through the new node. The outermost such
union is wrapped, once. A recursive glass object keeps the inner faces where its parts
overlap (README, "How the tracer works")."""
from __future__ import annotations

from dataclasses import replace

from ..language.names import UNION_ONLY_PRIMITIVES
from ..trace.vm import RAND
from .model import DIFFERENCE, INTERSECTION, MATERIAL, PRIMITIVE, SELECT, UNION, Graph, Node

MAX_PRIMITIVES = 64


def glass_unions_as_solids(graph: Graph) -> Graph:
    """`graph` with the unions that glass is made of (above) each under a difference of
    one operand, or `graph` itself where there are none."""
    glass = {name for name, m in graph.scene.materials.items() if m.get("transmit", 0) > 0}
    if not glass or (graph.exprs.arrays()["code"][:, 0] == RAND).any():
        return graph
    nodes = graph.nodes
    size = _fixed_sizes(graph)
    wrapped: dict[int, int] = {}
    # (node, whether a transmitting material is above it), each pair once
    stack, seen = [(graph.root, False)], set()
    while stack:
        i, under_glass = stack.pop()
        if (i, under_glass) in seen or i in wrapped:
            continue
        seen.add((i, under_glass))
        n = nodes[i]
        if n.kind == MATERIAL:
            under_glass = n.name in glass
        if n.kind in (INTERSECTION, DIFFERENCE):
            continue        # traced as intervals already
        if n.kind == UNION and 0 < size[i] <= MAX_PRIMITIVES and \
                (under_glass or _glass_below(graph, i, glass)):
            wrapped[i] = len(nodes) + len(wrapped)
            continue
        stack += [(c, under_glass) for c in n.children]
    if not wrapped:
        return graph
    new = list(nodes) + [Node(DIFFERENCE, children=[i], edge_spans=[nodes[i].span],
                              span=nodes[i].span) for i in wrapped]
    for p, n in enumerate(nodes):
        if any(c in wrapped for c in n.children):
            new[p] = replace(n, children=[wrapped.get(c, c) for c in n.children])
    return replace(graph, nodes=new, root=wrapped.get(graph.root, graph.root))


def _fixed_sizes(graph: Graph) -> list[int]:
    """For each node, the primitives of its expansion where no S-node is below it and all
    are solids, else 0: a recursive operand, or a flat triangle or a fractal, which have
    no inside (union only, notation §5) and so would turn solid in an interval list."""
    nodes = graph.nodes
    size = [-1] * len(nodes)
    for root in range(len(nodes)):
        stack = [(root, False)]
        while stack:
            i, done = stack.pop()
            if size[i] >= 0:
                continue
            n = nodes[i]
            if n.kind == SELECT:
                size[i] = 0
            elif n.kind == PRIMITIVE:
                size[i] = 0 if n.name in UNION_ONLY_PRIMITIVES else 1
            elif done:
                parts = [size[c] for c in n.children]
                size[i] = 0 if 0 in parts else min(sum(parts), MAX_PRIMITIVES + 1)
            else:
                stack.append((i, True))
                stack += [(c, False) for c in n.children if size[c] < 0]
    return size


def _glass_below(graph: Graph, i: int, glass: set[str]) -> bool:
    stack, seen = [i], set()
    while stack:
        j = stack.pop()
        if j in seen:
            continue
        seen.add(j)
        n = graph.nodes[j]
        if n.kind == MATERIAL and n.name in glass:
            return True
        stack += n.children
    return False
