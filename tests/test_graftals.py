"""Graftals: systems without primitives below their cycles are IFS attractors, bounded
automatically (graph/bounds.py) and rendered at pixel size."""
import math

import numpy as np
import pytest

import pcsg
from pcsg.compiler import compile_file, compile_text
from pcsg.graph import bounds
from pcsg.trace.nodes import EV_LOD, N_EVENTS

from .conftest import GRAMMARS


def _rot(axis, deg):
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    m = np.eye(4)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    m[i, i], m[i, j], m[j, i], m[j, j] = c, -s, s, c
    return m


def _affine(rows):
    m = np.eye(4)
    m[:3] = np.array(rows, float).reshape(3, 4)
    return m


def _move(x, y, z):
    return _affine([1, 0, 0, x, 0, 1, 0, y, 0, 0, 1, z])


# The fern's maps, written out again from grammars/barnsley_fern.pcsg (outermost first)
STEM = _affine([0.02, 0, 0, 0, 0, 0.02, 0, 0, 0, 0, 0.16, 0])
MAIN = _move(0, 0, 1.6) @ _rot(2, 7) @ _affine([0.85, 0, 0.04, 0, 0, 0.85, 0, 0,
                                               -0.04, 0, 0.85, 0])
LEFT = _move(0, 0, 1.6) @ _affine([0.2, 0, -0.26, 0, 0, 0.22, 0, 0, 0.23, 0, 0.22, 0])
RIGHT = _move(0, 0, 0.44) @ _affine([-0.15, 0, 0.28, 0, 0, 0.22, 0, 0, 0.26, 0, 0.24, 0])
LOBE_MAIN = _rot(1, -4) @ MAIN
# module -> its maps and the module each leads to
CODE = {"FERN": [(STEM, "FERN"), (MAIN, "FERN"), (LEFT, "PINNA"), (RIGHT, "PINNA")],
        "PINNA": [(STEM, "PINNA"), (MAIN, "PINNA"), (LEFT, "LOBE"), (RIGHT, "LOBE")],
        "LOBE": [(STEM, "LOBE"), (LOBE_MAIN, "LOBE"), (LEFT, "LOBE"), (RIGHT, "LOBE")]}


def chaos_game(n, rng, p_main, length=60, start="FERN"):
    """n points of the frond's attractor (of module `start`'s): random words of maps
    along the hierarchy, applied to a point of the lowest level's attractor (the fixed
    point of one of its maps), so every point lies on the attractor exactly, up to
    rounding. The main map is drawn with probability p_main: long runs of it reach the
    frond's far tip."""
    a = LOBE_MAIN[:3, :3]
    x0 = np.linalg.solve(np.eye(3) - a, LOBE_MAIN[:3, 3])
    odds = np.array([0.02, p_main, (0.98 - p_main) / 2, (0.98 - p_main) / 2])
    points = np.empty((n, 3))
    for p in range(n):
        module, m = start, np.eye(4)
        steps = 0
        while steps < length or module != "LOBE":
            maps = CODE[module]
            if steps < length:
                w, module = maps[rng.choice(4, p=odds)]
            else:               # down to the lowest level, where x0 lies
                w, module = [x for x in maps if x[1] != module][rng.integers(2)]
            m = m @ w
            steps += 1
        points[p] = m[:3, :3] @ x0 + m[:3, 3]
    return points


@pytest.fixture(scope="module")
def fern():
    return pcsg.load(GRAMMARS / "barnsley_fern.pcsg")


def test_the_automatic_box_holds_the_attractor_and_little_else(fern):
    frond = fern.graph.modules["FERN"]
    box = fern.boxes[frond]
    rng = np.random.default_rng(1)
    pts = np.concatenate([chaos_game(1000, rng, p) for p in (0.3, 0.6, 0.85, 0.95)])
    size = box[3:] - box[:3]
    assert np.all(pts >= box[:3] - 1e-9 * size) and np.all(pts <= box[3:] + 1e-9 * size)
    # Boxes turned by the maps cannot hug a twisted 3-D attractor, but the growth's
    # starting point (the origin) must be gone: each side's slack was up to 53 % of the
    # size before the hull rounds, 35 % after.
    slack = np.concatenate([pts.min(axis=0) - box[:3], box[3:] - pts.max(axis=0)])
    assert np.all(slack <= 0.4 * np.tile(size, 2)), slack / np.tile(size, 2)


def test_the_fern_keeps_the_tightest_box_any_round_found(fern):
    """The hull rounds never settle on the fern (their slack goes round its three
    states), so each node keeps the intersection of every round's boxes: their volumes
    sum to 5 244 where the tracer's, the last round's, summed to 8 895 (and the last
    round's of `bounds.bound` alone to 5 850: the round it stopped at decided)."""
    b = fern.boxes
    real = np.isfinite(b).all(axis=1) & (b[:, 0] <= b[:, 3])
    assert real.sum() > 30
    assert np.prod(b[real, 3:] - b[real, :3], axis=1).sum() < 5300


def _watch_invariant_balls(monkeypatch) -> list:
    """What each call of bounds._invariant_balls returns, in a list that fills as it runs."""
    found = []
    real = bounds._invariant_balls
    monkeypatch.setattr(bounds, "_invariant_balls",
                        lambda g, first, any_rule: found.append(real(g, first, any_rule))
                        or found[-1])
    return found


def test_the_attractor_boxes_start_from_invariant_balls_or_grow_from_a_point(monkeypatch):
    """Two starts of the tightening rounds: balls that one round keeps inside themselves
    (153 box rounds on the fern), and boxes grown from a point (405): both hold the
    attractor, and the rounds take them to the same boxes."""
    graph = compile_file(GRAMMARS / "barnsley_fern.pcsg", {})
    found = _watch_invariant_balls(monkeypatch)
    from_balls = bounds.bound(graph)[0]
    assert found and found[0] is not None
    monkeypatch.setattr(bounds, "_invariant_balls", lambda g, first, any_rule: None)
    grown = bounds.bound(graph)[0]
    real = np.isfinite(grown).all(axis=1) & (grown[:, 0] <= grown[:, 3])
    assert np.abs(from_balls[real] - grown[real]).max() <= 1e-8 * np.abs(grown[real]).max()


def test_maps_that_grow_balls_on_the_way_round_a_cycle_grow_a_box_instead(monkeypatch):
    """scale(2, 0.25, 0.25) scale(0.25, 2, 0.25) contracts, but the ball walk scales a
    ball by each map's largest singular value, 2 and 2: no ball is kept inside itself,
    and the box grows from a point. The attractor is the segment from (0,0,0) (the first
    map's fixed point) to (2,0,0) (the second's)."""
    graph = compile_text("S ∪ move(0, 0, -3) plane\nS 1\n1: S → scale(2, 0.25, 0.25) "
                         "scale(0.25, 2, 0.25) S ∪ move(1, 0, 0) uscale(0.5) S\n")
    found = _watch_invariant_balls(monkeypatch)
    box = bounds.bound(graph)[0][graph.modules["S"]]
    assert found == [None]
    assert np.allclose(box, [0, 0, 0, 2, 0, 0], atol=1e-8)


@pytest.mark.parametrize("selection, assign", [("rand() < 0.5", ""),
                                               ("k % 2 == 0", "{k = k + 1} ")])
def test_a_graftal_whose_selection_differs_by_instance_is_bounded_and_drawn(selection, assign):
    """A rand() or a counter that picks the rule made every instance's state its own: the
    memoised bounds gave up, the instance walk cannot bound what never ends, and the
    graftal had no bounding volume: drawn as nothing, after every ray entered
    --max-instances instances (100 s at 96x72). Bounded now with every rule taken: the
    box that holds the attractor of all four maps, [-1, 1]^3."""
    maps = [f"move({x},{y},{z}) uscale(0.5) S" for x, y, z in
            [(0.5, 0.5, 0.5), (-0.5, -0.5, 0.5), (0.5, -0.5, -0.5), (-0.5, 0.5, -0.5)]]
    text = (f"{{k = 0}} S\nS if({selection}, 1, 2)\n1: S → {assign}({' ∪ '.join(maps[:3])})\n"
            f"2: S → {assign}({' ∪ '.join(maps[1:])})\n")
    traced = pcsg.loads(text)
    assert traced.bounds_method == bounds.ANY_RULE and not traced.warnings
    np.testing.assert_allclose(traced.bounds, [-1, -1, -1, 1, 1, 1], atol=1e-6)
    from .oracle import camera_rays
    o, d = camera_rays(traced.bounds, 32, (1, -1.5, 0.5), spread=0.3)
    hits = traced.trace(o, d, lod=0.01)
    assert hits.hit.sum() > 30 and hits.events[EV_LOD].sum() > 0    # refined to its size


def test_a_graftal_whose_maps_differ_by_instance_and_that_draws_nothing_says_so():
    """Where what differs feeds a map (a rotation drawn by rand()), taking every rule
    does not make the states few. Without a primitive on its cycles such a graftal has
    nothing to draw: every ray entered --max-instances instances of it (38 s at 48x36)
    to draw nothing, without a word why; now it is bounded as empty, and said so."""
    graph = compile_text("S ∪ move(0, 0, -2) cube\n1: S → {a = 20 * rand()} (rotz(a) "
                         "move(0.5,0,0) uscale(0.5) S ∪ move(-0.5,0,0) uscale(0.5) S)\n")
    assert bounds._any_rule(graph, 8) is None
    traced = pcsg.Traced(graph)
    assert traced.bounds_method == bounds.MEMOISED
    (w,) = [w for w in traced.warnings if w.code == "unbounded-graftal"]
    assert w.message.startswith("'S' is a graftal (no rule of it ends) whose instances "
                                "differ in their maps") and "draws nothing of it" in w.message
    np.testing.assert_allclose(traced.bounds, [-1, -1, -3, 1, 1, -1])     # the cube alone
    # with a sphere on its cycle it has something to draw: left to the instance walk
    drawn = compile_text("S\n1: S → {a = 20 * rand()} (rotz(a) move(0.5,0,0) uscale(0.5) S "
                         "∪ sphere)\n")
    assert bounds._unboundable_voids(drawn, 8) is None


def test_finer_pixels_refine_the_fern_deeper(fern):
    """Rays refine instances until they are smaller than the pixel footprint and take
    that instance's box as the surface: a finer footprint goes deeper."""
    eye = np.array([11.0, -16, 5])
    tip = np.linalg.solve(np.eye(3) - MAIN[:3, :3], MAIN[:3, 3])    # on the attractor
    d = tip - eye
    deepest = []
    for lod in (1e-2, 1e-4):
        h = fern.trace([eye], [d], lod=lod)
        assert h.hit[0]
        deepest.append(h.events[N_EVENTS + EV_LOD].max())
    assert 5 < deepest[0] < deepest[1]


def test_averaged_normals_shade_the_fern_more_smoothly(fern):
    """A hit on a sub-pixel box takes the average of the normals of the boxes that led to
    it, the finer weighing more (Hart & DeFanti, as Bekaert & Willems do): neighbouring
    rays then turn their normals less than with the last box's normal alone."""
    plain = pcsg.Traced(fern.graph, average_normals=False)
    eye = np.array([11.0, -16, 5])
    box = fern.boxes[fern.graph.modules["FERN"]]
    centre = (box[:3] + box[3:]) / 2
    fwd = centre - eye
    right = np.cross(fwd, [0, 0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd / np.linalg.norm(fwd))
    u = np.linspace(-0.12, 0.12, 120)
    U, V = np.meshgrid(u, u * 1.5)
    d = fwd + np.linalg.norm(fwd) * (U.ravel()[:, None] * right + V.ravel()[:, None] * up)
    o = np.tile(eye, (len(d), 1))
    turn = []
    for traced in (fern, plain):
        h = traced.trace(o, d, lod=2e-3)
        n = h.normal.reshape(120, 120, 3)
        hit = h.hit.reshape(120, 120)
        assert hit.sum() > 500
        assert np.allclose(np.linalg.norm(n[hit], axis=1), 1.0)
        both = hit[:, 1:] & hit[:, :-1]
        cos = np.sum(n[:, 1:] * n[:, :-1], axis=2)[both]
        turn.append(np.mean(np.arccos(np.clip(cos, -1, 1))))
    assert turn[0] < 0.9 * turn[1], turn          # measured: 0.35 against 0.43 rad


def test_the_reference_render_of_a_graftal_is_cut_where_the_tracer_is(tmp_path, capsys):
    # it ignored --max-depth, expanded to 10 000 levels and failed after seconds
    from pcsg.cli import main
    fern = str(GRAMMARS / "barnsley_fern.pcsg")
    out = tmp_path / "f.png"
    assert main(["render", fern, "--reference", "--size", "20x15", "-o", str(out), "-q"]) == 1
    assert "--reference: 'FERN' has no rule that ends" in capsys.readouterr().err
    assert not out.exists()
    assert main(["render", fern, "--reference", "--max-depth", "2", "--size", "20x15",
                 "-o", str(out), "-q"]) == 0
    assert out.exists()


# two maps, one turned by an angle no multiple of 90 degrees, each instance a sphere: the
# memoised walk's rounds went round five estimates without end (the corner points merged
# into a box past MAX_POINTS, and that box turned grew again), so the graftal was walked
# instance by instance, unbounded: 19 s at 48x36, every ray at --max-instances, and the
# second branch never drawn (QA)
# (QA); and boxes turned by maps that shrink them less than the turn widens them grow
# round after round without end (uscale(0.72) rotz(45): 0.72 (cos 45 + sin 45) > 1), as
# do those of a map that shrinks slowly (uscale(0.94)): 40 to 50 s at 64x48, unbounded
TURNED = ["S\n1: S → uscale(0.5) sphere ∪ move(1,0,0) uscale(0.5) rotz(40) S ∪ "
          "move(-1,0,0) uscale(0.5) S\n",
          "S\n1: S → uscale(0.2) sphere ∪ move(0.3,0,0.1) rotz(45) uscale(0.72) S ∪ "
          "move(0,1,0) uscale(0.3) S\n",
          "S\n1: S → uscale(0.2) sphere ∪ move(0.3,0,0.1) uscale(0.94) S ∪ "
          "move(0,1,0) uscale(0.3) S\n",
          "S\n1: S → scale(0.07,0.07,1) cylinder ∪ move(0,0,1) rotz(137) roty(40) uscale(0.65) "
          "S ∪ move(0,0,0.6) rotz(250) roty(35) uscale(0.6) S\n"]


@pytest.mark.parametrize("text", TURNED)
def test_a_system_whose_rounds_do_not_settle_is_bounded_by_its_attractor(text):
    from pcsg.graph.cut import cut_of
    from pcsg.trace.reference import Reference
    from pcsg.tracer import Traced
    traced = pcsg.loads(text)
    assert traced.bounds_method == "memoised" and not traced.warnings
    # the box holds every instance of the expansion 8 levels deep: points on each sphere,
    # or on each cylinder's rims
    ref = Reference(traced.graph, cut=cut_of(Traced(traced.graph, max_depth=8)))
    root = traced.boxes[traced.graph.root]
    u = np.random.default_rng(1).normal(size=(200, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    rims = np.concatenate([u[:, :2] / np.linalg.norm(u[:, :2], axis=1, keepdims=True)] * 2)
    surface = {"sphere": u,
               "cylinder": np.column_stack([rims, np.repeat([0.0, 1.0], len(u))])}
    drawn = [leaf for leaf in ref.leaves if leaf.name in surface]     # not the cut's boxes
    assert len(drawn) > 100
    for leaf in drawn:
        p = surface[leaf.name] @ leaf.matrix[:3, :3].T + leaf.matrix[:3, 3]
        assert (p >= root[:3] - 1e-9).all() and (p <= root[3:] + 1e-9).all()
    # and cut at a depth, the graph tracer and the expansion agree ray by ray
    cut = Traced(traced.graph, max_depth=6, average_normals=False)
    x, y = np.meshgrid(np.linspace(root[0], root[3], 48), np.linspace(root[1], root[4], 16))
    o = np.stack([x.ravel(), y.ravel(), np.full(x.size, 5.0)], axis=1)
    d = np.tile([0.05, 0.03, -1.0], (len(o), 1))         # from above, a little aslant
    got = cut.trace(o, d)
    want = Reference(cut.graph, cut=cut_of(cut)).trace(o, d, exits=True)
    assert got.hit.sum() > 100 and (got.hit == want["hit"]).all()
    assert np.allclose(got.t[got.hit], want["t"][got.hit], rtol=1e-9)
    # the cut is the depth limit's, and no walk is cut short by a buffer
    assert [e.split(":")[0] for e in cut.describe_events(got.events)] == ["depth limit"]
