"""Without --max-depth, a derivation that ends is walked to its end: a row of 100 trees
written as a chain, the natural way, drew 64 of them and a note."""
import subprocess
import sys

import numpy as np

import pcsg
from pcsg.graph import bounds
from pcsg.limits import DEEPEST_DEFAULT, MAX_DEPTH

ROW = """{{ n = {n} }} ROW
ROW if(n > 0, 2, 1)
1: ROW → sphere
2: ROW → sphere ∪ {{ n = n - 1 }} move(2, 0, 0) ROW
"""


def _last_hit(obj, n):
    """Whether a ray down onto the row's last sphere (at x = 2n) hits it."""
    return bool(obj.trace(np.array([[2.0 * n, 0, 5]]), np.array([[0, 0, -1.0]])).hit[0])


def test_a_row_deeper_than_64_is_drawn_to_its_end():
    obj = pcsg.loads(ROW.format(n=100))
    assert obj.bounds_method == "memoised"
    assert obj.max_depth == obj.asked_depth == 101 and _last_hit(obj, 100)
    # asked for, the depth is what it was
    cut = pcsg.loads(ROW.format(n=100), max_depth=MAX_DEPTH)
    assert cut.max_depth == MAX_DEPTH and not _last_hit(cut, 100) and _last_hit(cut, 63)


def test_the_default_stays_64_where_the_derivation_does_not_end_or_is_too_deep(monkeypatch):
    # shallower systems keep 64, which costs them nothing
    assert pcsg.loads(ROW.format(n=10)).max_depth == MAX_DEPTH
    # deeper than DEEPEST_DEFAULT levels
    deep = pcsg.loads(ROW.format(n=DEEPEST_DEFAULT + 5))
    assert deep.max_depth == MAX_DEPTH
    # and says so, with the depth that draws it whole (a chain of 3,000 modules drew
    # nothing, its note told of instances "finished with their terminating rule")
    said = [w.message for w in deep.warnings if w.code == "deep-derivation"]
    assert said == [f"the derivation ends {DEEPEST_DEFAULT + 5:,} levels down, deeper than "
                    f"the {DEEPEST_DEFAULT:,} a render follows without max_depth: it is "
                    f"cut at {MAX_DEPTH}; max_depth={DEEPEST_DEFAULT + 6} draws it whole"]
    whole = pcsg.loads(ROW.format(n=DEEPEST_DEFAULT + 5), max_depth=DEEPEST_DEFAULT + 6)
    assert _last_hit(whole, DEEPEST_DEFAULT + 5) and not _last_hit(deep, DEEPEST_DEFAULT + 5)
    assert not [w for w in whole.warnings if w.code == "deep-derivation"]
    # a graftal never ends
    graftal = pcsg.loads("S\nS 1\n1: S → move(0.5, 0, 0) uscale(0.5) S ∪ move(-0.5, 0, 0) uscale(0.5) S")
    assert graftal.max_depth == MAX_DEPTH
    # one bounded instance by instance (too many states): its depth is not known before
    # the walk, which walks to the depth it is given
    monkeypatch.setattr(bounds, "MAX_STATES", 0)
    walked = pcsg.loads(ROW.format(n=100))
    assert walked.bounds_method == "every instance" and walked.max_depth == MAX_DEPTH


def test_render_draws_the_row_without_a_depth_note(tmp_path):
    path = tmp_path / "row.pcsg"
    path.write_text(ROW.format(n=100), encoding="utf-8")
    run = [sys.executable, "-m", "pcsg", "render", str(path), "--size", "80x60",
           "-o", str(tmp_path / "row.png")]
    out = subprocess.run(run, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0 and "depth limit" not in out.stderr, out.stderr
    out = subprocess.run(run + ["--max-depth", "64"], capture_output=True, text=True,
                         timeout=300)
    assert out.returncode == 0 and "depth limit: instances at --max-depth 64" in out.stderr


def test_a_row_whose_states_cull_nothing_is_still_drawn_to_its_end():
    # its boxes by state would cull no more than its node boxes, so it has no table of
    # them; the first version took that table for "the derivation ends" (found by review)
    tight = ROW.format(n=100).replace("move(2, 0, 0)", "move(0.001, 0, 0)")
    assert pcsg.loads(tight).max_depth == 101
    drawn = pcsg.loads(ROW.format(n=100).replace("move(2, 0, 0)", "move(2, rand() * 0.1, 0)"))
    assert drawn.bounds_method == "memoised" and drawn.max_depth == 101


def test_a_counter_that_no_longer_counts_is_drawn_at_pixel_size():
    """At c = 1e16, c - 1 is c: the state recurs and never selects the terminating rule,
    so its tetrahedron had no box, and the instances the level of detail finishes with
    it drew nothing ("no ray met the object"). Drawn now as at c = 40, ray by ray."""
    import numpy as np
    import pcsg
    from pcsg.render.camera import make_camera
    text = ("{c = 40} S\nS if(c > 0, 2, 1)\n1: S → tetrahedron\n2: S → {c = c-1} ("
            "move(0.5,0.5,0.5) uscale(0.5) S ∪ move(-0.5,-0.5,0.5) uscale(0.5) S ∪ "
            "move(0.5,-0.5,-0.5) uscale(0.5) S ∪ move(-0.5,0.5,-0.5) uscale(0.5) S)\n")
    hits = []
    for c in (40, 1e16):
        obj = pcsg.loads(text, c=c)
        cam = make_camera(obj, 4 / 3)
        ys, xs = np.mgrid[0:60, 0:80]
        o, d = cam.rays(80, 60, xs.ravel() + 0.5, ys.ravel() + 0.5)
        hits.append(obj.trace(o, d, lod=cam.pixel_angle(60)))
    assert hits[0].hit.sum() > 400
    assert np.array_equal(hits[0].hit, hits[1].hit)
    np.testing.assert_array_equal(hits[0].t[hits[0].hit], hits[1].t[hits[1].hit])
