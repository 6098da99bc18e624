"""Hyper-bounding boxes by visiting every instance (njit), for systems whose
instances are too many to memoise in Python: each instance's box is computed
bottom-up in its own frame and united into its node's hyper box. The walk stops
refining where the tracer does (the depth bound: terminating rules, or the box
itself for a graftal), so the boxes bound exactly what the tracer can reach."""
from __future__ import annotations

import numpy as np
from numba import njit

from ..graph.model import (CALC, INTERSECTION, MATERIAL, PAINT, PRIMITIVE, SELECT,
                           TRANSFORM, UNION)
from . import vm
from .nodes import node_affine, pick_rule, run_calc, table_slot
from .fractals import A_R
from .primitives import BOXES, FRACTAL_MIN

NODE, SLOT, LEVEL, PHASE, CUT = range(5)


@njit(cache=True, error_model="numpy")
def _transform_box(m, b, out):
    if b[0] > b[3]:
        out[:] = b
        return
    for i in range(3):
        lo = m[i, 3]
        hi = m[i, 3]
        for j in range(3):
            a = m[i, j]
            if a > 0.0:
                lo += a * b[j]
                hi += a * b[j + 3]
            elif a < 0.0:
                lo += a * b[j + 3]
                hi += a * b[j]
        out[i] = lo
        out[i + 3] = hi


@njit(cache=True, error_model="numpy")
def _unite(acc, b):
    for a in range(3):
        acc[a] = min(acc[a], b[a])
        acc[a + 3] = max(acc[a + 3], b[a + 3])


@njit(cache=True, error_model="numpy")
def _record(level, node, h, box, table, keys, used, vals, per_level):
    """Count the instance at its level; keep its box in the table if its level is within
    table[0], the deepest level kept. When the table would pass table[1] entries, its
    deepest level is dropped (table[0] lowered): the levels kept in the end are the
    most that fit, all of them complete, as if they had been known in advance."""
    if level < per_level.shape[0]:
        per_level[level] += 1
    if level > table[0]:
        return
    while table[2] + 1 > table[1] and table[0] >= 0:
        _drop_level(table[0], keys, used, vals)
        table[2] -= table[3 + table[0]]
        table[3 + table[0]] = 0
        table[0] -= 1
    if level > table[0]:
        return
    key = vm.mix(h, node)
    slot = table_slot(keys, used, key)
    if not used[slot]:
        table[2] += 1
        table[3 + level] += 1
    used[slot] = 1 + level          # 0: empty; else the entry's level + 1
    keys[slot] = key
    vals[slot, :] = box


@njit(cache=True, error_model="numpy")
def _drop_level(level, keys, used, vals):
    """Delete every entry of `level` (used == level + 1), keeping every other entry
    reachable: linear-probing deletion that moves later entries of a run back (Knuth's
    Algorithm R)."""
    mask = keys.shape[0] - 1
    for i in range(keys.shape[0]):
        while used[i] == level + 1:
            hole = i
            j = i
            while True:
                j = (j + 1) & mask
                if not used[j]:
                    break
                home = np.int64(keys[j] & np.uint64(mask))
                # the entry at j may move into the hole unless its home lies cyclically
                # in (hole, j]
                if (hole <= j and (home <= hole or home > j)) or \
                        (hole > j and home <= hole and home > j):
                    keys[hole] = keys[j]
                    used[hole] = used[j]
                    vals[hole, :] = vals[j]
                    hole = j
            used[hole] = 0


@njit(cache=True, error_model="numpy")
def walk(flat, max_depth, budget, capacity, boxes, table, keys, used, vals, per_level, changed):
    """Fill boxes[n] (pre-set to empty) with the union of node n's instance boxes, and the
    table (keys, used, vals) with the box of every S-node instance and operator operand
    of the top derivation levels that fit (see _record; `table` is its bookkeeping),
    keyed by its instance hash; per_level counts them by level, changed[0] the instances
    that the depth bound finished otherwise than their own selection would have.
    Returns the node visits made, or -1 if the visit budget or the stack capacity ran out."""
    fr = np.zeros((capacity, 5), dtype=np.int64)
    hs = np.zeros(capacity, dtype=np.uint64)
    params = np.full((capacity, flat.n_params), np.nan)
    acc = np.empty((capacity, 6))          # each frame's instance box so far
    tmp = np.empty(6)
    stack = np.empty(flat.max_stack)
    args = np.empty(12)
    m34 = np.empty((3, 4))
    fr[0, NODE] = flat.root
    hs[0] = vm.ROOT_HASH
    sp = 1
    visits = 0
    while sp > 0:
        f = sp - 1
        node = fr[f, NODE]
        kind = flat.kind[node]
        phase = fr[f, PHASE]
        if phase == 0:
            visits += 1
            if visits > budget:
                return -1
            acc[f, :3] = np.inf
            acc[f, 3:] = -np.inf
        child = -1
        if kind == PRIMITIVE:
            if flat.code[node] >= FRACTAL_MIN:
                r = flat.fractal[node, A_R]
                acc[f, :3] = -r
                acc[f, 3:] = r
            else:
                acc[f, :] = BOXES[flat.code[node]]
        elif kind == SELECT:
            if phase == 0:
                level = fr[f, LEVEL] + 1
                fr[f, LEVEL] = level
                if level > max_depth:
                    fr[f, CUT] = 1
                if fr[f, CUT] == 1:
                    r = flat.term_rule[node]
                    if level > 4 * max_depth + 64:
                        r = -1          # a terminating rule that keeps recursing: stopped
                    if r != pick_rule(flat, node, params, fr[f, SLOT], hs[f], stack):
                        changed[0] += 1     # the bound changed what this instance is
                    if r < 0:
                        r = -1          # a graftal: bounded by its own box (no growth)
                else:
                    r = pick_rule(flat, node, params, fr[f, SLOT], hs[f], stack)
                if r >= 0:
                    child = r
                    fr[f, PHASE] = 1 + r
            else:
                _unite(acc[f], acc[f + 1])
                _record(fr[f, LEVEL], node, hs[f], acc[f], table, keys, used, vals, per_level)
        elif kind == TRANSFORM or kind == CALC or kind == PAINT or kind == MATERIAL:
            if phase == 0:
                child = 0
                fr[f, PHASE] = 1
            elif kind == TRANSFORM:
                if node_affine(flat, node, params, fr[f, SLOT], hs[f], stack, args, m34):
                    _transform_box(m34, acc[f + 1], tmp)
                    acc[f, :] = tmp
                else:               # non-finite arguments: the tracer empties the instance
                    acc[f, :3] = np.inf
                    acc[f, 3:] = -np.inf
            else:
                acc[f, :] = acc[f + 1]
        else:   # UNION, INTERSECTION, DIFFERENCE: children one by one
            if phase > 0:
                b = acc[f + 1]
                # the operand's own box, in this operator's frame, for culling it unexpanded
                _record(fr[f, LEVEL], node, hs[f + 1], b, table, keys, used, vals, per_level)
                if phase == 1 or kind == UNION:
                    _unite(acc[f], b)
                elif kind == INTERSECTION:
                    for a in range(3):
                        acc[f, a] = max(acc[f, a], b[a])
                        acc[f, a + 3] = min(acc[f, a + 3], b[a + 3])
            if phase < flat.child_count[node]:
                child = phase
                fr[f, PHASE] = phase + 1
        if child >= 0:
            if sp >= capacity:
                return -1
            g = sp
            fr[g, :] = fr[f, :]
            fr[g, NODE] = flat.children[flat.child_start[node] + child]
            fr[g, PHASE] = 0
            hs[g] = hs[f]
            if kind == SELECT or flat.child_count[node] > 1:
                hs[g] = vm.edge_hash(hs[f], node, child)
            if kind == CALC:
                run_calc(flat, node, params, fr[f, SLOT], g, hs[f], stack)
                fr[g, SLOT] = g
            sp += 1
            continue
        if acc[f, 0] > acc[f, 3] or acc[f, 1] > acc[f, 4] or acc[f, 2] > acc[f, 5]:
            acc[f, :3] = np.inf         # normalise empty
            acc[f, 3:] = -np.inf
        _unite(boxes[node], acc[f])
        sp -= 1
    return visits


TABLE_SLOTS = 1 << 19      # instance boxes kept: ~30 MB at most, whatever the order
BUDGET = 60_000_000        # node visits of one walk: about 12 s on one core


def empty_table(slots: int = 2):
    return (np.zeros(slots, dtype=np.uint64), np.zeros(slots, dtype=np.int16),
            np.zeros((slots, 6)))


FIRST_DEPTH = 4        # the first walk, which measures how fast the instances grow


def walk_boxes(graph, max_depth: int = 64, budget: int | None = None, instances: bool = False):
    """(n, 6) hyper boxes of every node by visiting every instance, whether they are
    complete, the table of per-instance boxes of the top derivation levels (with
    `instances`: as many levels as fit half of TABLE_SLOTS, as (keys, used, vals) for the
    tracer), and the derivation depth they hold.

    When the instances down to max_depth are more than `budget` node visits, the boxes
    stop at the deepest depth whose instances fit, like --max-depth there: the tracer
    must then finish instances at that depth too, or it would reach instances that no
    box holds. The depth is found by walking to depth FIRST_DEPTH and one deeper, and then
    as deep as the growth of the visits from walk to walk predicts will fit. If not even
    the first walk fits, every node is left unbounded, which is always safe (and slow)."""
    from ..graph.flat import flatten_graph
    budget = BUDGET if budget is None else budget
    n = len(graph.nodes)
    empty = np.tile([np.inf, np.inf, np.inf, -np.inf, -np.inf, -np.inf], (n, 1))
    flat = flatten_graph(graph, empty)
    # a graftal's instances are bounded at the depth bound by nothing: no shallower bound
    graftal = (flat.term_rule[flat.kind == SELECT] < 0).any()
    depth = max_depth if graftal else min(max_depth, FIRST_DEPTH)
    best = last = None
    while True:
        boxes, visits, changed, table = _walk_to(flat, empty, depth, max_depth, budget,
                                                 instances)
        if visits < 0:
            break
        best = boxes, table, depth
        if depth == max_depth or changed == 0:
            # the bound changed nothing: these are the boxes of every depth
            return boxes, True, table, max_depth
        if last is None:
            deeper = depth + 1          # a second walk, to see how the visits grow
        else:
            growth = max(1.0, visits / max(last[1], 1)) ** (1.0 / (depth - last[0]))
            deeper, cost = depth, float(visits)
            while deeper < max_depth and cost * growth <= budget:
                cost *= growth
                deeper += 1
            if deeper == depth:
                break                   # the next depth would not fit: stop here
        last = depth, visits
        depth = deeper
    if best is None:
        boxes = np.tile([-np.inf, -np.inf, -np.inf, np.inf, np.inf, np.inf], (n, 1))
        return boxes, False, empty_table(), max_depth
    return best[0], True, best[1], best[2]


def _walk_to(flat, empty, depth: int, max_depth: int, budget: int, instances: bool):
    """One walk to `depth`: boxes, visits (-1: over budget), how many instances the depth
    bound changed, table."""
    n = empty.shape[0]
    boxes = empty.copy()
    capacity = (max_depth + 2) * (n + 2) + 16     # as deep a stack as the full walk's
    per_level = np.zeros(depth + 2, dtype=np.int64)
    table = empty_table(TABLE_SLOTS if instances else 2)
    # [deepest level kept, most entries, entries, entries by level...]
    book = np.zeros(3 + depth + 2, dtype=np.int64)
    book[0] = depth + 1 if instances else -1
    book[1] = TABLE_SLOTS // 2
    changed = np.zeros(1, dtype=np.int64)
    visits = walk(flat, depth, budget, capacity, boxes, book, *table, per_level, changed)
    if instances and book[0] < 0:
        table = empty_table()           # not even the root's level fits
    return boxes, visits, int(changed[0]), table
