"""The bounding walk's instance table: the boxes of the S-node instances and operator
operands of the top derivation levels, keyed by instance hash, for the tracer to cull
by (windows.instance_window). It keeps as many whole levels as fit: when it would pass
its entry limit it drops its deepest level.

Every walk appends its entries to a buffer of its own (a walk split over threads,
trace/boxsplit.py, cannot share one open-addressing table), and `gather` lists the
entries of the levels kept afterwards: a thread sees at most the instances the whole
walk sees, so its buffer holds every level the table can keep. The tracer's table is
hashed from that list (tracer_rows).

Boxes are kept as float32, rounded outwards: the tracer's rows are 32 bytes, half the
memory and cache lines of float64 ones. (2^21 slots, which hold one level more of the
terrain at 10 to 12, rendered it a third faster at 12 but cost its bounds more than they
saved at 9 and 10: tools/performance_notes.md.)"""
from __future__ import annotations

import numpy as np

from ..memory import zeroed
from .dispatch import cached_jit
from . import vm
from .jit import copy_into, inline, kernel, on_threads, share, threads
from .windows import table_slot
from .pad import pad_row

TABLE_SLOTS = 1 << 19      # instance boxes kept: 16 MB of rows at most, whatever the order
# an entry's values: its box (xmin, ymin, zmin, xmax, ymax, zmax) and its owner, the
# node whose hyper box holds it (an S-node, or an operator's operand)
OWNER = 6
ENTRY = 7
MIN_SLOTS_PER_WORKER = 1 << 14    # smaller tables are filled by one worker
ROW = 8                    # a slot as the tracer reads it: box (6 float32), key (2 columns)
KEY = 3                    # the key's column in the row's uint64 view


def empty_table(slots: int = 2, width: int = ENTRY):
    """A table of plain arrays, for the walks' own small ones and their buffers (a
    kernel's argument types stay those it was compiled for)."""
    return (np.zeros(slots, dtype=np.uint64), np.zeros(slots, dtype=np.int16),
            np.zeros((slots, width), dtype=np.float32))


def table_slots(entries: int) -> int:
    """The slots of a table for `entries` entries: a power of two, at least twice as
    many (a probe ends at an empty slot)."""
    return max(2, 1 << (2 * entries - 1).bit_length())


def _aligned_rows(slots: int) -> np.ndarray:
    buf = zeroed((slots * ROW + 16) * 4).view(np.float32)
    start = (-buf.ctypes.data % 64) // 4
    return buf[start:start + slots * ROW].reshape(slots, ROW)


def hashed(entries):
    """A hashed table (keys, used, vals) of the entries (keys, used, vals, slots) in that
    number of slots, the values' type kept: for tables probed outside the tracer
    (graph/states.py)."""
    keys, used, vals, slots = entries
    table = (np.zeros(slots, dtype=np.uint64), np.zeros(slots, dtype=np.int16),
             np.zeros((slots, vals.shape[1]), dtype=vals.dtype))
    _insert(keys, used, vals, *table)
    return table


@cached_jit(error_model="numpy")
def _insert(keys, used, vals, tkeys, tused, tvals):
    for i in range(keys.shape[0]):
        slot = table_slot(tkeys, tused, keys[i])
        tkeys[slot] = keys[i]
        tused[slot] = used[i]
        tvals[slot, :] = vals[i]


def tracer_rows(keys, used, vals, boxes, workers: int | None = None) -> dict:
    """The table as the tracer reads it (Flat's inst_* fields): the entries of (keys,
    used, vals), a list or a hashed table, hashed into 32-byte rows [box (6 float32) |
    key], aligned to a cache line, twice as many as the entries, key 0 marking an empty
    slot (an entry whose key is 0 is left out: the tracer then culls by its node's box).
    Each entry's box is padded (trace/pad.py) and cut to its owner's box in `boxes`, the
    nodes' padded boxes, in float64, then rounded outwards. inst_used holds each slot's
    level + 1 apart from the rows: the tracer probes by key alone.
    inst_deepest lets a walk skip the probes past the deepest level kept, which could only
    miss (the terrain at order 9 keeps 10 of its 12 levels). Filled by `workers` threads
    (default: as many as the render's, one for a small table); where an entry lands may
    depend on their number, what a probe finds does not."""
    rows = _aligned_rows(table_slots(int(np.count_nonzero(used))))
    levels = zeroed(2 * rows.shape[0]).view(np.int16)
    row_keys = rows.view(np.uint64)[:, KEY]
    if workers is None:
        workers = max(1, min(threads(), rows.shape[0] // MIN_SLOTS_PER_WORKER))
    spill = np.empty((workers, keys.shape[0]), dtype=np.int64)    # pages touched as used
    spilled = np.zeros(workers, dtype=np.int64)
    on_threads(_fill_share, workers, keys, used, vals, boxes, rows, row_keys, levels, spill,
               spilled)
    _put_spilled(keys, used, vals, boxes, rows, row_keys, levels, spill, spilled)
    return row_fields(rows, levels, int(levels.max(initial=0)) - 1)


def row_fields(rows: np.ndarray | None = None, levels: np.ndarray | None = None,
               deepest: int = -1) -> dict:
    """Flat's inst_* fields: views of `rows`, and `levels`; without arguments, a table of
    no entries."""
    if rows is None:
        rows, levels = _aligned_rows(2), np.zeros(2, dtype=np.int16)
    return dict(inst_keys=rows.view(np.uint64)[:, KEY], inst_used=levels,
                inst_boxes=rows, inst_deepest=np.int64(deepest))


@share
def _fill_share(w, workers, keys, used, vals, boxes, rows, row_keys, levels, spill, spilled):
    """tracer_rows's pass for worker w of `workers`: each live entry whose key hashes into
    the worker's part of the slots, padded, cut to its owner and rounded outwards into
    its slot (the same key twice: the later one). An entry whose probe would run into the
    next part is listed in spill[w] instead (their number in spilled[w]), for _put_spilled
    once every part is filled: the parts are written by one worker each, so the rows are
    the same whatever the timing. The table is filled in hash order, one cache miss an
    entry: two workers fill the terrain at 9's rows in 11 to 13 ms, one took 17."""
    n = row_keys.shape[0]
    lo = n * w // workers
    hi = n * (w + 1) // workers
    mask = np.uint64(n - 1)
    box = np.empty((1, ENTRY))
    count = 0
    for i in range(keys.shape[0]):
        if used[i] == 0 or keys[i] == 0:
            continue
        home = np.int64(keys[i] & mask)
        if home < lo or home >= hi:
            continue
        slot = home
        while slot < hi and row_keys[slot] != 0 and row_keys[slot] != keys[i]:
            slot += 1
        if slot == hi:
            spill[w, count] = i
            count += 1
        else:
            _put(keys, used, vals, boxes, rows, row_keys, levels, box, i, slot)
    spilled[w] = count


@cached_jit(error_model="numpy")
def _put_spilled(keys, used, vals, boxes, rows, row_keys, levels, spill, spilled):
    """The entries _fill_share listed, worker after worker, each in its listed order, by
    the table's own probe (which runs on into the next part, and wraps around)."""
    box = np.empty((1, ENTRY))
    for w in range(spilled.shape[0]):
        for j in range(spilled[w]):
            i = spill[w, j]
            _put(keys, used, vals, boxes, rows, row_keys, levels, box, i,
                 table_slot(row_keys, row_keys, keys[i]))


@inline
def _put(keys, used, vals, boxes, rows, row_keys, levels, box, i, slot):
    for a in range(6):
        box[0, a] = vals[i, a]
    pad_row(box, 0)
    clip_row(box, 0, boxes, np.int64(vals[i, OWNER]))
    store_box(rows, slot, box[0])
    row_keys[slot] = keys[i]
    levels[slot] = used[i]


@inline
def down32(x):
    """The largest float32 at most x."""
    v = np.float32(x)
    if v > x:
        v = np.nextafter(v, np.float32(-np.inf))
    return v


@inline
def up32(x):
    """The smallest float32 at least x."""
    v = np.float32(x)
    if v < x:
        v = np.nextafter(v, np.float32(np.inf))
    return v


@inline
def store_box(vals, i, box):
    """vals[i, :6] = box rounded outwards to float32, which holds it whatever vals' type."""
    for a in range(3):
        vals[i, a] = down32(box[a])
        vals[i, a + 3] = up32(box[a + 3])


def new_book(deepest: int, most: int) -> np.ndarray:
    """A table's bookkeeping: [deepest level kept, most entries, entries, entries by
    level...]; deepest -1 keeps nothing."""
    book = np.zeros(3 + max(deepest, 0) + 2, dtype=np.int64)
    book[0] = deepest
    book[1] = most
    return book


@inline
def entry_key(h, node, k):
    """The key of the instance h of an S-node `node` (k < 0), or of operand k of the
    instance h of the operator `node`. Computed only for the levels kept: most of a deep
    system's instances are not (two hashes each, a tenth of the terrain's walk at 12)."""
    if k < 0:
        return vm.mix(h, node)
    return vm.operand_key(h, node, k)


@inline
def append(level, h, node, k, owner, box, book, keys, used, vals, per_level):
    """Count the instance at its level; append its box under entry_key(h, node, k) to the
    buffer if its level is within book[0], the deepest level kept. When the buffer would
    pass book[1] entries, its deepest level is dropped (book[0] lowered): the levels kept
    in the end are the most that fit, all of them complete, as if they had been known in
    advance. (A walk that only collects instances has book[0] = -1: it counts.) The count
    is inlined and the append a call: most of a deep system's instances are only counted,
    and a call pushes its arrays on the stack (tools/performance_notes.md, session 72)."""
    if level < per_level.shape[0]:
        per_level[level] += 1
    if level <= book[0]:
        _append_kept(level, h, node, k, owner, box, book, keys, used, vals)


@kernel
def _append_kept(level, h, node, k, owner, box, book, keys, used, vals):
    """append's entry for an instance of a level kept so far."""
    while book[2] + 1 > book[1] and book[0] >= 0:
        kept = 0
        for i in range(book[2]):
            if used[i] != book[0] + 1:
                keys[kept] = keys[i]
                used[kept] = used[i]
                copy_into(vals[kept], vals[i])
                kept += 1
        book[2] = kept
        book[3 + book[0]] = 0
        book[0] -= 1
    if level > book[0]:
        return
    i = book[2]
    keys[i] = entry_key(h, node, k)
    used[i] = 1 + level
    store_box(vals, i, box)
    vals[i, OWNER] = owner
    book[2] += 1
    book[3 + level] += 1


@cached_jit(error_model="numpy")
def levels_kept(per_level, book):
    """The deepest level a table keeps, and its entries: the levels down to book[0] whose
    instances, counted by per_level over the whole walk, fit book[1] entries together, as
    append would have kept them, and that have instances two levels below them. The last
    two levels are the instances that end (the terrain's final triangles) and their
    parents, whose operand entries are the boxes of those: a ray tests a final triangle as
    cheaply as its box, and at order 9 those 655 360 entries cost the bounding walk time
    and memory and brought the render nothing (tools/performance_notes.md)."""
    deepest = -1
    total = 0
    kept = 0
    for level in range(min(book[0] + 1, per_level.shape[0])):
        total += per_level[level]
        if total > book[1] or level + 2 >= per_level.shape[0] or per_level[level + 2] == 0:
            break
        deepest = level
        kept = total
    return deepest, kept


@cached_jit(error_model="numpy")
def gather(per_level, book, bkeys, bused, bvals, bbook):
    """The entries of the buffers (one per row of bkeys, bused, bvals, bbook) at the
    levels levels_kept keeps, as one list (keys, used, vals); book then keeps those
    levels and counts those entries."""
    deepest, count = levels_kept(per_level, book)
    keys = np.zeros(count, dtype=np.uint64)
    used = np.zeros(count, dtype=np.int16)
    vals = np.zeros((count, bvals.shape[2]), dtype=bvals.dtype)
    n = 0
    for b in range(bkeys.shape[0]):
        for i in range(bbook[b, 2]):
            if bused[b, i] - 1 <= deepest and n < count:
                keys[n] = bkeys[b, i]
                used[n] = bused[b, i]
                copy_into(vals[n], bvals[b, i])
                n += 1
    book[0] = deepest
    book[2] = n
    book[3:] = 0
    for i in range(n):
        book[3 + used[i] - 1] += 1
    return keys[:n], used[:n], vals[:n]


@cached_jit(error_model="numpy")
def clip_to_owners(used, vals, boxes):
    """Every entry's box cut down to its owner's box in `boxes`. The walk makes a node's
    box the union of its instances' boxes, but padding (trace/pad.py) moves each by its
    own magnitudes, so an entry may stick out of its node's box by a hair. Inside it, the
    tracer can test a ray against the entry's box alone: within rounding that is
    monotone, the window of the cut box is the window of both boxes. Where the boxes do
    not meet, the cut box is empty, though their rounded windows may still touch at one
    t: nothing lies in both, so there is nothing that window could hit."""
    for i in range(used.shape[0]):
        if used[i]:
            clip_row(vals, i, boxes, np.int64(vals[i, OWNER]))


@inline
def clip_row(vals, i, boxes, o):
    """clip_to_owners for entry i, owned by node o."""
    empty = False
    for a in range(3):
        vals[i, a] = max(vals[i, a], boxes[o, a])
        vals[i, a + 3] = min(vals[i, a + 3], boxes[o, a + 3])
        empty = empty or vals[i, a] > vals[i, a + 3]
    if empty:       # box_window reads an empty box by its x sides
        for a in range(3):
            vals[i, a] = np.inf
            vals[i, a + 3] = -np.inf
