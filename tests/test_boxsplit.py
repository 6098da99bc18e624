"""The bounding walk split over threads gives what one walk from the root gives: the same
boxes, visits, counts and instance-table entries, whatever the number of workers."""
import numpy as np
import pytest

from pcsg.compiler import compile_file, compile_text
from pcsg.graph.flat import flatten_graph
from pcsg.trace.boxsplit import (_split_level, new_watch, predicted_visits, walk_split,
                                 watched_visits)
from pcsg.trace.boxwalk import FAULTS, STOPPED, _walk_to, new_counts, walk_boxes, walk_flat
from pcsg.trace.instance_table import TABLE_SLOTS, new_book
from pcsg.trace.jit import set_threads, threads

from tests.conftest import GRAMMARS


def split_walk(graph, depth, workers, budget=10**9, most=TABLE_SLOTS // 2, watch=None):
    n = len(graph.nodes)
    empty = np.tile([np.inf, np.inf, np.inf, -np.inf, -np.inf, -np.inf], (n, 1))
    flat = flatten_graph(graph, empty, runs=False)     # as walk_boxes: runs map by map
    boxes = empty.copy()
    book = new_book(depth + 1, most)
    per_level = np.zeros(depth + 2, dtype=np.int64)
    changed = new_counts(1)[0]
    capacity = (depth + 2) * (n + 2) + 16
    visits, table = walk_split(flat, depth, budget, capacity, boxes, book, per_level, changed,
                               workers, watch)
    if table is None:
        return visits, boxes, changed.tolist(), per_level.tolist(), int(book[0]), None, flat
    keys, used, vals = table
    kept = used > 0
    entries = sorted(zip(keys[kept].tolist(), used[kept].tolist(), map(tuple, vals[kept])))
    return visits, boxes, changed.tolist(), per_level.tolist(), int(book[0]), entries, flat


CASES = [("carpenter_terrain", {"cnt": 6}, 64),        # every instance, table complete
         ("carpenter_terrain", {"cnt": 8}, 6),         # cut by the depth bound
         ("sympodial_tree", {"cnt": 9}, 64),
         ("graftal_tree", {}, 7),
         ("non-finite maps", {}, 64)]                  # counted, the least node named
NONFINITE = """{c = 6} S
S if(c > 0, 2, 1)
1: S → move(sqrt(rand() - 0.1), 0, 0) sphere ∪ move(0, 0, log(rand() - 0.05)) cube
2: S → {c = c-1} (move(-1,0,0) uscale(0.5) S ∪ move(1,0,0) uscale(0.5) S ∪
                  move(0,1,0) uscale(0.5) S)
"""


@pytest.mark.parametrize("name, params, depth", CASES)
def test_split_walk_is_the_walk_from_the_root(name, params, depth):
    graph = compile_text(NONFINITE) if name == "non-finite maps" else \
        compile_file(GRAMMARS / f"{name}.pcsg", params)
    one = split_walk(graph, depth, 1)
    assert one[0] > 0
    level, count, _ = _split_level(one[6], depth, 10**9, (depth + 2) * (len(graph.nodes) + 2)
                                   + 16, 2, np.zeros(3, dtype=np.int64))
    assert count >= 2                   # the walk really is split
    for workers in (2, 5):
        got = split_walk(graph, depth, workers)
        assert got[0] == one[0]                             # visits
        assert np.array_equal(got[1], one[1])               # boxes
        assert got[2:6] == one[2:6]         # counts, per level, deepest kept, entries
    assert (one[2][FAULTS] > 0) == (name == "non-finite maps")


def test_split_walk_keeps_the_levels_that_fit():
    """With room for 300 entries the table keeps the levels whose instances, counted
    over every thread, fit; the threads' buffers drop their own deepest levels on the way."""
    graph = compile_file(GRAMMARS / "carpenter_terrain.pcsg", {"cnt": 6})
    one = split_walk(graph, 64, 1, most=300)
    assert 0 < one[4] < 6
    assert sum(one[3][:one[4] + 1]) <= 300 < sum(one[3][:one[4] + 2])
    assert len(one[5]) == sum(one[3][:one[4] + 1])
    two = split_walk(graph, 64, 2, most=300)
    assert two[0] == one[0] and np.array_equal(two[1], one[1]) and two[2:6] == one[2:6]


def test_split_walk_over_budget_fails_like_the_walk():
    graph = compile_file(GRAMMARS / "carpenter_terrain.pcsg", {"cnt": 6})
    visits = split_walk(graph, 64, 1)[0]
    for workers in (1, 2):
        assert split_walk(graph, 64, workers, budget=visits)[0] == visits
        assert split_walk(graph, 64, workers, budget=visits - 1)[0] == -1


def test_a_table_of_fewer_levels_holds_the_same_entries():
    """Below the deepest level it keeps, the walk leaves instance hashes alone (nothing
    there reads one); the levels it keeps have the keys and boxes of a table with room
    for every level, from one walk or split over threads (whose instances get their
    hashes from the collecting walk)."""
    graph = compile_file(GRAMMARS / "carpenter_terrain.pcsg", {"cnt": 6})
    full = split_walk(graph, 64, 1)
    for workers in (1, 2):
        few = split_walk(graph, 64, workers, most=300)
        assert 0 < few[4] < full[4]
        kept = [e for e in full[5] if e[1] <= few[4] + 1]
        assert few[5] == kept and np.array_equal(few[1], full[1])


DRAWS = """{ n = 7 } A
A if(n > 0, 2, 1)
1: A → cube
2: A → { n = n - 1; s = 0.5 + 0.4 * rand() } (scale(s, s, s) move(1, 0, 0) A ∪ move(0, 1.5 * rand(), 0) A)
"""


def test_a_system_that_draws_from_hashes_is_bounded_alike_whatever_its_table_keeps():
    """rand() reads its instance's hash at every level, kept in the table or not: the
    boxes of a walk that keeps few levels are those of one that keeps them all (a walk
    that skipped the hashes below its kept levels would draw other numbers there)."""
    graph = compile_text(DRAWS)
    full = split_walk(graph, 64, 1)
    for workers in (1, 2):
        few = split_walk(graph, 64, workers, most=20)
        assert 0 <= few[4] < full[4]
        assert np.array_equal(few[1], full[1]) and few[0] == full[0]


@pytest.mark.parametrize("workers", [1, 2])
def test_a_walk_whose_watch_is_set_stops(workers):
    """A set watch[0] stops the walk at its next report (every TELL_EVERY visits, and
    between the subtrees of a split walk), on one thread or several; a clear one lets it
    count its visits there (with those of the walks that find the split level)."""
    graph = compile_file(GRAMMARS / "carpenter_terrain.pcsg", {"cnt": 8})
    stop = new_watch(workers)
    stop[0] = 1
    assert split_walk(graph, 64, workers, watch=stop)[0] == STOPPED
    watch = new_watch(workers)
    visits = split_walk(graph, 64, workers, watch=watch)[0]
    told = watched_visits(watch, workers)
    assert visits > 1_000_000 and watch[0] == 0 and visits <= told < 1.01 * visits


def test_an_exception_from_the_poll_stops_the_walk_and_is_raised():
    """What Ctrl-C and --timeout do to a long bounding walk: the exception reaches the
    caller, and the next walk is unharmed."""
    graph = compile_file(GRAMMARS / "carpenter_terrain.pcsg", {"cnt": 10})
    calls = []

    def poll(visits, expected):
        calls.append((visits, expected))
        raise KeyboardInterrupt
    with pytest.raises(KeyboardInterrupt):
        walk_boxes(graph, instances=True, poll=poll)
    assert len(calls) == 1
    small = compile_file(GRAMMARS / "carpenter_terrain.pcsg", {"cnt": 6})
    assert np.array_equal(walk_boxes(small)[0], split_walk(small, 64, 1)[1])


@pytest.mark.parametrize("name, params, depth", [("carpenter_terrain", {"cnt": 5}, 64),
                                                 ("sympodial_tree", {"cnt": 7}, 64),
                                                 ("graftal_tree", {}, 6)])
def test_the_walk_reads_no_scratch_row_it_has_not_written(name, params, depth):
    """walk_scratch leaves its rows as the allocator gives them (boxwalk.walk_scratch):
    a walk over rows that hold another walk's values, or anything else, makes the same
    visits, boxes, counts and entries as over rows set to zeros and NaN."""
    from pcsg.trace.boxsplit import items_for
    from pcsg.trace.boxwalk import walk_in, walk_scratch
    from pcsg.trace.instance_table import ENTRY
    graph = compile_file(GRAMMARS / f"{name}.pcsg", params)
    n = len(graph.nodes)
    empty = np.tile([np.inf, np.inf, np.inf, -np.inf, -np.inf, -np.inf], (n, 1))
    flat = flatten_graph(graph, empty, runs=False)
    capacity = (depth + 2) * (n + 2) + 16

    def walk(fill):
        boxes = empty.copy()
        book = new_book(depth + 1, 4096)
        buffer = (np.empty(4096, np.uint64), np.empty(4096, np.int16),
                  np.empty((4096, ENTRY), np.float32))
        per_level = np.zeros(depth + 2, dtype=np.int64)
        changed = new_counts(1)[0]
        scratch = walk_scratch(flat, capacity)
        for array, value in zip(scratch[:4], fill):
            array[:] = value
        visits = walk_in(flat, depth, 10**9, capacity, boxes, book, *buffer, per_level,
                         changed, np.zeros(3, np.int64), *items_for(flat, 1), -1, *scratch,
                         np.zeros(2, np.int64), 1)
        kept = book[2]
        return (visits, boxes, per_level, changed.tolist(), buffer[0][:kept].tolist(),
                buffer[2][:kept])

    clean = walk((0, 0, np.nan, 0.0))
    assert clean[0] > 0
    for fill in [(3, 12345, 7.0, -1.0), (1, 2**63, -1e300, np.nan)]:
        dirty = walk(fill)
        assert dirty[0] == clean[0] and dirty[3:5] == clean[3:5]
        for got, want in zip(dirty[1:3] + dirty[5:], clean[1:3] + clean[5:]):
            assert np.array_equal(got, want)


def test_the_progress_of_a_walk_that_ends_above_its_depth_comes_from_its_subtrees():
    """The walk that bounds is as deep as the growth of two shallow walks says the budget
    allows; a derivation that ends above that depth (the terrain at 10 is walked to 13)
    makes far fewer visits than the growth predicts, and its progress line stalled at a
    quarter of that (the terrain at 11: 25 %, ETA 11 s, done). The subtrees it has
    finished predict it instead."""
    graph = compile_file(GRAMMARS / "carpenter_terrain.pcsg", {"cnt": 10})
    flat, empty = walk_flat(graph)
    calls = []
    was = threads()
    set_threads(2)
    try:
        _, visits, _, _ = _walk_to(flat, empty, 13, 64, 10**9, True,
                                   lambda v, e: calls.append((v, e)), expected=10**9)
    finally:
        set_threads(was)
    assert visits > 1_000_000 and calls
    # the last reports, once every worker finished a subtree, within a tenth of the walk
    # (the growth's figure, 10**9, is 15 times too many)
    assert abs(calls[-1][1] - visits) < 0.1 * visits
    assert all(v <= visits for v, _ in calls)


def test_the_prediction_of_a_finished_split_walk_is_its_visits():
    graph = compile_file(GRAMMARS / "carpenter_terrain.pcsg", {"cnt": 7})
    watch = new_watch(2)
    visits = split_walk(graph, 64, 2, watch=watch)[0]
    # all but the top walk's visits, which are above the split level
    assert 0.95 * visits < predicted_visits(watch, 2) <= visits
    assert predicted_visits(new_watch(2), 2) is None


def test_the_split_level_is_searched_no_deeper_than_deepest_split(monkeypatch):
    """Each level's collect walks every level above it again: a chain that never has
    ITEMS_PER_WORKER instances on a level (one recursive call and a sphere) was searched
    to its last level, 10,000 deep, 49 s of quadratic collects past --timeout."""
    from pcsg.trace import boxsplit
    graph = compile_text("{c = 1000} S\nS if(c > 0, 2, 1)\n1: S → sphere\n"
                         "2: S → {c = c-1} (uscale(0.999) S ∪ move(1,0,0) uscale(0.5) sphere)\n")
    n = len(graph.nodes)
    empty = np.tile([np.inf, np.inf, np.inf, -np.inf, -np.inf, -np.inf], (n, 1))
    flat = flatten_graph(graph, empty, runs=False)
    calls = []
    real = boxsplit.walk
    monkeypatch.setattr(boxsplit, "walk", lambda *a: calls.append(a) or real(*a))
    level, count, items = _split_level(flat, 1000, 10**9, (1002) * (n + 2) + 16, 2,
                                       new_watch(2))
    assert count < 2 and len(calls) <= boxsplit.DEEPEST_SPLIT + 2
