"""How many instances a view-dependent level of detail would refine, in Python.

    python tools/view_cut.py grammars/carpenter_terrain.pcsg --set cnt=12 [--size 640x480]

The bounding walk of a system with too many states (the terrain) visits every instance,
and the tracer's level of detail never fires on the terrain (its hyper boxes span the
whole height at every level), so the bounding walk of the terrain at 12 makes 313
million node visits, most of its time (tools/performance_notes.md). A cut that the walk and the tracer could both apply is one made per
instance from what the instance alone knows: stop refining where the box of the
instance's terminating geometry (its terminating rule, every S-node below it cut too)
is smaller than a pixel seen from the file's #camera eye. This walks the derivation
with that cut (graph/derive.py, exactly the tracer's parameter states and matrices)
and counts, level by level, the instances that follow their own selection and those
cut. It measures the design; nothing renders with this cut yet.
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

from pcsg.arguments import set_value
from pcsg.compiler import compile_file
from pcsg.graph.bounds import EMPTY, _corners, as_box, transform_bound, union_box
from pcsg.graph.derive import Deriver
from pcsg.graph.model import CALC, OPERATORS, PRIMITIVE, SELECT, TRANSFORM
from pcsg.graph.terminating import terminating_rules
from pcsg.render.camera import DEFAULT_FOV
from pcsg.trace.primitives import object_box

PROGRESS = 1_000_000       # instances between progress lines: Python walks ~10,000 a second


class ViewCut:
    def __init__(self, graph, eye, pixel_angle: float):
        self.g, self.d = graph, Deriver(graph)
        self.term = terminating_rules(graph)
        self.eye, self.lod = np.asarray(eye, float), pixel_angle

    def _world_box(self, node, state, h, m) -> np.ndarray:
        """The world box of the geometry below `node` with every S-node cut (bounds.py's
        arithmetic: corner points through the matrices)."""
        box = EMPTY.copy()
        stack = [(node, state, h, m, 0)]
        while stack:
            i, state, h, m, depth = stack.pop()
            n = self.g.nodes[i]
            if n.kind == PRIMITIVE:
                own = transform_bound(m, _corners(object_box(n.name,
                                                             self.g.constant_args(i))))
                box = union_box(box, as_box(own))
            elif n.kind == SELECT:
                r = self.term[i]
                if r < 0 or depth > 64:         # a graftal, or a rule that never ends
                    return -EMPTY           # unbounded
                stack.append((n.children[r], state, self.d.edge(h, i, r), m, depth + 1))
            else:
                stack.extend((*child, depth) for child in self._below(i, n, state, h, m))
        return box

    def _below(self, i, n, state, h, m):
        """The children of a C-, T-, paint, material or operator node: (node, state,
        hash, world matrix) each, as graph/flatten.py derives them."""
        if n.kind == CALC:
            state = self.d.calc(i, state, h)
        elif n.kind == TRANSFORM:
            m = m @ self.d.matrix(i, state, h)
        many = n.kind in OPERATORS.values()
        return [(c, state, self.d.edge(h, i, k) if many else h, m)
                for k, c in enumerate(n.children)]

    def small(self, box: np.ndarray) -> bool:
        """Smaller than a pixel where it is nearest the eye (the tracer's world_size:
        the sum of the extents)."""
        if not np.all(np.isfinite(box)):
            return False
        gap = np.maximum(0.0, np.maximum(box[:3] - self.eye, self.eye - box[3:]))
        return float((box[3:] - box[:3]).sum()) < self.lod * float(np.linalg.norm(gap))

    def count(self, max_levels: int = 64):
        """Instances that follow their own selection, and instances cut, by derivation
        level."""
        own, cut = np.zeros(max_levels + 2, int), np.zeros(max_levels + 2, int)
        state, h = self.d.initial()
        stack = [(self.g.root, state, h, np.eye(4), 0)]
        seen = 0
        while stack:
            i, state, h, m, level = stack.pop()
            n = self.g.nodes[i]
            if n.kind == PRIMITIVE:
                continue
            if n.kind == SELECT:
                level += 1
                seen += 1
                if seen % PROGRESS == 0:
                    print(f"  {seen:,} instances so far", file=sys.stderr, flush=True)
                r = self.term[i]
                if level > max_levels or (r >= 0 and self.small(self._world_box(
                        n.children[r], state, self.d.edge(h, i, r), m))):
                    cut[min(level, max_levels + 1)] += 1
                    continue
                own[level] += 1
                r = self.d.select(i, state, h)
                stack.append((n.children[r], state, self.d.edge(h, i, r), m, level))
                continue
            stack.extend((*child, level) for child in self._below(i, n, state, h, m))
        return own, cut


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("file")
    ap.add_argument("--set", action="append", default=[], type=set_value, metavar="NAME=VALUE")
    ap.add_argument("--size", default="640x480")
    args = ap.parse_args()
    w, h = (int(v) for v in args.size.split("x"))
    graph = compile_file(Path(args.file), args.set)
    cam = graph.scene.camera
    if "eye" not in cam:
        print("view_cut: the file needs a #camera with eye= and fov=", file=sys.stderr)
        return 2
    angle = math.radians(cam.get("fov", DEFAULT_FOV)) / h         # Camera.pixel_angle
    start = time.perf_counter()
    own, cut = ViewCut(graph, cam["eye"], angle).count()
    seconds = time.perf_counter() - start
    levels = np.nonzero(own + cut)[0]
    print(f"{args.file} {dict(args.set)} {w}x{h}: {own.sum():,} instances follow "
          f"their own selection, {cut.sum():,} are cut at pixel size ({seconds:.1f} s in Python)")
    print("level      own      cut")
    for lv in levels:
        print(f"{lv:5d} {own[lv]:8,d} {cut[lv]:8,d}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
