"""The bounding walk's instance table: the levels kept are the most that fit, and each
entry knows the node whose box holds it."""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import pcsg
from pcsg.compiler import compile_file
from pcsg.graph.model import DIFFERENCE, INTERSECTION, SELECT, UNION
from pcsg.graph.regroup import regroup
from pcsg.trace.boxwalk import walk_boxes
from pcsg.trace.instance_table import (OWNER, append, clip_to_owners, empty_table, hashed,
                                       tracer_rows)
from pcsg.trace.nodes import DX, F_WIDTH, OX, set_inverse
from pcsg.trace.windows import box_window, table_slot

from .conftest import GRAMMARS
from .oracle import camera_rays


def outwards32(boxes):
    """(boxes' lower sides, their upper sides) rounded outwards to float32."""
    b = np.asarray(boxes, dtype=np.float64)
    f = b.astype(np.float32)
    low = np.where(f > b, np.nextafter(f, np.float32(-np.inf)), f)
    high = np.where(f < b, np.nextafter(f, np.float32(np.inf)), f)
    return low, high


def find(keys, used, key):
    slot = table_slot(keys, used, np.uint64(key))
    return slot if used[slot] else None


def test_a_buffer_keeps_the_most_levels_that_fit():
    keys, used, vals = empty_table(64)
    book = np.zeros(3 + 8, dtype=np.int64)
    book[0], book[1] = 7, 20                 # levels 0..7 wanted, at most 20 entries
    per_level = np.zeros(8, dtype=np.int64)
    box = np.zeros(6)
    sizes = [1, 2, 4, 8, 16, 32]             # a doubling derivation, deepest first (DFS)
    n = 0
    for level in reversed(range(len(sizes))):
        for _ in range(sizes[level]):
            n += 1
            append(level, np.uint64(n), 1, -1, 1, box, book, keys, used, vals, per_level)
    assert list(per_level[:6]) == sizes
    assert book[0] == 3                      # 1 + 2 + 4 + 8 = 15 fit, + 16 would not
    kept = used[:book[2]]                    # the buffer's entries; past them, dropped ones
    assert book[2] == 15 == (kept > 0).sum()
    assert sorted(np.bincount(kept)[1:]) == [1, 2, 4, 8]


def test_every_entry_lies_in_its_owners_box():
    """The walk names each entry's owner: the S-node of an S-node instance, the operand
    node of an operand. The owner's box is the union of its instances' boxes, so the
    entry lies inside it (before padding) but for its rounding outwards to float32, which
    is monotone: inside the owner's box rounded the same way."""
    graph = compile_file(GRAMMARS / "carpenter_terrain.pcsg", {"cnt": 4})
    boxes, complete, (keys, used, vals), depth = walk_boxes(graph, instances=True)
    assert complete and vals.dtype == np.float32
    kept = used > 0
    owner = vals[kept, OWNER].astype(np.int64)
    box = vals[kept, :OWNER]
    low, high = outwards32(boxes)
    assert np.all(box[:, :3] >= low[owner, :3]) and np.all(box[:, 3:] <= high[owner, 3:])
    selects = {i for i, n in enumerate(graph.nodes) if n.kind == SELECT}
    operands = {c for n in graph.nodes if n.kind in (UNION, INTERSECTION, DIFFERENCE)
                for c in n.children}
    owners = set(owner.tolist())
    assert owners <= selects | operands
    assert owners & selects and owners - selects       # both kinds of entry


def test_clipping_cuts_an_entry_to_its_owner():
    boxes = np.array([[0.0, 0, 0, 1, 1, 1], [-5.0, -5, -5, 5, 5, 5]])
    used = np.array([1, 1, 0, 2], dtype=np.int16)
    vals = np.array([[-1e-9, 0.2, 0.2, 0.5, 0.5, 1 + 1e-9, 0],     # out by a hair
                     [0.2, 2.0, 0.2, 0.5, 3.0, 0.5, 0],            # beside its owner in y
                     [7.0, 7, 7, 7, 7, 7, 0],                       # an empty slot
                     [-1.0, -1, -1, 1, 1, 1, 1]])                   # inside
    clip_to_owners(used, vals, boxes)
    assert vals[0, :6].tolist() == [0.0, 0.2, 0.2, 0.5, 0.5, 1.0]
    assert vals[1, :6].tolist() == [np.inf] * 3 + [-np.inf] * 3
    assert vals[2, :6].tolist() == [7.0] * 6
    assert vals[3, :6].tolist() == [-1.0, -1, -1, 1, 1, 1]


coord = st.floats(-4, 4)
# no subnormal directions: 1/d would be infinite, and 0 * inf in the slab test NaN
direction = coord.filter(lambda v: v == 0.0 or abs(v) > 1e-300)


@settings(max_examples=300, deadline=None)
@given(st.lists(coord, min_size=12, max_size=12),
       st.tuples(coord, coord, coord, direction, direction, direction))
def test_the_window_of_a_clipped_entry_is_the_window_of_both_boxes(ends, ray):
    """What lets the tracer test a ray against an entry alone, not also its node's box."""
    a = np.sort(np.reshape(ends[:6], (2, 3)), axis=0).ravel()
    b = np.sort(np.reshape(ends[6:], (2, 3)), axis=0).ravel()
    clipped = np.r_[a, 0.0][None]
    clip_to_owners(np.ones(1, dtype=np.int16), clipped, b[None])
    F = np.zeros((1, F_WIDTH))
    F[0, OX:OX + 3] = ray[:3]
    F[0, DX:DX + 3] = ray[3:]
    set_inverse(F, 0)
    a0, a1 = box_window(a[None], 0, F, 0)
    b0, b1 = box_window(b[None], 0, F, 0)
    c0, c1 = box_window(clipped, 0, F, 0)
    both = (max(a0, b0), min(a1, b1))
    meet = np.all(np.maximum(a[:3], b[:3]) <= np.minimum(a[3:], b[3:]))
    if not meet:
        # no point lies in both boxes, so no ray may enter the entry; the two rounded
        # windows can still touch at one t (a side 1e-163 from the other, seen by 1.0)
        assert c0 > c1
    elif both[0] > both[1]:
        assert c0 > c1
    else:
        assert (c0, c1) == both


def test_disjoint_boxes_whose_rounded_windows_touch_give_an_empty_entry():
    """The case hypothesis found: the windows of the two boxes meet at t = -1 only by
    rounding (5e-163 - 1 == -1), the boxes themselves do not."""
    a = np.array([0.0, 5.1278179516629826e-163, 0.0, 0.0, 1.0, 0.0])
    b = np.zeros(6)
    clipped = np.r_[a, 0.0][None]
    clip_to_owners(np.ones(1, dtype=np.int16), clipped, b[None])
    assert clipped[0, :6].tolist() == [np.inf] * 3 + [-np.inf] * 3
    F = np.zeros((1, F_WIDTH))
    F[0, OX:OX + 3] = (0.0, 1.0, 0.0)
    F[0, DX:DX + 3] = (0.0, 1.0, 0.0)
    set_inverse(F, 0)
    c0, c1 = box_window(clipped, 0, F, 0)
    assert c0 > c1


def test_the_tracer_reads_the_table_in_rows_of_half_a_cache_line():
    """Flat's inst_keys and inst_boxes are views of one array of 32-byte rows (the box as
    float32, the key), aligned, so a probe and the box it finds share a line; a probe
    reads the keys alone (0: an empty slot), and every entry is found at its own slot.
    inst_used, apart, holds the level each was kept at."""
    obj = pcsg.load(GRAMMARS / "carpenter_terrain.pcsg", cnt=5)
    flat = obj.flat
    rows = flat.inst_boxes
    assert rows.dtype == np.float32 and rows.shape[1] == 8 and rows.ctypes.data % 64 == 0
    assert np.shares_memory(flat.inst_keys, rows) and not np.shares_memory(flat.inst_used, rows)
    kept = np.flatnonzero(flat.inst_keys)
    assert len(kept) > 300 and np.array_equal(kept, np.flatnonzero(flat.inst_used))
    for i in kept:
        assert table_slot(flat.inst_keys, flat.inst_keys, flat.inst_keys[i]) == i
    assert flat.inst_deepest == flat.inst_used.max() - 1


def test_the_operands_of_an_instance_lie_side_by_side():
    """A union's operands are tested one after another, so their entries are keyed to
    neighbouring slots (vm.operand_key): in the terrain's table each of a subdividing
    instance's four operands but the last has the next one's key, one slot on but where
    probing moved it. (The walks read these entries, or the test below would fail.)"""
    graph = regroup(compile_file(GRAMMARS / "carpenter_terrain.pcsg", {"cnt": 5}))
    boxes, _, (keys, used, vals), _ = walk_boxes(graph, instances=True)
    kinds = np.array([n.kind for n in graph.nodes])
    kept = np.flatnonzero(used)
    operand_keys = keys[kept[kinds[vals[kept, OWNER].astype(np.int64)] != SELECT]]
    rows = tracer_rows(keys, used, vals, boxes)
    keys = rows["inst_keys"]
    at = {int(k): i for i, k in enumerate(keys) if k}
    slot = {int(k): at[int(k)] for k in operand_keys}
    pairs = [(i, slot[k + 1]) for k, i in slot.items() if k + 1 in slot]
    # the T1 and T2 instances that subdivide, each into four operands, and the three
    # operands that are no S-node above them: the two of MNT, and the sea (whose
    # neighbour, MNT, is one)
    subdividing = 2 * (1 + 4 + 16 + 64)
    assert len(operand_keys) == 4 * subdividing + 3 and len(pairs) == 3 * subdividing + 1
    apart = np.array([(j - i) % len(keys) for i, j in pairs])
    assert np.median(apart) == 1 and np.mean(apart <= 4) > 0.9


@pytest.mark.parametrize("packets", [True, False])
def test_the_walks_probe_the_table_down_to_its_deepest_level_and_no_further(packets):
    """A probe past inst_deepest could only miss, so the walks skip it. Entries emptied
    by hand show which levels a walk reads: every level down to the deepest one it
    reads (an S-node met through its operand's entry skips its own, so the last level,
    whose S-nodes are all met so, is never read), that one still with inst_deepest
    set to it, and no longer with inst_deepest one lower."""
    obj = pcsg.load(GRAMMARS / "carpenter_terrain.pcsg", cnt=4)
    flat = obj.flat
    top = flat.inst_boxes[flat.inst_used == 1, :6]
    o, d = camera_rays(np.concatenate([top[:, :3].min(0), top[:, 3:].max(0)]), 48,
                       (0.3, -0.4, 1.0), spread=0.3, seed=5)
    whole = obj.trace(o, d, packets=packets).t
    kept = flat.inst_boxes.copy()

    def emptied(level, deepest):
        flat.inst_boxes[:] = kept
        gone = flat.inst_used == level + 1
        flat.inst_boxes[gone, 0] = np.inf       # box_window: min side > max side is empty
        flat.inst_boxes[gone, 3] = -np.inf
        obj.flat = flat._replace(inst_deepest=np.int64(deepest))
        return obj.trace(o, d, packets=packets).t

    read = [level for level in range(flat.inst_deepest + 1)
            if not np.array_equal(emptied(level, flat.inst_deepest), whole)]
    assert len(read) >= 5 and read == list(range(len(read)))
    last = read[-1]
    assert not np.array_equal(emptied(last, last), whole)
    assert np.array_equal(emptied(last, last - 1), whole)


def test_the_tracer_lays_out_a_hashed_table_as_its_list_of_entries():
    """tracer_rows hashes the entries of a table (a walk's list of them, or a hashed
    table with empty slots and unused ones) into its rows: the same rows either way,
    each entry padded, cut to its owner and rounded outwards to float32, found by its key
    alone, with its level beside; a dropped entry is not there."""
    from pcsg.trace.vm import mix
    from pcsg.trace.pad import pad_boxes
    rng = np.random.default_rng(3)
    boxes = np.array([[0.0, 0, 0, 1, 1, 1], [-2.0, -2, -2, 2, 2, 2]])
    padded = boxes.copy()
    pad_boxes(padded)
    lows = rng.uniform(-1.5, 0.5, (40, 3))
    entries = np.c_[lows, lows + rng.uniform(0, 1.5, (40, 3))]
    # the entries as the walk leaves them (instance_table.entry_key, store_box), at levels
    # 0 to 2, owned by node 0 or 1
    low, high = outwards32(entries)
    keys = np.array([mix(np.uint64(1000 + 7 * k), 5) for k in range(40)], dtype=np.uint64)
    used = np.array([k % 3 + 1 for k in range(40)], dtype=np.int16)
    vals = np.c_[low[:, :3], high[:, 3:], np.arange(40) % 2].astype(np.float32)
    table = hashed((keys, used, vals, 128))
    table[1][table[1] == 3] = 0         # level 2 unused: stale keys and owners in its slots
    live = np.flatnonzero(table[1])     # its entries listed in the order of their slots
    hashed_rows = tracer_rows(*table, padded)
    listed = tracer_rows(*(column[live] for column in table), padded)
    for name in ("inst_keys", "inst_used", "inst_boxes"):
        assert np.array_equal(hashed_rows[name], listed[name])
    assert hashed_rows["inst_deepest"] == 1 and hashed_rows["inst_boxes"].ctypes.data % 64 == 0
    rows, keys, levels = (hashed_rows["inst_boxes"], hashed_rows["inst_keys"],
                          hashed_rows["inst_used"])
    low, high = outwards32(padded)
    for k, box in enumerate(entries):
        slot = find(keys, keys, mix(np.uint64(1000 + 7 * k), 5))     # instance_table.entry_key
        if k % 3 == 2:
            assert slot is None
            continue
        assert slot is not None and levels[slot] == k % 3 + 1
        owner = k % 2
        want = np.r_[np.maximum(box[:3], padded[owner, :3]), np.minimum(box[3:], padded[owner, 3:])]
        got = rows[slot, :6].astype(np.float64)
        if (want[:3] > want[3:]).any():         # beside its owner: empty
            assert got[0] > got[3]
            continue
        assert np.all(got[:3] <= want[:3]) and np.all(got[3:] >= want[3:])     # outwards
        assert np.all(got[:3] >= low[owner, :3]) and np.all(got[3:] <= high[owner, 3:])


def test_the_rows_hold_the_same_entries_whatever_the_workers_that_fill_them():
    """tracer_rows fills the table's parts on threads of their own, and an entry whose
    probe would cross into the next part after them. Keys crowded into a few runs of
    slots, across the parts' borders and around the table's end, some of them twice
    (the later entry wins): every probe finds the same box and level with 1 to 5 workers
    as by the one-worker fill, and the rows hold nothing else."""
    from pcsg.trace.instance_table import ENTRY
    rng = np.random.default_rng(11)
    n = 300
    slots = 1024                      # table_slots(300)
    # runs across the parts' borders of 2 (at 512), 3 (341, 682) and 5 workers (409), and
    # across the table's end
    homes = np.concatenate([rng.integers(330, 340, 60), rng.integers(400, 408, 50),
                            rng.integers(505, 518, 60), rng.integers(675, 681, 40),
                            rng.integers(1015, 1024, 50), rng.integers(0, slots, 40)])
    keys = (rng.integers(1, 2**40, n).astype(np.uint64) * np.uint64(slots)
            + homes.astype(np.uint64))
    keys[280:] = keys[:20]            # the same keys again, with other boxes and levels
    used = rng.integers(1, 4, n).astype(np.int16)
    used[5] = 0                       # a dropped entry
    lows = rng.uniform(-1, 0.5, (n, 3))
    vals = np.c_[lows, lows + rng.uniform(0.1, 1, (n, 3)), np.zeros(n)].astype(np.float32)
    assert vals.shape[1] == ENTRY
    boxes = np.array([[-2.0, -2, -2, 2, 2, 2]])
    tables = [tracer_rows(keys, used, vals, boxes, workers=w) for w in (1, 2, 3, 5)]
    one = tables[0]
    assert one["inst_keys"].shape[0] == slots
    live = {int(k) for k, u in zip(keys, used) if u}
    for t in tables:
        assert sorted(int(k) for k in t["inst_keys"] if k) == sorted(live)
        for k in live:
            a = find(one["inst_keys"], one["inst_keys"], np.uint64(k))
            b = find(t["inst_keys"], t["inst_keys"], np.uint64(k))
            assert a is not None and b is not None
            assert np.array_equal(t["inst_boxes"][b, :6], one["inst_boxes"][a, :6])
            assert t["inst_used"][b] == one["inst_used"][a]
    last = {int(k): i for i, k in enumerate(keys) if used[i]}    # the later entry wins
    for k, i in last.items():
        a = find(one["inst_keys"], one["inst_keys"], np.uint64(k))
        assert one["inst_used"][a] == used[i]
    # the parts' borders were crossed: two workers placed entries otherwise than one
    assert not np.array_equal(tables[1]["inst_keys"], one["inst_keys"])
