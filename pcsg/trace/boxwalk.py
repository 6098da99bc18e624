"""Hyper-bounding boxes by visiting every instance (njit), for systems whose
instances are too many to memoise in Python: each instance's box is computed
bottom-up in its own frame, cut to a ball carried beside it where the system turns boxes
off their axes (trace/balls.py), and united into its node's hyper box. The walk stops
refining where the tracer does (the depth bound: terminating rules, or the box
itself for a graftal), so the boxes bound exactly what the tracer can reach. The walk
runs on every core, split below the first level with enough instances
(trace/boxsplit.py)."""
from __future__ import annotations

import numpy as np

from .dispatch import cached_jit
from ..limits import BOUNDS_BUDGET
from ..graph.model import (CALC, INTERSECTION, MATERIAL, PAINT, PRIMITIVE, SELECT,
                           TRANSFORM, UNION)
from ..graph import boxcache
from . import vm
from .jit import copy_into, inline, kernel, threads
from .instance_table import TABLE_SLOTS, append, empty_table, new_book
from .nodes import culprit, node_affine, pick_rule, run_calc, singular_map
from .fractals import A_R
from .balls import ROW, ball_of_box, map_ball, rotates, smaller_ball, tighten, unite_ball
from .primitives import BOXES, FRACTAL_MIN, HULL, HULL_COUNT, TRI1, TRI2

NODE, SLOT, LEVEL, PHASE, CUT = range(5)
COLLECT, CONSUME = 1, 2    # split modes of walk
STOPPED = -3               # a walk's result when watch[0] asked it to stop
TELL_EVERY = 1 << 16       # visits between a walk's reports to its watch (a few ms)
# a walk's counts: changed[CHANGED] instances the depth bound finished otherwise, then for
# each kind of fault (a map with non-finite arguments, a singular map: the tracer empties
# the instance) the instances it emptied and the least such T-node (NO_NODE if none), at
# changed[FAULTS + 2 * kind] and the column after it
CHANGED, FAULTS = 0, 1
NONFINITE, SINGULAR = 0, 1
KINDS = 2
NO_NODE = 1 << 62


@inline
def _transform_box(m, b, out):
    if b[0] > b[3]:
        copy_into(out, b)
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


@inline
def _unite(acc, b):
    for a in range(3):
        acc[a] = min(acc[a], b[a])
        acc[a + 3] = max(acc[a + 3], b[a + 3])


@inline
def _close(boxes, node, b):
    """A node's instance box done: an empty one normalised, then united into the node's
    hyper box."""
    if b[0] > b[3] or b[1] > b[4] or b[2] > b[5]:
        _empty(b)
    _unite(boxes[node], b)


@inline
def _primitive_box(flat, node, out, balls):
    """A primitive's object box, and the ball round it where the walk carries balls."""
    if flat.code[node] >= FRACTAL_MIN:
        r = flat.fractal[node, A_R]
        out[:3] = -r
        out[3:6] = r
    else:
        for a in range(6):
            out[a] = BOXES[flat.code[node], a]
    if balls:
        ball_of_box(out)


@inline
def _empty(row):
    """An empty box, and in a row with a ball (trace/balls.py) an empty ball: its radius
    -inf."""
    row[:3] = np.inf
    row[3:] = -np.inf


@inline
def _mapped_primitive_box(flat, prim, m, inner, out):
    """The box of primitive node `prim` under the map m, its object box being `inner`:
    its mapped corners' box for a polytope (exact), else inner's image."""
    code = flat.code[prim]
    if code == TRI1 or code == TRI2:        # corners 0, s e_x, s e_y: the terrain's leaves
        s = 1.0 if code == TRI1 else -1.0
        for i in range(3):
            a = s * m[i, 0]
            b = s * m[i, 1]
            out[i] = m[i, 3] + min(0.0, min(a, b))
            out[i + 3] = m[i, 3] + max(0.0, max(a, b))
        return
    k = HULL_COUNT[code] if code < FRACTAL_MIN else 0
    if k == 0:
        _transform_box(m, inner, out)
        return
    for i in range(3):
        lo = np.inf
        hi = -np.inf
        for c in range(k):
            v = m[i, 3] + m[i, 0] * HULL[code, c, 0] + m[i, 1] * HULL[code, c, 1] \
                + m[i, 2] * HULL[code, c, 2]
            lo = min(lo, v)
            hi = max(hi, v)
        out[i] = lo
        out[i + 3] = hi


@inline
def _fault(flat, changed, kind, node, params, slot, h, stack, args, m34):
    """A map with non-finite arguments or a singular one (kind) emptied an instance of
    T-node `node`: the tracer empties it too, and no ray may ever reach it to say so (its
    box is empty). Counted at the node of a fused run that fails so (nodes.culprit), as
    the tracer's note is: the run's head named `rotz(a)` of `rotz(a) move(0,0,ln(d))`."""
    at = culprit(flat, node, params, slot, h, stack, args, m34, kind + 1)
    changed[FAULTS + 2 * kind] += 1
    changed[FAULTS + 2 * kind + 1] = min(changed[FAULTS + 2 * kind + 1], at)


@inline
def _walk_chain(flat, f, capacity, boxes, fr, params, acc, hs, stack, args, m34, changed,
                balls):
    """The run of single-child steps from frame f down to its primitive (Flat.chain) in
    two loops, down and up, with the arithmetic of the general walk's frames but not its
    dispatch per frame: the terminating rules, three quarters of the terrain's visits.
    Where the walk carries balls, the chain's head takes the ball round its box: one
    primitive's box mapped by a few maps, the first of them exactly (its corners), which
    a ball carried down the chain would bound tighter only under several turns; the
    chains are most of a walk's visits.
    Returns the frames it took below f, -1 if the stack's capacity ran out."""
    g = f
    while flat.kind[fr[g, NODE]] != PRIMITIVE:
        if g + 1 >= capacity:
            return -1
        node = fr[g, NODE]
        fr[g + 1, NODE] = flat.children[flat.child_start[node]]
        fr[g + 1, SLOT] = fr[g, SLOT]
        if flat.kind[node] == CALC and flat.defer[node] == 0:
            run_calc(flat, node, params, fr[g, SLOT], g + 1, hs[f], stack)
            fr[g + 1, SLOT] = g + 1
        g += 1
    _primitive_box(flat, fr[g, NODE], acc[g], False)
    _close(boxes, fr[g, NODE], acc[g])
    bare = True         # acc[k + 1] is the primitive's object box
    for k in range(g - 1, f - 1, -1):
        node = fr[k, NODE]
        if flat.kind[node] != TRANSFORM:
            copy_into(acc[k], acc[k + 1])
        else:
            if not node_affine(flat, node, params, fr[k, SLOT], hs[f], stack, args, m34):
                _empty(acc[k])
                _fault(flat, changed, NONFINITE, node, params, fr[k, SLOT], hs[f], stack, args,
                       m34)
            elif singular_map(m34):
                _empty(acc[k])
                _fault(flat, changed, SINGULAR, node, params, fr[k, SLOT], hs[f], stack, args,
                       m34)
            elif bare:
                _mapped_primitive_box(flat, fr[g, NODE], m34, acc[k + 1], acc[k])
            else:
                _transform_box(m34, acc[k + 1], acc[k])
            bare = False
        _close(boxes, node, acc[k])
    if balls:
        ball_of_box(acc[f])
    return g - f


@inline
def draws_hashes(flat):
    """Whether a block, argument or selection draws rand() from its instance's hash."""
    for r in range(flat.vm_code.shape[0]):
        if flat.vm_code[r, 0] == vm.RAND:
            return True
    return False


@cached_jit(error_model="numpy")
def walk_scratch(flat, capacity):
    """A walk's frames (fr), their hashes (hs), parameter rows, instance boxes (acc) and
    the small arrays of its steps, for walk_in: allocated once per thread, not per
    subtree (a walk's rows of parameters alone are a megabyte). Not initialised: walk_in
    writes every row before it reads it, and filling them touched every page of rows
    that a walk mostly never reaches (its stack is as deep as the graph is long)."""
    return (np.empty((capacity, 5), dtype=np.int64), np.empty(capacity, dtype=np.uint64),
            np.empty((capacity, flat.n_params)), np.empty((capacity, ROW)),
            np.empty(ROW), np.empty(flat.max_stack), np.empty(12), np.empty((3, 4)))


@cached_jit(error_model="numpy", nogil=True)
def walk(flat, max_depth, budget, capacity, boxes, book, keys, used, vals, per_level, changed,
         split, items, item_hash, item_params, item_boxes, first, watch, tell):
    """walk_in with scratch of its own."""
    fr, hs, params, acc, tmp, stack, args, m34 = walk_scratch(flat, capacity)
    return walk_in(flat, max_depth, budget, capacity, boxes, book, keys, used, vals,
                   per_level, changed, split, items, item_hash, item_params, item_boxes, first,
                   fr, hs, params, acc, tmp, stack, args, m34, watch, tell)


@kernel
def walk_in(flat, max_depth, budget, capacity, boxes, book, keys, used, vals, per_level,
            changed, split, items, item_hash, item_params, item_boxes, first, fr, hs, params,
            acc, tmp, stack, args, m34, watch, tell):
    """Fill boxes[n] (pre-set to empty) with the union of node n's instance boxes, and
    append to the buffer (keys, used, vals) the box of every S-node instance and operator
    operand of the top derivation levels that fit (see instance_table.append; `book` is
    its bookkeeping), keyed by its instance hash; per_level counts them by level, changed
    the instances that the depth bound finished otherwise than their own selection would
    have, and the faults (CHANGED, FAULTS: see there). Returns the node visits made, or -1
    if the visit budget or the stack capacity ran out.

    The walk starts at the root when `first` is -1, else at the S-node instance
    items[first] (node, level above it, cut; its hash and parameters beside) and leaves
    its box in item_boxes[first]. split = [mode, level, count]: mode COLLECT stores the
    instances that reach `level` in the items arrays instead of entering them (returns -2
    when they are more than the arrays hold), CONSUME takes their boxes from item_boxes,
    in the same order (trace/boxsplit.py).

    Every TELL_EVERY visits it adds the visits since its last report to watch[tell], and
    returns STOPPED if watch[0] is set: the thread that waits for the walk reads the one
    for progress and sets the other on Ctrl-C or a timeout (jit.watched).

    The scratch arrays come from walk_scratch, and may hold an earlier walk's values:
    every frame's row is written as the frame is pushed, and every parameter row before
    it is read, but for the first, set here. Compiled without reference counting (as the
    tracer's walks are, jit.py): with it, the atomic counts of the arrays its steps pass
    around were two thirds of this walk's time on two threads."""
    fr[0, :] = 0
    from_item = first >= 0
    draws = draws_hashes(flat)
    balls = rotates(flat)
    if from_item:
        fr[0, NODE] = items[first, 0]
        fr[0, LEVEL] = items[first, 1]
        fr[0, CUT] = items[first, 2]
        hs[0] = item_hash[first]
        copy_into(params[0], item_params[first])
    else:
        fr[0, NODE] = flat.root
        hs[0] = vm.ROOT_HASH
        params[0, :] = np.nan
    sp = 1
    visits = 0
    told = 0
    while sp > 0:
        f = sp - 1
        node = fr[f, NODE]
        kind = flat.kind[node]
        phase = fr[f, PHASE]
        chained = False
        if phase == 0:
            visits += 1
            if visits > budget:
                return -1
            if visits - told >= TELL_EVERY:
                watch[tell] += visits - told
                told = visits
                if watch[0] != 0:
                    return STOPPED
            _empty(acc[f])
            if flat.chain[node] != 0:
                steps = _walk_chain(flat, f, capacity, boxes, fr, params, acc, hs, stack,
                                    args, m34, changed, balls)
                visits += steps
                if steps < 0 or visits > budget:
                    return -1
                chained = True
        child = -1
        if chained:
            pass                # closed by _walk_chain, with every frame of its chain
        elif kind == PRIMITIVE:
            _primitive_box(flat, node, acc[f], balls)
        elif kind == SELECT:
            if phase == 0:
                level = fr[f, LEVEL] + 1
                fr[f, LEVEL] = level
                if split[0] != 0 and level == split[1]:
                    # an instance of the split level: its own walk enters and counts it
                    visits -= 1
                    i = split[2]
                    split[2] += 1
                    if split[0] == COLLECT:
                        if i >= items.shape[0]:
                            return -2
                        items[i, 0] = node
                        items[i, 1] = level - 1
                        items[i, 2] = fr[f, CUT]
                        item_hash[i] = hs[f]
                        copy_into(item_params[i], params[fr[f, SLOT]])
                    else:
                        copy_into(acc[f], item_boxes[i])
                else:
                    if level > max_depth:
                        fr[f, CUT] = 1
                    if fr[f, CUT] == 1:
                        r = flat.term_rule[node]
                        if level > 4 * max_depth + 64:
                            r = -1          # a terminating rule that keeps recursing: stopped
                        if r != pick_rule(flat, node, params, fr[f, SLOT], hs[f], stack):
                            changed[CHANGED] += 1   # the bound changed what this instance is
                        if r < 0:
                            r = -1          # a graftal: bounded by its own box (no growth)
                    else:
                        r = pick_rule(flat, node, params, fr[f, SLOT], hs[f], stack)
                    if r >= 0:
                        child = r
                        fr[f, PHASE] = 1 + r
            else:
                copy_into(acc[f], acc[f + 1])
                append(fr[f, LEVEL], hs[f], node, -1, node, acc[f], book, keys, used, vals,
                       per_level)
        elif kind == TRANSFORM or kind == CALC or kind == PAINT or kind == MATERIAL:
            child = 0           # met at phase 0 only: the loop after the pop finishes them
            fr[f, PHASE] = 1
        else:   # UNION, INTERSECTION, DIFFERENCE: children one by one
            if phase > 0:
                b = acc[f + 1]
                # the operand's own box, in this operator's frame, for culling it unexpanded
                append(fr[f, LEVEL], hs[f], node, phase - 1, fr[f + 1, NODE], b, book, keys,
                       used, vals, per_level)
                if phase == 1:
                    copy_into(acc[f], b)
                elif kind == UNION:
                    _unite(acc[f], b)
                    if balls:
                        unite_ball(acc[f], b)
                elif kind == INTERSECTION:
                    for a in range(3):
                        acc[f, a] = max(acc[f, a], b[a])
                        acc[f, a + 3] = min(acc[f, a + 3], b[a + 3])
                    if balls:
                        smaller_ball(acc[f], b)
            if phase < flat.child_count[node]:
                child = phase
                fr[f, PHASE] = phase + 1
        if child >= 0:
            if sp >= capacity:
                return -1
            g = sp
            copy_into(fr[g], fr[f])
            fr[g, NODE] = flat.children[flat.child_start[node] + child]
            fr[g, PHASE] = 0
            hs[g] = hs[f]
            # below the table's deepest level only rand() reads a hash (draws); the
            # collecting walk hands its instances' hashes to the walks that keep entries
            if (kind == SELECT or flat.child_count[node] > 1) and (
                    draws or split[0] == COLLECT or fr[f, LEVEL] <= book[0]):
                hs[g] = vm.edge_hash(hs[f], node, child)
            if kind == CALC and flat.defer[node] == 0:
                # a deferrable block only colours (graph/defer.py): no box depends on it
                run_calc(flat, node, params, fr[f, SLOT], g, hs[f], stack)
                fr[g, SLOT] = g
            sp += 1
            continue
        if not chained:
            if balls and kind != PRIMITIVE and kind != SELECT:
                tighten(acc[f])     # an operator's: its operands' balls united
            _close(boxes, node, acc[f])
        sp -= 1
        # the single-child nodes above it finish here, each at once, rather than on a turn
        # of the loop of its own with the dispatch on its kind and phase (the T- and C-node
        # above each operand of the terrain's unions: the walk of the terrain at 12 took 7 %
        # less time)
        while sp > 0:
            p = sp - 1
            up = fr[p, NODE]
            above = flat.kind[up]
            if above == TRANSFORM:
                bad = NONFINITE
                if node_affine(flat, up, params, fr[p, SLOT], hs[p], stack, args, m34):
                    bad = SINGULAR if singular_map(m34) else -1
                if bad < 0:
                    _transform_box(m34, acc[p + 1], tmp)
                    if balls:
                        map_ball(m34, acc[p + 1], tmp)
                        tighten(tmp)
                    copy_into(acc[p], tmp)
                else:               # the tracer empties the instance
                    _empty(acc[p])
                    _fault(flat, changed, bad, up, params, fr[p, SLOT], hs[p], stack, args, m34)
            elif above == CALC or above == PAINT or above == MATERIAL:
                copy_into(acc[p], acc[p + 1])
            else:
                break
            _close(boxes, up, acc[p])
            sp -= 1
    if from_item:
        copy_into(item_boxes[first], acc[0])
    watch[tell] += visits - told
    return visits


FIRST_DEPTH = 4        # the first walk, which measures how fast the instances grow
SHALLOWEST = 1_000_000  # the budget of a walk to depth 0 at least


def walk_boxes(graph, max_depth: int = 64, budget: int | None = None, instances: bool = False,
               poll=None, cache: bool = False, faults: list | None = None):
    """(n, 6) hyper boxes of every node by visiting every instance, whether they are
    complete, the table of per-instance boxes of the top derivation levels (with
    `instances`: as many levels as fit half of TABLE_SLOTS, as (keys, used, vals) for the
    tracer), and the derivation depth they hold.

    When the instances down to max_depth are more than `budget` node visits, the boxes
    stop at the deepest depth whose instances fit, like --max-depth there: the tracer
    must then finish instances at that depth too, or it would reach instances that no
    box holds. The depth is found by walking to depth FIRST_DEPTH and one deeper, and then
    as deep as the growth of the visits from walk to walk predicts will fit; where the
    first walk does not fit, to the deepest depth below it that does (depth 0 with a
    budget of SHALLOWEST at least). If not even that fits, every node is left unbounded,
    which is always safe (and slow).
    A graftal is bounded at max_depth or not at all (no shallower depth bounds its deeper
    instances), so when the growth predicts that max_depth will not fit it is left
    unbounded without the walk that would find out: for a graftal that neither ends nor
    contracts that walk spent the whole budget, 15 s of every `pcsg stats` and render.

    poll(visits, expected), if given, is called every 50 ms while a walk runs, with the
    visits it has made and those predicted for it: by the subtrees of the split walk it
    has finished (boxsplit.predicted_visits), before that by the growth of the walks
    before it (None for the first two walks); an exception it raises, or Ctrl-C, stops
    the walk within milliseconds and is raised.

    With `cache`, the result of a long walk is kept on disk and read instead of walking
    again (graph/boxcache.py).

    `faults`, if given, gets the faults of the boxes' walk: for a map with non-finite
    arguments and for a singular one, (instances it emptied, the least such T-node), with
    count 0 where none (faults_of)."""
    budget = BOUNDS_BUDGET if budget is None else budget
    flat, empty = walk_flat(graph)
    k = None
    if cache and boxcache.enabled():
        k = boxcache.key(flat, max_depth, budget, instances, FIRST_DEPTH, TABLE_SLOTS)
        kept = boxcache.load(k)
        if kept is not None:
            result, found = kept
            if faults is not None:
                faults.append(found)
            return result
    result, visits, found = _walk_depths(flat, empty, max_depth, budget, instances, poll)
    if k is not None and visits >= boxcache.MIN_VISITS:
        boxcache.store(k, result, found)
    if faults is not None:
        faults.append(found)
    return result


def walk_flat(graph):
    """The Flat of the walks of every instance (this one and trace/leafwalk.py), and the
    empty node boxes it is made with: arguments and selections compiled (Flat.arg_fn),
    runs of T-nodes map by map. bounds.bound writes runs out as one matrix node first
    where it can (graph/fuse.py); composed in the walk (nodes.composed_affine), they made
    it slower."""
    from ..graph.flat import flatten_graph
    empty = np.tile([np.inf, np.inf, np.inf, -np.inf, -np.inf, -np.inf], (len(graph.nodes), 1))
    return flatten_graph(graph, empty, native_args=True, runs=False), empty


def _walk_depths(flat, empty, max_depth: int, budget: int, instances: bool, poll):
    """walk_boxes's result from the walks deeper and deeper, the visits they made, and
    the faults (faults_of) of the walk whose boxes it gives."""
    n = empty.shape[0]
    spent = 0
    graftal = (flat.term_rule[flat.kind == SELECT] < 0).any()
    depth = min(max_depth, FIRST_DEPTH)
    best = last = None
    expected = None
    while True:
        # depth 0 walks no S-node's rules, whatever the budget: --bounds-budget 1 gave
        # no box at all, and the terrain rendered for minutes
        boxes, visits, counts, table = _walk_to(
            flat, empty, depth, max_depth, budget if depth else max(budget, SHALLOWEST),
            instances, poll, expected)
        if visits < 0:
            table = None            # over budget: best's table is built again below
            spent += budget
            if best is None and last is None and not graftal and depth > 0:
                # not even the first walk fits: a shallower one may, and refining to it
                # beats no box at all (--bounds-budget 300 ran the terrain for minutes)
                depth -= 1
                continue
            break
        changed = int(counts[CHANGED])
        found = faults_of(counts)
        spent += visits
        if depth == max_depth or changed == 0:
            # the bound changed nothing: these are the boxes of every depth
            return (boxes, True, table, max_depth), spent, found
        if last is None:
            deeper = depth + 1          # a second walk, to see how the visits grow
        else:
            growth = max(1.0, visits / max(last[1], 1)) ** (1.0 / (depth - last[0]))
            deeper, cost = depth, float(visits)
            while deeper < max_depth and cost * growth <= budget:
                cost *= growth
                deeper += 1
            if graftal and deeper < max_depth:
                break                               # max_depth would not fit
            if deeper == depth:
                return (boxes, True, table, depth), spent, found   # the next would not fit
            expected = int(cost)
        if not graftal:
            # a list of its entries (boxsplit.walk_split), no slots to free: kept as it is
            best = boxes, table, depth, found
        table = None
        last = depth, visits
        depth = deeper
    if best is None:
        boxes = np.tile([-np.inf, -np.inf, -np.inf, np.inf, np.inf, np.inf], (n, 1))
        return (boxes, False, empty_table(), max_depth), spent, faults_of(new_counts(1)[0])
    return (best[0], True, best[1], best[2]), spent, best[3]


def _walk_to(flat, empty, depth: int, max_depth: int, budget: int, instances: bool,
             poll=None, expected: int | None = None):
    """One walk to `depth`, on every core: boxes, visits (-1: over budget), its counts
    (CHANGED, FAULTS ...), table."""
    from .boxsplit import new_watch, predicted_visits, walk_split, watched_visits
    n = empty.shape[0]
    boxes = empty.copy()
    capacity = (max_depth + 2) * (n + 2) + 16     # as deep a stack as the full walk's
    per_level = np.zeros(depth + 2, dtype=np.int64)
    book = new_book(depth + 1 if instances else -1, TABLE_SLOTS // 2)
    changed = new_counts(1)[0]
    workers = threads()
    watch = new_watch(workers)

    def tick():
        predicted = predicted_visits(watch, workers)
        poll(watched_visits(watch, workers), expected if predicted is None else
             min(predicted, expected or budget, budget))
    visits, table = walk_split(flat, depth, budget, capacity, boxes, book, per_level,
                               changed, workers, watch, None if poll is None else tick)
    return boxes, visits, changed, table


def new_counts(walks: int) -> np.ndarray:
    """The counts (CHANGED, FAULTS ...) of `walks` walks, one row each."""
    counts = np.zeros((walks, FAULTS + 2 * KINDS), dtype=np.int64)
    counts[:, FAULTS + 1::2] = NO_NODE
    return counts


def faults_of(counts) -> tuple:
    """((instances, least T-node) of each kind of fault) of a walk's counts."""
    return tuple((int(counts[FAULTS + 2 * k]), int(counts[FAULTS + 2 * k + 1]))
                 for k in range(KINDS))


def add_counts(total: np.ndarray, rows: np.ndarray) -> None:
    """The counts of several walks into `total`, whatever walked what."""
    total[CHANGED] += rows[:, CHANGED].sum()
    for k in range(KINDS):
        total[FAULTS + 2 * k] += rows[:, FAULTS + 2 * k].sum()
        total[FAULTS + 2 * k + 1] = min(total[FAULTS + 2 * k + 1],
                                        rows[:, FAULTS + 2 * k + 1].min())
