"""The bounding walk's instance table: dropping its deepest level when it fills keeps
every other entry findable (linear-probing deletion), and the levels kept are the
most that fit."""
import numpy as np
from hypothesis import given, settings, strategies as st

from pcsg.trace.instance_table import drop_level, empty_table, record
from pcsg.trace.nodes import table_slot


def find(keys, used, key):
    slot = table_slot(keys, used, np.uint64(key))
    return slot if used[slot] else None


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 2**64 - 1), st.integers(0, 5)), min_size=1,
                max_size=60, unique_by=lambda e: e[0]), st.integers(0, 5))
def test_dropping_a_level_keeps_the_others_reachable(entries, drop):
    keys, used, vals = empty_table(128)
    for key, level in entries:
        slot = table_slot(keys, used, np.uint64(key))
        keys[slot], used[slot], vals[slot] = key, level + 1, key % 1000
    drop_level(drop, keys, used, vals)
    for key, level in entries:
        slot = find(keys, used, key)
        if level == drop:
            assert slot is None
        else:
            assert slot is not None and vals[slot, 0] == key % 1000


def test_record_keeps_the_most_levels_that_fit():
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
            record(level, 1, np.uint64(n), box, book, keys, used, vals, per_level)
    assert list(per_level[:6]) == sizes
    assert book[0] == 3                      # 1 + 2 + 4 + 8 = 15 fit, + 16 would not
    assert book[2] == 15 == (used > 0).sum()
    assert sorted(np.bincount(used)[1:]) == [1, 2, 4, 8]
