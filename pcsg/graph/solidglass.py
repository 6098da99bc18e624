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
instance the ray passes), no flat triangle or fractal (they have no inside) and no rand()
(its values hash the path through the new node), that a transmitting material reaches
(below one, or one below it). The outermost such union is wrapped, once. Where a union
is not such a tree (a floor beside the glass that is a module or a triangle), its
operands that are go under a new union of their own first, in a system without rand()
(their numbers in the union change, which the hashes of every instance below it hold).
A recursive glass object keeps the inner faces where its parts overlap (README, "How the
tracer works")."""
from __future__ import annotations

from dataclasses import replace

from ..language.names import UNION_ONLY_PRIMITIVES
from .model import DIFFERENCE, INTERSECTION, MATERIAL, PRIMITIVE, SELECT, UNION, Graph, Node
from .regroup import draws_per_instance

MAX_PRIMITIVES = 64


def glass_unions_as_solids(graph: Graph) -> Graph:
    """`graph` with what glass is made of (above) under a difference of one operand, or
    `graph` itself where there is nothing to change."""
    glass = {name for name, m in graph.scene.materials.items() if m.get("transmit", 0) > 0}
    if not glass:
        return graph
    nodes = graph.nodes
    size, glass_below = _fixed_trees(graph, glass)
    # numbering a union's operands anew changes the hashes below them (rand(), the
    # instance table): only in a system without rand(), as regroup's splice
    regroup = not draws_per_instance(graph)

    def fixed_glass(i: int, under_glass: bool) -> bool:
        return 0 < size[i] <= MAX_PRIMITIVES and (under_glass or glass_below[i])

    whole: set[int] = set()                 # unions wrapped as they are
    grouped: dict[int, list[int]] = {}      # union -> its operands wrapped as one union
    # (node, whether a transmitting material is above it), each pair once
    stack, seen = [(graph.root, False)], set()
    while stack:
        i, under_glass = stack.pop()
        if (i, under_glass) in seen or i in whole:
            continue
        seen.add((i, under_glass))
        n = nodes[i]
        if n.kind == MATERIAL:
            under_glass = n.name in glass
        if n.kind in (INTERSECTION, DIFFERENCE):
            continue        # traced as intervals already
        if n.kind == UNION and fixed_glass(i, under_glass):
            whole.add(i)
            continue
        if n.kind == UNION and regroup and i not in grouped:
            # glass given operand by operand beside a floor that is a module, or many
            # primitives: `material(glass) A ∪ material(glass) B ∪ F` (QA)
            ops, total = [], 0
            for c in n.children:
                if c not in ops and fixed_glass(c, under_glass) and \
                        total + size[c] <= MAX_PRIMITIVES:
                    ops.append(c)
                    total += size[c]
            if len(ops) > 1:
                grouped[i] = ops
        stack += [(c, under_glass) for c in n.children if c not in grouped.get(i, ())]
    if not whole and not grouped:
        return graph
    new = list(nodes)

    def solid(children: list[int], span) -> int:
        new.append(Node(DIFFERENCE, children=children, edge_spans=[span], span=span))
        return len(new) - 1
    wrapper = {i: solid([i], nodes[i].span) for i in sorted(whole)}
    for i, ops in grouped.items():
        n = nodes[i]
        spans = dict(zip(n.children, n.edge_spans))
        new.append(Node(UNION, children=ops, edge_spans=[spans[c] for c in ops], span=n.span))
        one = solid([len(new) - 1], n.span)
        kept = [k for k, c in enumerate(n.children) if c not in ops or c == ops[0]]
        new[i] = replace(n, children=[one if n.children[k] == ops[0] else n.children[k]
                                      for k in kept],
                         edge_spans=[n.edge_spans[k] for k in kept])
    for p, n in enumerate(new[:len(nodes)]):
        if any(c in wrapper for c in n.children):
            new[p] = replace(n, children=[wrapper.get(c, c) for c in n.children])
    return replace(graph, nodes=new, root=wrapper.get(graph.root, graph.root))


def _fixed_trees(graph: Graph, glass: set[str]) -> tuple[list[int], list[bool]]:
    """For each node, the primitives of its expansion where no S-node is below it and all
    are solids, else 0: a recursive operand, or a flat triangle or a fractal, which have
    no inside (union only, notation §5) and so would turn solid in an interval list; and
    where it is such a tree, whether a transmitting material is in it."""
    nodes = graph.nodes
    size = [-1] * len(nodes)
    glass_below = [False] * len(nodes)
    for root in range(len(nodes)):
        stack = [(root, False)]
        while stack:
            i, done = stack.pop()
            if size[i] >= 0:
                continue
            n = nodes[i]
            if n.kind == SELECT or any(graph.exprs.uses_rand(e) for e in n.exprs):
                size[i] = 0
            elif n.kind == PRIMITIVE:
                size[i] = 0 if n.name in UNION_ONLY_PRIMITIVES else 1
            elif done:
                parts = [size[c] for c in n.children]
                size[i] = 0 if 0 in parts else min(sum(parts), MAX_PRIMITIVES + 1)
                glass_below[i] = (n.kind == MATERIAL and n.name in glass) or \
                    any(glass_below[c] for c in n.children)
            else:
                stack.append((i, True))
                stack += [(c, False) for c in n.children if size[c] < 0]
    return size, glass_below
