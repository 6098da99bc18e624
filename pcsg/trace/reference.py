"""The reference tracer: the complete derivation expanded into a plain CSG TREE
and traced ray by ray with Roth's interval CSG. Deliberately simple (pure Python
and numpy, one njit call per primitive and batch of rays), for small orders: it
is the oracle the graph tracer is checked against.

Semantics (the contract the tracer is compared on)
--------------------------------------------------
- A ray is p(t) = o + t d with d as given (not normalised); t is in units of d.
- A leaf is the primitive with its world matrix M (world from object). The ray
  goes to the object frame with M^-1 (t unchanged), ``primitives.intersect``
  gives the interval, normals go to world with M^-T (outward even for a
  mirror) and are normalised. A singular or non-finite M makes the leaf empty.
  Each interval is clipped to [tmin, tmax] (the clipped end keeps the
  primitive's normal); an interval that misses [tmin, tmax] is dropped.
- Every interval end carries (t, unit world normal, paint, material, primitive).
- union: the sorted union, intervals that touch or overlap merged (closed sets);
  degenerate intervals [t, t] (flat triangles, grazing hits) are kept.
- intersection: max of starts, min of ends; only pieces thicker than a sliver (walk.thick)
  (1e-9 relative) are kept (regularised: solids that only touch give nothing,
  and coincident surfaces that rounding separates leave no sliver).
- difference (n-ary, first child minus all the others): the first child
  intersected with the complement of the union of the others; boundaries that
  come from a subtracted operand get their normal negated and keep that
  operand's paint/material; only pieces with start < end are kept (so A \\ A
  is empty).
- The hit is the first interval whose start t is > tmin (strictly): an
  interval clipped at tmin (the origin inside a solid) is not a hit, the
  next one is; with trace(..., exits=True) such a ray reports instead where
  it leaves the solid (t_out < tmax, the outward normal there). For a flat
  triangle the normal is turned so that dot(normal, d) <= 0; a solid's normal
  is the CSG outward normal as is.
- Coincident surfaces: on a tie a union keeps its first operand's end; the graph
  tracer, which visits operands nearest box first (cheap ones before the others), may
  show the other one. `tie` marks the rays whose hit has another surface of a different
  paint or material at the same t.
- Misses: hit False, t inf, normal nan, paint nan, material -1, primitive ''.
- With a cut (graph/cut.py), the expansion a tracer walks at its depth bound without
  a level of detail: deeper selections take their terminating rule, and a graftal's
  instance there is its bounding box or sphere intersected with the volumes above it
  that do not hold it (leaves named with CLIP). Where a ray's hit is on such a clip,
  the graph tracer's normal is its own volume's nearest face's, not the clip's.
"""
from __future__ import annotations

import math

import numpy as np

from .dispatch import cached_jit
from ..graph.cut import Cut
from ..graph.flatten import flatten, leaf_inverse
from ..graph.model import DIFFERENCE, INTERSECTION, UNION, Graph
from . import fractals, primitives
from .walk import HIT_SHEET, HIT_SHELL, HIT_SOLID, thick

CLIP = " (clip)"     # the name's mark of a volume that clips a cut graftal instance
LEAF = -1            # tree node kind of a primitive; operators use the graph's kinds
_OPNAMES = {UNION: "union", INTERSECTION: "intersection", DIFFERENCE: "difference"}
_CHUNK = 4096        # rays per batch (bounds the per-leaf arrays)
_POLL = 64           # rays between polls of trace's caller


class Leaf:
    """A primitive of the expanded tree."""
    __slots__ = ("code", "name", "matrix", "paint", "material", "inverse", "normal_matrix",
                 "fractal", "what")

    def __init__(self, code, name, matrix, paint, material, args=(), volume=False):
        self.code, self.name, self.matrix = code, name, matrix
        # what a hit on it is, as the tracer's R_HIT (trace/walk.py): a graftal's volume
        # and a fractal are shells, a triangle a sheet
        self.what = (HIT_SHELL if volume or code >= primitives.FRACTAL_MIN else
                     HIT_SHEET if code in primitives.FLAT else HIT_SOLID)
        self.fractal = None
        if code >= primitives.FRACTAL_MIN:
            self.fractal = np.array([fractals.fractal_row(name, args)])
        self.paint, self.material = paint, material          # rgb tuple | None, index | -1
        self.inverse = leaf_inverse(matrix)                  # None: singular, empty
        self.normal_matrix = None if self.inverse is None else self.inverse[:3, :3].T


class Op:
    """An operator of the expanded tree: kind UNION / INTERSECTION / DIFFERENCE."""
    __slots__ = ("kind", "children")

    def __init__(self, kind, n):
        self.kind, self.children = kind, [None] * n

    @property
    def name(self):
        return _OPNAMES[self.kind]


@cached_jit(error_model='numpy')
def _intersect_many(code, O, D, out, hit):
    for k in range(O.shape[0]):
        hit[k] = primitives.intersect(code, O[k, 0], O[k, 1], O[k, 2],
                                      D[k, 0], D[k, 1], D[k, 2], out[k])


@cached_jit(error_model='numpy')
def _march_many(is_julia, args, O, D, tmin, tmax, out, hit):
    for k in range(O.shape[0]):
        hit[k] = fractals.march(is_julia, args, 0, O[k, 0], O[k, 1], O[k, 2],
                                D[k, 0], D[k, 1], D[k, 2], tmin, tmax, 0.0, 0.0, 1.0, out[k])


class Reference:
    def __init__(self, graph: Graph, max_primitives: int = 200_000, cut: Cut | None = None):
        """The expansion of graph; with a cut (graph/cut.py), the one a tracer of graph
        walks with that depth bound and no level of detail (lod=0). An instance whose
        selection is invalid is empty, as the tracer makes it; `faults` says why."""
        self.graph = graph
        self.nodes: list = []        # tree nodes in pre-order: children after parents
        self.faults: list = []       # Diagnostics of the invalid selections met
        self.root = self._build(graph, max_primitives, cut)

    # ---- the expanded tree ------------------------------------------------------

    def _build(self, graph: Graph, max_primitives: int, cut: Cut | None) -> int:
        """The derivation from pcsg.graph.flatten, regrouped into its operators: every
        primitive's path names the operator instances above it, so a path prefix is one
        operator instance of the tree."""
        tree = self.nodes
        holder = [None]
        ops: dict[tuple, Op] = {}
        for inst in flatten(graph, max_primitives, cut, self.faults):
            parent, slot = holder, 0
            for j, (node, k) in enumerate(inst.path):
                op = ops.get(inst.path[:j])
                if op is None:
                    g = graph.nodes[node]
                    op = ops[inst.path[:j]] = Op(g.kind, len(g.children))
                    parent[slot] = len(tree)
                    tree.append(op)
                parent, slot = op.children, k
            material = graph.material_names.index(inst.material) if inst.material else -1
            paint = None if inst.paint is None else tuple(float(v) for v in inst.paint)
            # under ∩ or \ the tracer takes every surface from interval lists, solids' ends
            # (walk.py: HIT_SOLID there), a graftal's volume too
            shell = inst.volume and not any(graph.nodes[node].kind in (INTERSECTION, DIFFERENCE)
                                            for node, _ in inst.path)
            if inst.clip:           # a cut graftal instance: its volume ∩ those that clip it
                op = Op(INTERSECTION, 1 + len(inst.clip))
                parent[slot] = len(tree)
                tree.append(op)
                for k, (name, matrix) in enumerate(inst.clip, 1):
                    op.children[k] = len(tree)
                    tree.append(Leaf(primitives.CODES[name], name + CLIP, matrix, paint,
                                     material, volume=shell))
                parent, slot = op.children, 0
            parent[slot] = len(tree)
            tree.append(Leaf(primitives.CODES[inst.primitive], inst.primitive, inst.matrix,
                             paint, material, inst.args, shell))
        return holder[0]

    @property
    def leaves(self) -> list[Leaf]:
        """The primitives in derivation order (the order of pcsg.graph.flatten)."""
        return [n for n in self.nodes if isinstance(n, Leaf)]

    def as_tree(self):
        """The expanded tree as nested tuples: ('union' | 'intersection' |
        'difference', [children]) and leaves (code, 4x4 world matrix, paint rgb or
        None, material index or -1)."""
        built = [None] * len(self.nodes)
        for idx in range(len(self.nodes) - 1, -1, -1):      # children come after parents
            n = self.nodes[idx]
            if isinstance(n, Leaf):
                built[idx] = (n.code, n.matrix, n.paint, n.material)
            else:
                built[idx] = (n.name, [built[c] for c in n.children if c is not None])
        return None if self.root is None else built[self.root]

    # ---- tracing ----------------------------------------------------------------

    def trace(self, origins, directions, tmin=1e-9, tmax=np.inf, exits=False,
              poll=None) -> dict:
        """First hits of the rays o + t d, t in (tmin, tmax]. With exits=True a ray
        that starts inside a solid (its first interval is clipped at tmin) reports
        where it leaves it instead (t_out and the outward normal there), if that is
        before tmax; by default such a ray sees past the solid to the next start.
        poll() is called every few rays: it may raise to stop (--timeout)."""
        O = np.ascontiguousarray(np.asarray(origins, dtype=np.float64).reshape(-1, 3))
        D = np.ascontiguousarray(np.asarray(directions, dtype=np.float64).reshape(-1, 3))
        if O.shape != D.shape:
            raise ValueError("origins and directions must have the same shape (N, 3)")
        n = len(O)
        res = {"hit": np.zeros(n, dtype=bool), "t": np.full(n, np.inf),
               "normal": np.full((n, 3), np.nan), "paint": np.full((n, 3), np.nan),
               "material": np.full(n, -1, dtype=np.int64),
               "primitive": np.full(n, "", dtype=object), "tie": np.zeros(n, dtype=bool),
               "what": np.zeros(n)}
        for a in range(0, n, _CHUNK):
            self._trace_chunk(O[a:a + _CHUNK], D[a:a + _CHUNK], float(tmin), float(tmax),
                              bool(exits), res, a, poll)
        return res

    def _leaf_hits(self, leaf: Leaf, O, D, tmin, tmax):
        """Per ray: None, or the clipped interval [t0, end0, t1, end1] of the leaf."""
        n = len(O)
        if leaf.inverse is None:
            return [None] * n
        inv = leaf.inverse
        Oo = np.ascontiguousarray(O @ inv[:3, :3].T + inv[:3, 3])
        Do = np.ascontiguousarray(D @ inv[:3, :3].T)
        out = np.zeros((n, 8))
        hit = np.zeros(n, dtype=bool)
        if leaf.fractal is None:
            _intersect_many(leaf.code, Oo, Do, out, hit)
        else:
            _march_many(leaf.code == primitives.JULIA, leaf.fractal, Oo, Do, tmin, tmax, out, hit)
        rows = np.flatnonzero(hit)
        nin = out[rows, 2:5] @ leaf.normal_matrix.T
        nout = out[rows, 5:8] @ leaf.normal_matrix.T
        with np.errstate(invalid="ignore", divide="ignore"):
            nin /= np.linalg.norm(nin, axis=1, keepdims=True)
            nout /= np.linalg.norm(nout, axis=1, keepdims=True)
        flat = leaf.code in primitives.UNION_ONLY
        res = [None] * n
        for r, k in enumerate(rows):
            t0, t1 = max(out[k, 0], tmin), min(out[k, 1], tmax)
            if not (t0 <= t1 and t0 < math.inf and t1 > -math.inf):
                continue                         # outside [tmin, tmax] or at infinity
            res[k] = (t0, (tuple(nin[r]), leaf, flat), t1, (tuple(nout[r]), leaf, flat))
        return res

    def _trace_chunk(self, O, D, tmin, tmax, exits, res, offset, poll=None):
        nodes = self.nodes
        leaf_hits = {}
        for idx, node in enumerate(nodes):
            if isinstance(node, Leaf):
                leaf_hits[idx] = self._leaf_hits(node, O, D, tmin, tmax)
        for k in range(len(O)):
            if poll is not None and k % _POLL == 0:
                poll()      # a ray's walk of every node here is Python's: seconds a chunk
            spans = [None] * len(nodes)
            for idx in range(len(nodes) - 1, -1, -1):     # children come after parents
                node = nodes[idx]
                if isinstance(node, Leaf):
                    iv = leaf_hits[idx][k]
                    spans[idx] = [] if iv is None else [iv]
                    continue
                # an operand that derived no instance (a cut node without a volume) is
                # empty: its slot was never filled
                kids = [[] if c is None else spans[c] for c in node.children]
                for c in node.children:
                    if c is not None:
                        spans[c] = None
                if node.kind == UNION:
                    spans[idx] = union(kids)
                elif node.kind == INTERSECTION:
                    acc = kids[0]
                    for other in kids[1:]:
                        acc = intersection(acc, other)
                    spans[idx] = acc
                else:
                    spans[idx] = difference(kids[0], kids[1:])
            for t0, e0, t1, e1 in ([] if self.root is None else spans[self.root]):
                if exits and t0 <= tmin < t1 < tmax:     # inside at tmin: the exit
                    t0, e0 = t1, e1
                if t0 > tmin:
                    normal, leaf, flat = e0
                    nrm = np.array(normal)
                    if flat and np.dot(nrm, D[k]) > 0.0:
                        nrm = -nrm
                    j = offset + k
                    res["hit"][j] = True
                    res["t"][j] = t0
                    res["normal"][j] = nrm
                    if leaf.paint is not None:
                        res["paint"][j] = leaf.paint
                    res["material"][j] = leaf.material
                    res["primitive"][j] = leaf.name
                    res["what"][j] = leaf.what
                    res["tie"][j] = _tie(leaf_hits, k, leaf, t0)
                    break


def _tie(leaf_hits, k, leaf, t) -> bool:
    """Whether another leaf of a different paint or material has a surface at t too
    (coincident surfaces): the graph tracer, which visits union operands nearest box
    first, may then show either; the oracle compares paint and material elsewhere."""
    eps = 1e-9 * max(1.0, abs(t))
    for hits in leaf_hits.values():
        iv = hits[k]
        if iv is None or iv[1][1] is leaf:
            continue
        other = iv[1][1]
        if (abs(iv[0] - t) <= eps or abs(iv[2] - t) <= eps) and (
                other.material != leaf.material or
                not np.array_equal(np.asarray(other.paint, float), np.asarray(leaf.paint, float),
                                   equal_nan=True)):
            return True
    return False


# ---- Roth's interval CSG on sorted lists of disjoint closed intervals ----------------
# An interval is (t0, end0, t1, end1); an end is (normal tuple, Leaf, is_flat).

def union(lists):
    """The union of several interval lists; touching or overlapping intervals merge."""
    items = sorted((iv for lst in lists for iv in lst), key=lambda iv: iv[0])
    out = []
    for iv in items:
        if out and iv[0] <= out[-1][2]:
            last = out[-1]
            if iv[2] > last[2]:
                out[-1] = (last[0], last[1], iv[2], iv[3])
        else:
            out.append(iv)
    return out


def intersection(a, b):
    """The regularised intersection: pieces thicker than a sliver only (the graph tracer
    drops the same slivers, which coincident surfaces leave where rounding differs)."""
    out = []
    i = j = 0
    while i < len(a) and j < len(b):
        x, y = a[i], b[j]
        s, se = (x[0], x[1]) if x[0] >= y[0] else (y[0], y[1])
        e, ee = (x[2], x[3]) if x[2] <= y[2] else (y[2], y[3])
        if thick.py_func(s, e):         # the walk's test, in Python
            out.append((s, se, e, ee))
        if x[2] <= y[2]:
            i += 1
        else:
            j += 1
    return out


def _negate(end):
    normal, leaf, flat = end
    return (tuple(-v for v in normal), leaf, flat)


_NO_END = ((0.0, 0.0, 1.0), None, False)


def complement(lst):
    """The complement over (-inf, inf); the ends come from the operand, negated."""
    out = []
    t, e = -math.inf, _NO_END
    for t0, e0, t1, e1 in lst:
        out.append((t, e, t0, _negate(e0)))
        t, e = t1, _negate(e1)
    out.append((t, e, math.inf, _NO_END))
    return out


def difference(a, others):
    """a minus the union of others (regularised)."""
    if not a:
        return []
    return intersection(a, complement(union(others)))
