"""The bounding walk's instance table: the boxes of the S-node instances and operator
operands of the top derivation levels, keyed by instance hash, for the tracer to cull
by (windows.instance_window). It keeps as many whole levels as fit: when it would pass
its entry limit it drops its deepest level.

A walk split over threads (trace/boxsplit.py) cannot share one open-addressing table,
so each thread appends its entries to a buffer of its own under the same rule, and
`merge` adds them to the table afterwards: a thread sees at most the instances the
whole walk sees, so its buffer holds every level the table can keep."""
from __future__ import annotations

import numpy as np
from numba import njit

from . import vm
from .jit import copy_into, inline, kernel
from .windows import table_slot
from .pad import pad_row

TABLE_SLOTS = 1 << 19      # instance boxes kept: ~30 MB at most, whatever the order
# an entry's values: its box (xmin, ymin, zmin, xmax, ymax, zmax) and its owner, the
# node whose hyper box holds it (an S-node, or an operator's operand)
OWNER = 6
ENTRY = 7
ROW = 8                    # a slot as the tracer reads it: box (6), used, key


def empty_table(slots: int = 2, width: int = ENTRY):
    """A table of plain arrays, for the walks' own small ones (a kernel's argument types
    stay those it was compiled for)."""
    return (np.zeros(slots, dtype=np.uint64), np.zeros(slots, dtype=np.int16),
            np.zeros((slots, width)))


def row_table(slots: int):
    """An empty table laid out as the tracer will read it, so that tracer_rows need not
    copy it: keys and values are views of one (slots, 8) array aligned to 64 bytes, each
    slot one cache line, the key in column 7 and the values (box, owner) in 0 to 6;
    `used` is apart until then. The copy into new rows took 16 ms of the terrain at 9's
    bounds phase (merging into these views takes as long as into three arrays did: the
    time is the first writes into fresh pages)."""
    rows = _aligned_rows(slots)
    return rows.view(np.uint64)[:, ROW - 1], np.zeros(slots, dtype=np.int16), rows[:, :ENTRY]


def _aligned_rows(slots: int) -> np.ndarray:
    buf = np.zeros(slots * ROW + ROW)          # zero pages: only what is written is faulted in
    start = (-buf.ctypes.data % 64) // 8
    return buf[start:start + slots * ROW].reshape(slots, ROW)


def _rows_of(keys, vals) -> np.ndarray | None:
    """The (slots, 8) array that a row_table's keys and values view, or None."""
    if (vals.ndim == 2 and vals.shape[1] == ENTRY and vals.strides == (ROW * 8, 8)
            and keys.strides == (ROW * 8,) and len(keys) == len(vals)
            and vals.ctypes.data % 64 == 0
            and keys.ctypes.data == vals.ctypes.data + (ROW - 1) * 8):
        return np.lib.stride_tricks.as_strided(vals, (len(vals), ROW), (ROW * 8, 8))
    return None


def compact(table):
    """The table's entries without its empty slots, and its slot count. A table kept in
    case the next walk fails would otherwise stay resident while that walk fills a table
    of its own, and hashing touches a page every few slots: even a table of few entries is
    resident in full (26 MiB at the terrain's depth 5)."""
    keys, used, vals = table
    kept = np.flatnonzero(used)
    return keys[kept], used[kept], vals[kept], len(keys)


def expand(entries):
    """The table again from compact's entries (the same entries; their slots may differ,
    which no lookup sees)."""
    keys, used, vals, slots = entries
    table = row_table(slots)
    _insert(keys, used, vals, *table)
    return table


@njit(cache=True, error_model="numpy")
def _insert(keys, used, vals, tkeys, tused, tvals):
    for i in range(keys.shape[0]):
        slot = table_slot(tkeys, tused, keys[i])
        tkeys[slot] = keys[i]
        tused[slot] = used[i]
        tvals[slot, :] = vals[i]


def tracer_rows(keys, used, vals, boxes) -> dict:
    """The table as the tracer reads it (Flat's inst_* fields): one 64-byte row per slot,
    [box (6) | used | key], aligned to a cache line, so that a probe and the box it finds
    load one line, not one from each of three arrays (the table is 32 MiB at the
    terrain's orders, far more than the caches; its probes were the walk's hottest loads,
    though the time this layout saves measured within the noise, see
    tools/performance_notes.md). Each entry's box is padded (trace/pad.py) and cut to its
    owner's box in `boxes`, the nodes' padded boxes (clip_to_owners).
    A row_table is finished in place, its owner column becoming `used`: from then on it
    is the tracer's. Any other table is copied.
    inst_deepest lets a walk skip the probes past the deepest level kept, which could only
    miss (the terrain at order 9 keeps 10 of its 11 levels)."""
    rows = _rows_of(keys, vals)
    if rows is None:
        rows = _aligned_rows(len(keys))
    _finish_rows(keys, used, vals, boxes, rows, rows.view(np.uint64))
    return row_fields(rows, int(used.max(initial=0)) - 1)


def row_fields(rows: np.ndarray | None = None, deepest: int = -1) -> dict:
    """Flat's inst_* fields: views of `rows`; without arguments, a table of no entries."""
    if rows is None:
        rows = _aligned_rows(2)
    return dict(inst_keys=rows.view(np.uint64)[:, ROW - 1], inst_used=rows[:, ROW - 2],
                inst_boxes=rows, inst_deepest=np.int64(deepest))


@njit(cache=True, error_model="numpy")
def _finish_rows(keys, used, vals, boxes, rows, bits):
    """tracer_rows's pass; rows may be the memory vals views (a row's owner is read before
    its column becomes `used`)."""
    for i in range(keys.shape[0]):
        if used[i]:
            for a in range(6):
                rows[i, a] = vals[i, a]
            o = np.int64(vals[i, OWNER])
            pad_row(rows, i)
            clip_row(rows, i, boxes, o)
            bits[i, ROW - 1] = keys[i]
        rows[i, ROW - 2] = used[i]      # also where an entry was dropped: 0, not its owner


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


@kernel
def record(level, h, node, k, owner, box, table, keys, used, vals, per_level):
    """Count the instance at its level; keep its box under entry_key(h, node, k) if its
    level is within table[0], the deepest level kept. When the table would pass table[1]
    entries, its deepest level is dropped (table[0] lowered): the levels kept in the end
    are the most that fit, all of them complete, as if they had been known in advance."""
    if level < per_level.shape[0]:
        per_level[level] += 1
    if level > table[0]:
        return
    while table[2] + 1 > table[1] and table[0] >= 0:
        drop_level(table[0], keys, used, vals)
        table[2] -= table[3 + table[0]]
        table[3 + table[0]] = 0
        table[0] -= 1
    if level > table[0]:
        return
    key = entry_key(h, node, k)
    slot = table_slot(keys, used, key)
    if not used[slot]:
        table[2] += 1
        table[3 + level] += 1
    used[slot] = 1 + level          # 0: empty; else the entry's level + 1
    keys[slot] = key
    copy_into(vals[slot, :OWNER], box)
    vals[slot, OWNER] = owner


@kernel
def drop_level(level, keys, used, vals):
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
                    copy_into(vals[hole], vals[j])
                    hole = j
            used[hole] = 0


@kernel
def append(level, h, node, k, owner, box, book, keys, used, vals, per_level):
    """record's rule on a buffer (entries in order, not hashed): count the instance at its
    level and keep its entry while its level fits, dropping the deepest level when the
    buffer would pass book[1] entries."""
    if level < per_level.shape[0]:
        per_level[level] += 1
    if level > book[0]:
        return
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
    copy_into(vals[i, :OWNER], box)
    vals[i, OWNER] = owner
    book[2] += 1
    book[3 + level] += 1


@njit(cache=True, error_model="numpy")
def levels_kept(per_level, book):
    """The deepest level a table keeps, and its entries: the levels down to book[0] whose
    instances, counted by per_level over the whole walk, fit book[1] entries together, as
    record would have kept them."""
    deepest = -1
    total = 0
    kept = 0
    for level in range(min(book[0] + 1, per_level.shape[0])):
        total += per_level[level]
        if total > book[1]:
            break
        deepest = level
        kept = total
    return deepest, kept


@njit(cache=True, error_model="numpy")
def merge(per_level, book, keys, used, vals, bkeys, bused, bvals, bbook):
    """Add the entries of the buffers (one per row of bkeys, bused, bvals, bbook) to the
    table, keeping the levels levels_kept keeps."""
    deepest = levels_kept(per_level, book)[0]
    while book[0] > deepest:
        drop_level(book[0], keys, used, vals)
        book[2] -= book[3 + book[0]]
        book[3 + book[0]] = 0
        book[0] -= 1
    for b in range(bkeys.shape[0]):
        for i in range(bbook[b, 2]):
            level = bused[b, i] - 1
            if level > deepest:
                continue
            slot = table_slot(keys, used, bkeys[b, i])
            if not used[slot]:
                book[2] += 1
                book[3 + level] += 1
            used[slot] = bused[b, i]
            keys[slot] = bkeys[b, i]
            vals[slot, :] = bvals[b, i]


@njit(cache=True, error_model="numpy")
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
