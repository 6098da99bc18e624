"""Bounding volumes: the hyper boxes of graph/bounds.py and, for graftals, Bekaert &
Willems' choice (§3.2) between a box and a sphere as the initial bounding volume.

A graftal node is an S-node with no rule that ever ends (graph/terminating.py): the
tracer refines it until an instance is smaller than a pixel and hits that instance's
bounding volume. Each such node gets the volume with the smaller average projected
area, which for a convex body is a quarter of its surface area (Cauchy): a box of
sides a, b, c has 2(ab + bc + ca) / 4, a sphere of radius r has pi r^2. Where the sphere
wins, the tracer culls the node's instances by it and hits it (trace/windows.py
node_window, volume_normal), and the boxes above are computed from the sphere, so that
they hold it and a sub-pixel instance's surface is its sphere."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..limits import BOUNDS_BUDGET, MAX_DEPTH
from .bounds import ANY_RULE, MEMOISED, _Walker, bound
from .model import Graph
from .states import StateTable
from .spheres import ball_points, node_spheres
from .terminating import terminating_rules


@dataclass
class Choice:
    """What bounds one graftal node, and why."""
    node: int
    name: str
    box: np.ndarray                 # (6,) its hyper box
    sphere: np.ndarray | None       # (4,) centre and radius; None if it has none
    nested: bool                    # one round of the maps takes the spheres into themselves

    @property
    def box_area(self) -> float:
        return box_area(self.box)

    @property
    def sphere_area(self) -> float:
        return math.inf if self.sphere is None else math.pi * self.sphere[3] ** 2

    @property
    def volume(self) -> str:
        return "sphere" if self.sphere_area < self.box_area else "box"


@dataclass
class Volumes:
    boxes: np.ndarray               # (n, 6) per node, as bounds.hyper_boxes
    spheres: np.ndarray | None      # (n, 4) per node: the sphere that bounds it instead
                                    # of its box (radius -1: its box); None: no sphere won
    method: str                     # as bounds.hyper_boxes
    problems: list
    table: tuple | StateTable | None  # per-instance boxes (bounds.bound)
    choices: list[Choice]           # one per graftal node, in node order
    depth: int                      # the derivation depth the boxes hold (bounds.bound)
    graph: Graph                    # the graph they are for (bounds.bound's `fuse`)
    asked: int                      # the depth asked for, a default resolved (bounds.bound)


def box_area(box: np.ndarray) -> float:
    """The average projected area of a box (xmin, ..., zmax): its surface over 4."""
    a, b, c = box[3:] - box[:3]
    return float(a * b + b * c + c * a) / 2


def graftal_nodes(graph: Graph) -> list[int]:
    return sorted(s for s, r in terminating_rules(graph).items() if r < 0)


def bounding_volumes(graph: Graph, max_depth: int | None = MAX_DEPTH,
                     budget: int = BOUNDS_BUDGET, poll=None, fuse: bool = False) -> Volumes:
    """poll: as trace/boxwalk.walk_boxes's, for a system bounded instance by instance;
    fuse: as bounds.bound's (Volumes.graph is then the graph to trace)."""
    boxes, method, problems, table, hulls, depth, graph, asked = bound(graph, max_depth,
                                                                       budget, poll, fuse)
    out = Volumes(boxes, None, method, problems, table, [], depth, graph, asked)
    graftals = [s for s in graftal_nodes(graph)
                if boxes[s, 0] <= boxes[s, 3] and np.all(np.isfinite(boxes[s]))]
    if method not in (MEMOISED, ANY_RULE) or not hulls or not graftals:
        return out
    any_rule = method == ANY_RULE
    found = node_spheres(graph, hulls, any_rule)
    spheres, nested = found if found is not None else (None, False)
    for s in graftals:
        ball = None if spheres is None or spheres[s, 3] < 0 else spheres[s].copy()
        out.choices.append(Choice(s, graph.nodes[s].name, boxes[s].copy(), ball, nested))
    won = {c.node: c.sphere for c in out.choices if c.volume == "sphere"}
    if won:
        below = _boxes_from_spheres(graph, hulls, won, any_rule)
        if below is None:       # the boxes could not be made to hold the spheres
            for c in out.choices:
                c.sphere = None
        else:
            out.boxes = below
            out.spheres = np.tile([0.0, 0.0, 0.0, -1.0], (len(graph.nodes), 1))
            for s, ball in won.items():
                out.spheres[s] = ball
    return out


def _boxes_from_spheres(graph: Graph, hulls: dict, won: dict, any_rule: bool
                        ) -> np.ndarray | None:
    """The hyper boxes again, each node won by a sphere giving its parents the sphere
    (as points whose hull holds it) instead of its own bound, so that every box above
    holds the sphere; the re-entered states' estimates are the box walk's last ones.
    A node's own box row becomes its sphere's box (its size for the level of detail)."""
    w = _Walker(graph, any_rule)
    w.estimate = dict(hulls)
    w.volumes = {s: ball_points(ball) for s, ball in won.items()}
    state, h = w.d.initial()
    w.box(graph.root, state, h, 0)
    if any(k not in hulls and k[0] not in w.volumes for k in w.reentered):
        return None
    for s, ball in won.items():
        w.boxes[s] = np.concatenate([ball[:3] - ball[3], ball[:3] + ball[3]])
    return w.boxes


def report(volumes: Volumes) -> dict:
    """The choices as `pcsg stats --json` gives them: module -> its volumes and areas."""
    out = {}
    for c in volumes.choices:
        out[c.name] = {
            "volume": c.volume,
            "box": [float(v) for v in c.box], "box_area": c.box_area,
            "sphere": None if c.sphere is None else [float(v) for v in c.sphere],
            "sphere_area": None if c.sphere is None else c.sphere_area,
            "nested": c.nested}
    return out
