"""For each module, the rule that ends the derivation soonest.

Where the tracer stops refining (an instance smaller than a pixel, or the depth
bound), it finishes the instance with these rules instead of dropping it: a
sub-pixel Sierpinski instance becomes one tetrahedron (its convex hull), a
terrain patch one triangle through its corners. Modules that cannot end at all
(graftals: no primitive below the cycle) get -1, and their box is hit instead.
"""
from __future__ import annotations

import math

from .model import SELECT, Graph


def modules_below(graph: Graph, start: int) -> set[int]:
    """S-nodes reachable from `start` without passing through another S-node."""
    found, seen, stack = set(), {start}, [start]
    while stack:
        for c in graph.nodes[stack.pop()].children:
            if graph.nodes[c].kind == SELECT:
                found.add(c)
            elif c not in seen:
                seen.add(c)
                stack.append(c)
    return found


def terminating_rules(graph: Graph) -> dict[int, int]:
    """S-node -> 0-based index of the rule with the fewest derivation levels to
    primitives (-1 when no rule ever ends). Bellman-Ford over the module graph."""
    selects = [i for i, n in enumerate(graph.nodes) if n.kind == SELECT]
    below = {(s, r): modules_below(graph, c)
             for s in selects for r, c in enumerate(graph.nodes[s].children)}
    dist = {s: math.inf for s in selects}
    best = {s: -1 for s in selects}
    for _ in range(len(selects) + 1):
        changed = False
        for s in selects:
            for r in range(len(graph.nodes[s].children)):
                d = 1 + max((dist[m] for m in below[(s, r)]), default=0)
                if d < dist[s]:
                    dist[s], best[s], changed = d, r, True
        if not changed:
            break
    return best
