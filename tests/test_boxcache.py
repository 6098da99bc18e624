"""The bounding walk's results kept on disk (graph/boxcache.py): read back to the bit,
keyed by everything the walk reads, and never trusted when unreadable."""
import numpy as np
import pytest

from pcsg.cli import main
from pcsg.compiler import compile_file
from pcsg.graph import boxcache
from pcsg.trace.boxwalk import walk_boxes
from tests.conftest import GRAMMARS

TERRAIN = GRAMMARS / "carpenter_terrain.pcsg"


@pytest.fixture
def cache(monkeypatch, tmp_path):
    """The cache on, in a folder of its own, keeping walks of any length."""
    monkeypatch.setenv("PCSG_BOUNDS_CACHE", "1")
    monkeypatch.setenv("PCSG_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(boxcache, "MIN_VISITS", 0)
    return tmp_path / "bounds"


def entries(table):
    keys, used, vals = table
    kept = np.flatnonzero(used)
    order = np.argsort(keys[kept], kind="stable")
    return keys[kept][order], used[kept][order], vals[kept][order]


def same(a, b):
    assert np.array_equal(a[0], b[0]) and a[1] == b[1] and a[3] == b[3]
    for x, y in zip(entries(a[2]), entries(b[2])):
        assert np.array_equal(x, y)


def test_a_walk_is_read_back_to_the_bit(cache):
    graph = compile_file(TERRAIN, {"cnt": 4})
    hits = boxcache.hits
    walked = walk_boxes(graph, instances=True, cache=True)
    assert len(list(cache.glob("*.npz"))) == 1 and boxcache.hits == hits
    read = walk_boxes(graph, instances=True, cache=True)
    assert boxcache.hits == hits + 1
    same(read, walked)
    assert len(entries(read[2])[0]) > 100            # the table's entries came back too
    same(read, walk_boxes(graph, instances=True))    # and are what a walk finds


def test_the_key_is_what_the_walk_reads(cache):
    a, b = compile_file(TERRAIN, {"cnt": 4}), compile_file(TERRAIN, {"cnt": 3})
    walk_boxes(a, instances=True, cache=True)
    walk_boxes(b, instances=True, cache=True)           # another order: another entry
    walk_boxes(a, 5, instances=True, cache=True)        # another depth bound
    walk_boxes(a, budget=10_000, instances=True, cache=True)    # another budget
    assert len(list(cache.glob("*.npz"))) == 4
    walk_boxes(compile_file(TERRAIN, {"cnt": 4}), instances=True, cache=True)
    assert len(list(cache.glob("*.npz"))) == 4          # the same system: read, not kept


def test_an_unreadable_entry_is_walked_again(cache):
    graph = compile_file(TERRAIN, {"cnt": 4})
    walked = walk_boxes(graph, instances=True, cache=True)
    (entry,) = cache.glob("*.npz")
    entry.write_bytes(entry.read_bytes()[:1000])
    hits = boxcache.hits
    again = walk_boxes(graph, instances=True, cache=True)
    assert boxcache.hits == hits
    same(again, walked)
    assert entry.stat().st_size > 1000                  # and kept whole again


def test_short_walks_are_not_kept_and_the_folder_stays_small(cache, monkeypatch):
    graph = compile_file(TERRAIN, {"cnt": 4})
    monkeypatch.setattr(boxcache, "MIN_VISITS", 10 ** 12)
    walk_boxes(graph, instances=True, cache=True)
    assert not list(cache.glob("*.npz"))
    monkeypatch.setattr(boxcache, "MIN_VISITS", 0)
    walk_boxes(graph, instances=True, cache=True)
    (entry,) = cache.glob("*.npz")
    # room for that one entry: the two walks kept before it go, oldest first
    monkeypatch.setattr(boxcache, "LIMIT", entry.stat().st_size)
    entry.unlink()
    for cnt in (2, 3):
        walk_boxes(compile_file(TERRAIN, {"cnt": cnt}), instances=True, cache=True)
    assert len(list(cache.glob("*.npz"))) == 2          # both fit: smaller than the limit
    walk_boxes(graph, instances=True, cache=True)
    assert list(cache.glob("*.npz")) == [entry]


def test_a_render_from_kept_bounds_is_the_same_picture(cache, tmp_path, capsys):
    args = [str(TERRAIN), "--set", "cnt=4", "--size", "96x72", "--shadow-samples", "1",
            "--timings", "-q"]
    assert main(["render", *args, "-o", str(tmp_path / "a.png")]) == 0
    assert "read from" not in capsys.readouterr().err
    assert main(["render", *args, "-o", str(tmp_path / "b.png")]) == 0
    err = capsys.readouterr().err
    assert "kept by an earlier render" in err
    assert (tmp_path / "a.png").read_bytes() == (tmp_path / "b.png").read_bytes()


def test_off_walks_every_time(cache, monkeypatch):
    monkeypatch.setenv("PCSG_BOUNDS_CACHE", "0")
    walk_boxes(compile_file(TERRAIN, {"cnt": 4}), instances=True, cache=True)
    assert not cache.exists()


def test_a_write_that_fails_leaves_nothing_behind(cache, monkeypatch):
    def full_disk(f, **arrays):
        f.write(b"PK" + bytes(4096))
        raise OSError(28, "No space left on device")
    graph = compile_file(TERRAIN, {"cnt": 4})
    monkeypatch.setattr(boxcache.np, "savez", full_disk)
    walked = walk_boxes(graph, instances=True, cache=True)
    assert cache.is_dir() and not list(cache.iterdir())     # no entry, no temporary file
    monkeypatch.undo()
    same(walked, walk_boxes(graph, instances=True))


def test_the_terrain_from_order_7_is_kept_by_its_first_render(monkeypatch, tmp_path, capsys):
    """At the threshold as shipped (no MIN_VISITS patched): the terrain at 7, whose walk
    makes 212 k visits, is read back by its second render."""
    monkeypatch.setenv("PCSG_BOUNDS_CACHE", "1")
    monkeypatch.setenv("PCSG_CACHE_DIR", str(tmp_path))
    args = [str(TERRAIN), "--size", "32x24", "--shadow-samples", "1", "--timings", "-q"]
    for cnt, kept in ((6, False), (7, True)):
        for run in range(2):
            assert main(["render", *args, "--set", f"cnt={cnt}",
                         "-o", str(tmp_path / f"{cnt}-{run}.png")]) == 0
            read = "kept by an earlier render" in capsys.readouterr().err
            assert read == (kept and run == 1), (cnt, run)
