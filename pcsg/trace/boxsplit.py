"""The bounding walk on every core: one walk from the root down to the first derivation
level with enough S-node instances (the split level) collects them; their subtrees,
which share nothing, are walked on threads (jit.on_threads), each into boxes, counts
and a table buffer of its own; a second walk of the top levels takes their boxes where
it meets them. Unions, sums and the table's kept levels do not depend on which thread walked
what, so the results are those of one walk from the root, at any thread count."""
from __future__ import annotations

import numpy as np

from . import vm
from .boxwalk import (COLLECT, CONSUME, STOPPED, add_counts, new_counts, walk, walk_in,
                      walk_scratch)
from .balls import ROW
from .instance_table import ENTRY, empty_table, gather
from .jit import share, watched

MAX_ITEMS = 8192            # instances one split level may have
ITEMS_PER_WORKER = 64       # enough that the threads' shares come out even
DEEPEST_SPLIT = 64          # levels searched for them: a binary tree has 128 at level 7


def items_for(flat, count: int):
    """Arrays for `count` split instances: (node, level above, cut), hash, parameters,
    box and ball (trace/balls.py)."""
    return (np.zeros((count, 3), dtype=np.int64), np.zeros(count, dtype=np.uint64),
            np.zeros((count, flat.n_params)), np.zeros((count, ROW)))


def new_watch(workers: int) -> np.ndarray:
    """A split walk's watch: [0] its stop flag; [1 + w] the visits worker w has told
    (boxwalk.walk); [1 + workers + w] the subtrees w has finished and [1 + 2 workers + w]
    their visits; [-1] the subtrees (0 until the split level is found)."""
    return np.zeros(2 + 3 * workers, dtype=np.int64)


def watched_visits(watch: np.ndarray, workers: int) -> int:
    return int(watch[1:1 + workers].sum())


def predicted_visits(watch: np.ndarray, workers: int) -> int | None:
    """The walk's visits as its finished subtrees predict them (their mean times the
    subtrees), once every worker has finished one; else None. The visits of walks that
    grow as expected say as much, but a derivation that ends above the depth walked to
    (the terrain at 11 walks to 13) makes 4 times fewer than that depth would."""
    count = int(watch[-1])
    done = watch[1 + workers:1 + 2 * workers]
    if count < 2 or (done == 0).any():
        return None
    return int(watch[1 + 2 * workers:1 + 3 * workers].sum() / done.sum() * count)


def walk_split(flat, depth: int, budget: int, capacity: int, boxes, book, per_level,
               changed, workers: int, watch=None, tick=None):
    """walk from the root into the given boxes and counts, the subtrees below the split
    level on `workers` threads; returns the visits (-1: over budget or stack, STOPPED:
    watch[0] was set) and the entries of the levels that `book` keeps, as a list (keys,
    used, vals; None unless the walk ended). The long walks run on helper threads
    (jit.watched): watch (new_watch) is their stop flag and their progress, tick() is
    called while they run.

    Every walk appends its entries to a buffer of its own, the top walk too (the root as
    its instance), and the entries of the levels kept are listed once they are all known:
    a hashed table of every slot, touched all over, made each of the walks that only
    measure how the instances grow fault in 30 MiB. The tracer hashes the list into its
    own rows (tracer_rows)."""
    if watch is None:
        watch = new_watch(workers)
    level, count, items = _split_level(flat, depth, budget, capacity, workers, watch)
    watch[-1] = count
    # the buffers: one per worker and the top walk's last, each with room for every
    # entry the table may keep, all of which one of them may hold. Not zeroed: entries
    # are appended and read below bbook[b, 2] only, and zeroing 30 MB a walk took 7 ms
    # (a freed buffer comes back from the heap, so calloc clears it)
    shares = workers if count >= 2 else 0
    room = int(book[1]) if book[0] >= 0 else 0
    bkeys = np.empty((shares + 1, room), dtype=np.uint64)
    bused = np.empty((shares + 1, room), dtype=np.int16)
    bvals = np.empty((shares + 1, room, ENTRY), dtype=np.float32)
    bbook = np.zeros((shares + 1, book.shape[0]), dtype=np.int64)
    bbook[:, :2] = book[:2]
    items = _with_root(flat, items)
    root = len(items[0]) - 1
    if count < 2:
        top = watched([(walk, (flat, depth, budget, capacity, boxes, bbook[0], bkeys[0],
                               bused[0], bvals[0], per_level, changed,
                               np.zeros(3, dtype=np.int64), *items, root, watch, 1))],
                      watch, tick)[0]
        wvisits = np.zeros(0, dtype=np.int64)
    else:
        wboxes = np.repeat(boxes[None], workers, axis=0)
        wlevels = np.zeros((workers, per_level.shape[0]), dtype=np.int64)
        wchanged = new_counts(workers)
        wvisits = np.zeros(workers, dtype=np.int64)
        watched([(_walk_share, (w, workers, flat, depth, budget, capacity, count, *items,
                                wboxes, bbook, bkeys, bused, bvals, wlevels, wchanged,
                                wvisits, watch))
                 for w in range(workers)], watch, tick)
        split = np.array([CONSUME, level, 0], dtype=np.int64)
        top = walk(flat, depth, budget, capacity, boxes, bbook[-1], bkeys[-1], bused[-1],
                   bvals[-1], per_level, changed, split, *items, root, watch, 1)
        np.minimum(boxes[:, :3], wboxes[:, :, :3].min(axis=0), out=boxes[:, :3])
        np.maximum(boxes[:, 3:], wboxes[:, :, 3:].max(axis=0), out=boxes[:, 3:])
        per_level += wlevels.sum(axis=0)
        add_counts(changed, wchanged)
    if top == STOPPED or (wvisits == STOPPED).any():
        return STOPPED, None
    if top < 0 or (wvisits < 0).any() or top + wvisits.sum() > budget:
        return -1, None
    # the instances of the levels kept, whatever the thread count
    table = gather(per_level, book, bkeys, bused, bvals, bbook) if book[0] >= 0 else \
        empty_table(0)
    return int(top + wvisits.sum()), table


def _with_root(flat, items):
    """The split instances' items (or none) and the root's last, as the instance the
    top walk starts from: level 0, the root's hash, no parameter set."""
    count = 0 if items is None else len(items[0])
    out = items_for(flat, count + 1)
    if items is not None:
        for a, b in zip(out, items):
            a[:count] = b
    out[0][count] = (flat.root, 0, 0)
    out[1][count] = vm.ROOT_HASH
    out[2][count] = np.nan
    return out


def _split_level(flat, depth: int, budget: int, capacity: int, workers: int, watch):
    """The shallowest level with ITEMS_PER_WORKER instances per thread (or the deepest
    with at most MAX_ITEMS), its instance count and their items; count < 2 when the
    walk is better not split."""
    if workers < 2:
        return 0, 0, None
    items = items_for(flat, MAX_ITEMS)
    boxes = np.empty((flat.box.shape[0], 6))
    levels = np.zeros(depth + 2, dtype=np.int64)
    book = np.array([-1, 0, 0], dtype=np.int64)         # keeps no entry
    none = empty_table(1)

    def collect(level):
        """The instances of `level` into items: (walk's result, how many)."""
        split = np.array([COLLECT, level, 0], dtype=np.int64)
        got = walk(flat, depth, budget, capacity, boxes, book, *none, levels,
                   new_counts(1)[0], split, *items, -1, watch, 1)
        return got, int(split[2])

    best = last = 0
    # not past DEEPEST_SPLIT: each level's collect walks every level above it again, and a
    # chain that never reaches ITEMS_PER_WORKER instances a level (one recursive call and a
    # sphere, 10,000 deep) took 49 s of quadratic collects, past --timeout and Ctrl-C
    for level in range(1, min(depth, DEEPEST_SPLIT) + 2):
        got, count = collect(level)
        if got < 0 or count == 0:
            break                   # too many to hold, over budget, or the system ended
        best, last = level, count
        if last >= ITEMS_PER_WORKER * workers:
            break
    if best == 0:
        return 0, 0, None
    if level != best:               # the arrays may hold some of a deeper level: again
        collect(best)
    return best, last, tuple(a[:last] for a in items)


@share
def _walk_share(w, workers, flat, depth, budget, capacity, count, items, item_hash,
                item_params, item_boxes, wboxes, bbook, bkeys, bused, bvals, wlevels,
                wchanged, wvisits, watch):
    """Worker w's subtrees: split instances w, w + workers, ..., with one scratch for all
    of them; wvisits[w] -1 when one of them ran out of budget or stack, STOPPED when
    watch[0] stopped it."""
    split = np.zeros(3, dtype=np.int64)
    fr, hs, params, acc, tmp, stack, args, m34 = walk_scratch(flat, capacity)
    for i in range(w, count, workers):
        if watch[0] != 0:       # between subtrees too: one may make fewer visits than a report
            wvisits[w] = STOPPED
            break
        got = walk_in(flat, depth, budget - wvisits[w], capacity, wboxes[w], bbook[w],
                      bkeys[w], bused[w], bvals[w], wlevels[w], wchanged[w], split,
                      items, item_hash, item_params, item_boxes, i, fr, hs, params, acc, tmp,
                      stack, args, m34, watch, 1 + w)
        if got < 0:
            wvisits[w] = got
            break
        wvisits[w] += got
        watch[1 + workers + w] += 1
        watch[1 + 2 * workers + w] = wvisits[w]
