"""Hyper-bounding boxes (Gervautz & Traxler §5): one box per node, in the frame
in which the node receives the ray, enclosing every instance of that node.

Each instance's box is computed bottom-up from its own children with its real
parameter values, so a rotated child is bounded by its transformed primitives'
boxes rather than by a box grown turn after turn (the paper's Fig. 9), and a
node's hyper box is the union of its instances' boxes: exact and conservative.
Instances are memoised on the parameters their geometry can depend on; when a
system has too many distinct states for that (the terrain: every patch has its
own heights), the numba walk in pcsg.trace.boxwalk visits every instance.
"""
from __future__ import annotations

import sys

import numpy as np

from ..language.errors import PcsgError
from ..trace.primitives import BOXES, CODES
from .dependence import RAND, structural_params
from .derive import Deriver
from .model import CALC, DIFFERENCE, INTERSECTION, PRIMITIVE, SELECT, TRANSFORM, UNION, Graph
from .stats import MAX_LEVELS

EMPTY = np.array([np.inf, np.inf, np.inf, -np.inf, -np.inf, -np.inf])
MAX_STATES = 50_000


class TooManyStates(Exception):
    pass


def transform_box(m: np.ndarray, box: np.ndarray) -> np.ndarray:
    """The box of the image of `box` under the affine map m (3x4 or 4x4): interval
    arithmetic per axis, exact for boxes; infinite extents stay infinite."""
    if box[0] > box[3]:
        return EMPTY.copy()
    out = np.empty(6)
    for i in range(3):
        lo = hi = m[i, 3]
        for j in range(3):
            a = m[i, j]
            if a > 0:
                lo, hi = lo + a * box[j], hi + a * box[j + 3]
            elif a < 0:
                lo, hi = lo + a * box[j + 3], hi + a * box[j]
        out[i], out[i + 3] = lo, hi
    return out


def union_box(a, b):
    return np.concatenate([np.minimum(a[:3], b[:3]), np.maximum(a[3:], b[3:])])


def intersect_box(a, b):
    out = np.concatenate([np.maximum(a[:3], b[:3]), np.minimum(a[3:], b[3:])])
    return out if np.all(out[:3] <= out[3:]) else EMPTY.copy()


class _Walker:
    def __init__(self, graph: Graph):
        self.g = graph
        self.d = Deriver(graph)
        rel = structural_params(graph, geometry=True)
        self.rand = [RAND in r for r in rel]
        slots = [sorted(graph.params[p] for p in r if p != RAND) for r in rel]
        self.slots = [np.array(s, dtype=np.int64) for s in slots]
        self.masks = [sum(1 << i for i in s) for s in slots]
        self.memo: dict = {}
        self.boxes = np.tile(EMPTY, (len(graph.nodes), 1))

    def box(self, i: int, state, h: int, level: int) -> np.ndarray:
        n = self.g.nodes[i]
        if n.kind == PRIMITIVE:
            b = BOXES[CODES[n.name]].copy()
            self.boxes[i] = union_box(self.boxes[i], b)
            return b
        key = (i, state.values[self.slots[i]].tobytes(), state.assigned & self.masks[i],
               h if self.rand[i] else 0)
        hit = self.memo.get(key)
        if hit is not None:
            return hit
        if len(self.memo) >= MAX_STATES:
            raise TooManyStates
        if n.kind == SELECT:
            if level >= MAX_LEVELS:
                raise TooManyStates
            r = self.d.select(i, state, h)
            b = self.box(n.children[r], state, self.d.edge(h, i, r), level + 1)
        elif n.kind == CALC:
            b = self.box(n.children[0], self.d.calc(i, state, h), h, level)
        elif n.kind == TRANSFORM:
            b = transform_box(self.d.matrix(i, state, h), self.box(n.children[0], state, h, level))
        elif n.kind in (UNION, INTERSECTION, DIFFERENCE):
            parts = [self.box(c, state, self.d.edge(h, i, k), level)
                     for k, c in enumerate(n.children)]
            b = parts[0]
            for p in parts[1:]:
                if n.kind == UNION:
                    b = union_box(b, p)
                elif n.kind == INTERSECTION:
                    b = intersect_box(b, p)
        else:       # paint, material
            b = self.box(n.children[0], state, h, level)
        self.memo[key] = b
        self.boxes[i] = union_box(self.boxes[i], b)
        return b


def hyper_boxes(graph: Graph) -> tuple[np.ndarray, str]:
    """(n, 6) boxes (xmin, ymin, zmin, xmax, ymax, zmax) per node, and which method
    computed them ('memoised' or 'every instance')."""
    w = _Walker(graph)
    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(max(limit, 20 * MAX_LEVELS))
    try:
        state, h = w.d.initial()
        w.box(graph.root, state, h, 0)
        return w.boxes, "memoised"
    except (TooManyStates, PcsgError):
        pass
    finally:
        sys.setrecursionlimit(limit)
    from ..trace.boxwalk import walk_boxes
    return walk_boxes(graph), "every instance"
