"""Every primitive instance of the derivation, compiled: its node, world map, paint and
material, in derivation order (left operand first), as graph/flatten.instances gives
them in Python. For `pcsg export --pov`, whose Python derivation took 0.1 ms per
primitive: a minute for the terrain at order 9.

The walk keeps a stack of pending entries, each an instance of a node with its
parameter row, level, hash, world map (3x4), paint, material and chain of CSG blocks.
An entry whose node has one child (a selection's chosen rule included) becomes that
child where it stands; an operator's entry becomes its operands, the first on top. A
C-node writes its state into the row of its own stack position: every entry below it
reads a row no higher than its own position, so no pending entry reads the row it
overwrites.

The walk hands out its leaves in chunks: it stops when its out arrays are full and goes
on from there (`state`) at the next call, so its memory does not grow with the
derivation."""
from __future__ import annotations

import numpy as np

from ..graph.model import CALC, MATERIAL, PAINT, PRIMITIVE, SELECT, TRANSFORM, UNION
from . import vm
from .jit import copy_into, inline, kernel
from .nodes import determinant, eval_args, node_affine, pick_rule, run_calc

NODE, SLOT, LEVEL, MAT, CSG = range(5)   # fr's columns; CSG: the length of its chain
SP, STATUS, NEXT_ID = range(3)           # state's fields
# state[STATUS]; GRAFTAL_CUT: an instance with no rule that ends reached the cut, whose
# volume only the Python derivation writes (graph/cut.py)
RUNNING, ROOM, BAD_SELECTION, TOO_DEEP, CHAIN_ROOM, GRAFTAL_CUT = range(6)


@kernel
def leaves(flat, max_levels, cut, fr, hs, world, paint, last, path, params, stack, args,
           m34, state, out_node, out_world, out_paint, out_mat, out_chain, out_csg):
    """Walk on from state[SP] pending entries, writing leaves into the out_ arrays until
    they are full or the walk ends (state[SP] = 0); returns the leaves written. Stops
    early with state[STATUS] = ROOM when the entry arrays need more rows, CHAIN_ROOM when
    the path needs more rows (the caller grows them and calls again), or with
    BAD_SELECTION or TOO_DEEP (more than max_levels nested selections) at the entry on
    top. Selections deeper than `cut` take their terminating rule, as the tracer's past
    its depth bound; GRAFTAL_CUT where there is none.

    An entry's chain is the CSG operators above it from the first ∩ or \\ down, unions
    below that included, which the export writes as blocks: (instance id, node, operand
    number) each, the id numbering the operator's instances (state[NEXT_ID]); a leaf
    takes its chain to out_chain and its length to out_csg. An entry keeps only its chain's
    length and last link (`last`): the links above it are `path`'s, the chain of the entry
    taken last at each length, since every entry taken between an entry's making and its
    turn is below its operator (the walk is depth first) and writes only links at or below
    the entry's own. Chains copied into every entry took rows times nesting: a derivation
    nested 10,000 blocks deep asked for gigabytes."""
    n = 0
    sp = state[SP]
    state[STATUS] = RUNNING
    while sp > 0:
        f = sp - 1
        node = fr[f, NODE]
        kind = flat.kind[node]
        c = fr[f, CSG]
        if c > 0:
            copy_into(path[c - 1], last[f])
        if kind == PRIMITIVE:
            if n == out_node.shape[0]:
                break
            out_node[n] = node
            copy_into(out_world[n], world[f])
            copy_into(out_paint[n], paint[f])
            out_mat[n] = fr[f, MAT]
            out_csg[n] = c
            for i in range(c):
                copy_into(out_chain[n, i], path[i])
            n += 1
            sp -= 1
            continue
        count = flat.child_count[node]
        first = flat.child_start[node]
        if f + count > fr.shape[0]:
            state[STATUS] = ROOM
            break
        slot = fr[f, SLOT]
        h = hs[f]
        if kind == SELECT:
            level = fr[f, LEVEL] + 1
            if level > max_levels:
                state[STATUS] = TOO_DEEP
                break
            if level > cut:         # as the tracer past its depth bound: the rule that
                r = flat.term_rule[node]                            # ends soonest
                if r < 0:
                    state[STATUS] = GRAFTAL_CUT
                    break
                if level > 4 * cut + 64:    # a terminating rule that keeps recursing
                    sp -= 1
                    continue
            else:
                r = pick_rule(flat, node, params, slot, h, stack)
                if r < 0:
                    state[STATUS] = BAD_SELECTION
                    break
            fr[f, NODE] = flat.children[first + r]
            fr[f, LEVEL] = level
            hs[f] = vm.edge_hash(h, node, r)
            continue
        if kind == CALC:
            run_calc(flat, node, params, slot, f, h, stack)
            fr[f, SLOT] = f
        elif kind == TRANSFORM:
            # non-finite arguments, or a map singular itself (graph/linear.py flat): an
            # empty instance, as in the tracer (a flat map's product with the maps below is
            # singular only up to rounding)
            if (node_affine(flat, node, params, slot, h, stack, args, m34)
                    and determinant(m34) != 0.0):
                _compose(world[f], m34)
            else:
                world[f, :] = np.nan
        elif kind == PAINT:
            if flat.fixed[node]:
                for k in range(3):
                    paint[f, k] = flat.fixed_map[node, k]
            else:
                ok = eval_args(flat, node, params, slot, h, stack, args)
                for k in range(3):
                    paint[f, k] = args[k]
                if not ok:
                    world[f, :] = np.nan
        elif kind == MATERIAL:
            fr[f, MAT] = flat.code[node]
            if flat.fixed[node]:    # its own colour paints over a paint above (flat.py)
                for k in range(3):
                    paint[f, k] = flat.fixed_map[node, k]
        if kind == CALC or kind == TRANSFORM or kind == PAINT or kind == MATERIAL:
            fr[f, NODE] = flat.children[first]
            continue
        # an operator: its operands above it, the first on top; position f last, as the
        # others copy from it
        block = c > 0 or kind != UNION
        if block and c == path.shape[0]:
            state[STATUS] = CHAIN_ROOM
            break
        op = state[NEXT_ID]
        if block:
            state[NEXT_ID] += 1
        for k in range(count):
            g = f + count - 1 - k
            if g != f:
                copy_into(fr[g], fr[f])
                copy_into(world[g], world[f])
                copy_into(paint[g], paint[f])
            fr[g, NODE] = flat.children[first + k]
            hs[g] = vm.edge_hash(h, node, k)
            if block:
                last[g, 0] = op
                last[g, 1] = node
                last[g, 2] = k
                fr[g, CSG] = c + 1
        sp = f + count
    state[SP] = sp
    return n


@inline
def _compose(w, m34):
    """w (a 3x4 world map, row-major in 12) := w followed by the T-node's map m34: the
    products of the reference's 4x4 w @ m, whose last row is (0, 0, 0, 1), summed in an
    order of their own (ulps apart from numpy's)."""
    for i in range(3):
        a, b, c = w[4 * i], w[4 * i + 1], w[4 * i + 2]
        w[4 * i + 3] = a * m34[0, 3] + b * m34[1, 3] + c * m34[2, 3] + w[4 * i + 3]
        for j in range(3):
            w[4 * i + j] = a * m34[0, j] + b * m34[1, j] + c * m34[2, j]


class Walker:
    """The walk's arrays and where it stands, for leaf_chunks (graph/leaves.py)."""

    def __init__(self, flat, max_levels: int, cut: int | None = None, rows: int = 64):
        self.flat = flat
        self.max_levels = max_levels
        self.cut = max_levels if cut is None else cut
        self.fr = np.zeros((rows, 5), dtype=np.int64)
        self.hs = np.zeros(rows, dtype=np.uint64)
        self.world = np.zeros((rows, 12))
        self.paint = np.full((rows, 3), np.nan)
        self.last = np.zeros((rows, 3), dtype=np.int64)
        self.path = np.zeros((4, 3), dtype=np.int64)
        self.params = np.full((rows, flat.n_params), np.nan)
        self.fr[0] = (flat.root, 0, 0, -1, 0)
        self.hs[0] = vm.ROOT_HASH
        self.world[0] = np.eye(4)[:3].ravel()
        if flat.pixels_slot >= 0:       # no camera sees the derivation: every instance large
            self.params[0, flat.pixels_slot] = np.inf
        self.stack = np.empty(flat.max_stack)
        self.args = np.empty(max(12, int(flat.expr_count.max(initial=0))))
        self.m34 = np.empty((3, 4))
        self.state = np.array([1, RUNNING, 0], dtype=np.int64)
        self.out_node = self.out_world = self.out_paint = self.out_mat = None
        self.out_chain = self.out_csg = None

    def run(self, chunk: int) -> int:
        """Walk on until `chunk` leaves are in the out_ arrays, or it stops (state)."""
        if (self.out_node is None or len(self.out_node) != chunk
                or self.out_chain.shape[1] != self.path.shape[0]):
            self.out_node = np.empty(chunk, dtype=np.int64)
            self.out_world = np.empty((chunk, 12))
            self.out_paint = np.empty((chunk, 3))
            self.out_mat = np.empty(chunk, dtype=np.int64)
            self.out_chain = np.empty((chunk,) + self.path.shape, dtype=np.int64)
            self.out_csg = np.empty(chunk, dtype=np.int64)
        return leaves(self.flat, self.max_levels, self.cut, self.fr, self.hs, self.world,
                      self.paint, self.last, self.path, self.params, self.stack, self.args,
                      self.m34, self.state, self.out_node, self.out_world, self.out_paint,
                      self.out_mat, self.out_chain, self.out_csg)

    def grow(self):
        """Twice the entry rows, keeping what they hold."""
        def doubled(a, fill):
            b = np.full((2 * a.shape[0],) + a.shape[1:], fill, dtype=a.dtype)
            b[:a.shape[0]] = a
            return b
        self.fr = doubled(self.fr, 0)
        self.hs = doubled(self.hs, 0)
        self.world = doubled(self.world, 0.0)
        self.paint = doubled(self.paint, np.nan)
        self.last = doubled(self.last, 0)
        self.params = doubled(self.params, np.nan)

    def grow_chain(self):
        """A path twice as long, keeping what it holds."""
        longer = np.zeros((2 * self.path.shape[0], 3), dtype=np.int64)
        longer[:self.path.shape[0]] = self.path
        self.path = longer


def walker(graph, cut: int | None = None) -> Walker:
    """A Walker at the root of graph's derivation, with its parameters undefined (nan)
    as in flatten.instances, on the bounding walk's Flat (maps one T-node at a time, as
    the reference composes them); selections deeper than `cut` take their terminating
    rule."""
    from ..graph.stats import MAX_LEVELS
    from .boxwalk import walk_flat
    return Walker(walk_flat(graph)[0], MAX_LEVELS, cut)
