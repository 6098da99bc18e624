"""Trees of boxes over the operands of wide unions (and over the subtrahends of wide
differences), for the tracer.

A union's operands are tested one by one (walk.py): a generated scene written as one
union of 10,000 spheres cost each ray 10,000 box tests (3.1 s at 320x240 against 0.17 s
for the same spheres nested into unions of four by hand). A union of at least WIDE
operands gets a tree of boxes over its operands' hyper boxes, and a ray tests only the
operands whose tree boxes it meets; so does `A \\ B1 \\ B2 ...` over its Bs, each of
whose interval lists a ray cut from A's (a block with 1,000 holes). The operands keep
their numbers, so the instance hashes (rand(), the instance table) and the order of visits
are those of the operator as written: the same operands are met, and the same picture
drawn.

The tree is laid out depth first; each tree node stores where its subtree ends (skip),
so a ray walks it without a stack: into a node whose box it meets (the next row), past
one whose box it misses (its skip). A leaf holds up to LEAF operands.
"""
from __future__ import annotations

import numpy as np

from .model import DIFFERENCE, UNION

WIDE = 16       # the fewest operands of a union that get a tree
LEAF = 4        # the most operands of a leaf
# an instance table's box is float32, cut to its node's box and rounded to nearest: it may
# stick out of that box by half a float32 step, so each operand's box is widened by more
WIDEN = 2.0 ** -20
TINY = 1e-37


def operand_trees(kind, starts, counts, children, boxes, spheres) -> dict:
    """The Flat's tree_* fields: tree_root[n] (-1: no tree), and per tree node its box,
    skip, and operands tree_items[first:first + count] (count 0: an inner node)."""
    n = len(kind)
    root = np.full(n, -1, dtype=np.int32)
    out = _Trees()
    for u in np.flatnonzero(((kind == UNION) & (counts >= WIDE)) |
                            ((kind == DIFFERENCE) & (counts > WIDE))).tolist():
        # a difference's subtrahends: its first operand is walked whatever the boxes
        ks = np.arange(int(kind[u] == DIFFERENCE), counts[u], dtype=np.int32)
        items = _item_boxes(boxes, spheres, children[starts[u] + ks])
        keep = items[:, 0] <= items[:, 3]       # an empty box meets no ray
        # (where nothing is bounded, every box is all of space: a tree would cull nothing)
        if keep.sum() >= 2 and np.isfinite(items[keep]).all(axis=1).any():
            root[u] = out.build(ks[keep], items[keep])
    return dict(tree_root=root, **out.arrays())


def _item_boxes(boxes, spheres, nodes) -> np.ndarray:
    """Each node's box as the walk tests it (windows.volume_window): its box, or its sphere
    where it has one, widened; an empty box stays empty (all sides inverted)."""
    b = np.array(boxes[nodes], dtype=np.float64)
    empty = b[:, 0] > b[:, 3]
    # box_window reads a box as empty by its x sides only, and other sides' slabs swap
    # crossed ends: as a ray meets it, a box is each axis' span
    lo, hi = np.minimum(b[:, :3], b[:, 3:]), np.maximum(b[:, :3], b[:, 3:])
    lo[empty], hi[empty] = np.inf, -np.inf
    if spheres is not None and len(spheres):
        s = spheres[nodes]
        has = s[:, 3] >= 0.0
        r = s[has, 3:4] * (1.0 + WIDEN)
        lo[has] = np.minimum(lo[has], s[has, :3] - r)
        hi[has] = np.maximum(hi[has], s[has, :3] + r)
    with np.errstate(invalid="ignore"):     # inf - inf where a side is already infinite
        lo = lo - (np.abs(lo) * WIDEN + TINY)
        hi = hi + (np.abs(hi) * WIDEN + TINY)
    return np.concatenate([lo, hi], axis=1)


class _Trees:
    def __init__(self):
        self.box: list[np.ndarray] = []
        self.skip: list[int] = []
        self.first: list[int] = []
        self.count: list[int] = []
        self.items: list[np.ndarray] = []
        self.n_items = 0

    def build(self, ks: np.ndarray, items: np.ndarray) -> int:
        """A tree over the operands ks with boxes items; returns its first row."""
        first = len(self.skip)
        # an unbounded operand (a plane) as a finite one, to be sorted among the others
        finite = np.clip(items, -1e300, 1e300)
        centres = 0.5 * (finite[:, :3] + finite[:, 3:])
        # depth first without recursion: the operands of each node still to make
        todo = [np.arange(len(ks))]
        inner = []                      # the inner nodes' rows, in the order made
        while todo:
            sel = todo.pop()
            row = len(self.skip)
            sub = items[sel]
            self.box.append(np.concatenate([sub[:, :3].min(axis=0), sub[:, 3:].max(axis=0)]))
            self.skip.append(-1)
            if len(sel) <= LEAF:
                self.first.append(self.n_items)
                self.count.append(len(sel))
                self.items.append(ks[sel])
                self.n_items += len(sel)
                self.skip[row] = row + 1
            else:
                self.first.append(0)
                self.count.append(0)
                c = centres[sel]
                axis = int(np.argmax(c.max(axis=0) - c.min(axis=0)))
                half = len(sel) // 2
                # a stable order: the same tree for the same boxes, whatever numpy's
                # partition does with ties
                order = np.lexsort((sel, c[:, axis]))
                todo.append(sel[order[half:]])
                todo.append(sel[order[:half]])
                inner.append(row)
        # an inner node's subtree ends where its second child's does; that child starts
        # where its first child's subtree (from the next row) ends. Every leaf's skip is
        # set, and from the last inner node back, each child's is set before its parent's
        for row in reversed(inner):
            self.skip[row] = self.skip[self.skip[row + 1]]
        return first

    def arrays(self) -> dict:
        return dict(
            tree_box=np.ascontiguousarray(np.array(self.box, dtype=np.float64).reshape(-1, 6)),
            tree_skip=np.array(self.skip, dtype=np.int32),
            tree_first=np.array(self.first, dtype=np.int32),
            tree_count=np.array(self.count, dtype=np.int32),
            tree_items=np.concatenate([np.zeros(0, dtype=np.int32), *self.items]).astype(
                np.int32))
