"""A polytope primitive (the triangles, the tetrahedron) is bounded under its map by its
mapped corners, in both bounding walks: exact, where the image of its object box is not
(a sheared triangle's box reached the height of the corner (1, 1) the triangle does not
have, and the terrain's patches were 1.3 times as tall as their triangles)."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import pcsg
from pcsg.compiler import compile_text
from pcsg.graph import bounds
from pcsg.graph.bounds import hyper_boxes
from pcsg.graph.flatten import flatten
from pcsg.trace.boxwalk import walk_boxes
from pcsg.trace.primitives import BOXES, CODES, hull

from .conftest import GRAMMARS
from .oracle import assert_agrees

CORNERS = {"tri1": [[0, 0, 0], [1, 0, 0], [0, 1, 0]],
           "tri2": [[0, 0, 0], [-1, 0, 0], [0, -1, 0]],
           "tetrahedron": [[1, 1, 1], [-1, -1, 1], [1, -1, -1], [-1, 1, -1]]}


def _box(points):
    return np.concatenate([points.min(axis=0), points.max(axis=0)])


def _image_of_object_box(name, m):
    """What the walks bounded the primitive by before: its object box's image."""
    return bounds.transform_box(m, BOXES[CODES[name]])


def _both_walks(text):
    """The root's box from the memoised walk and from the compiled walk of every
    instance, and the root's world maps of the primitives (one here)."""
    g = compile_text(text)
    memo, how, _, _ = hyper_boxes(g)
    assert how == "memoised"
    walked, complete, _, _ = walk_boxes(g)
    assert complete
    return memo[g.root], walked[g.root], [x.matrix for x in flatten(g)]


@pytest.mark.parametrize("name, maps", [
    ("tri1", "zshear(1, 1)"),                   # the terrain's shear: corners at 0, 1, 1
    ("tri2", "zshear(1, 1)"),
    ("tri1", "rotx(40) rotz(25) scale(1, 2, 3)"),
    ("tetrahedron", "rotx(40) rotz(25)"),
    ("tetrahedron", "move(1, 2, 3) rotz(45) rotx(30) scale(2, 1, 0.5)"),
])
def test_a_polytope_is_bounded_by_its_mapped_corners(name, maps):
    memo, walked, (m,) = _both_walks(f"{{x = 1}} {maps} {name}")
    exact = _box(np.asarray(CORNERS[name], float) @ m[:3, :3].T + m[:3, 3])
    loose = _image_of_object_box(name, m)
    assert np.allclose(memo, exact, rtol=0, atol=1e-12)
    assert np.allclose(walked, exact, rtol=0, atol=1e-12)
    # what the test tells apart: the object box's image is larger on some side
    assert np.any(np.abs(loose - exact) > 0.1)


def test_round_primitives_keep_their_object_box_image():
    memo, walked, (m,) = _both_walks("{x = 1} rotx(40) rotz(25) cylinder")
    assert hull(CODES["cylinder"]) is None
    assert np.allclose(walked, _image_of_object_box("cylinder", m), rtol=0, atol=1e-12)
    assert np.all(memo[:3] >= walked[:3] - 1e-12) and np.all(memo[3:] <= walked[3:] + 1e-12)


def test_only_the_first_map_above_the_primitive_takes_its_corners():
    """The compiled walk maps the corners through the T-node nearest the primitive, and
    that box through the ones above (conservative); the memoised walk carries the
    corners through all of them (exact)."""
    memo, walked, (m,) = _both_walks("{x = 1} rotz(45) paint(1, 0, 0) zshear(1, 1) tri1")
    exact = _box(np.asarray(CORNERS["tri1"], float) @ m[:3, :3].T + m[:3, 3])
    assert np.allclose(memo, exact, rtol=0, atol=1e-12)
    assert np.all(walked[:3] <= exact[:3] + 1e-12) and np.all(walked[3:] >= exact[3:] - 1e-12)
    # z is only sheared, so the T-node above (a turn about z) keeps it exact
    assert walked[2] == pytest.approx(0.0, abs=1e-12) and walked[5] == pytest.approx(1.0)


@pytest.mark.parametrize("method", ["memoised", "every instance"])
def test_the_terrains_box_is_its_vertices_box(monkeypatch, method):
    """Every map of the terrain above its final triangles' shears moves and scales
    along the axes, so both walks bound it exactly: the root's box is the box of every
    triangle's corners (their object boxes' images rose above its highest vertex)."""
    if method == "memoised":
        monkeypatch.setattr(bounds, "PROBE_STATES", bounds.MAX_STATES)
        monkeypatch.setattr(bounds, "PROBE_RANDOM", bounds.MAX_STATES)
    else:
        monkeypatch.setattr(bounds, "MAX_STATES", 0)
    g = pcsg.load(GRAMMARS / "carpenter_terrain.pcsg", cnt=4).graph
    boxes, how, _, _ = hyper_boxes(g)
    assert how == method
    mnt = next(i for i, n in enumerate(g.nodes) if n.name == "MNT")   # not the sea
    vertices, loose = [], []
    for x in flatten(g):
        if x.primitive in CORNERS:
            c = np.asarray(CORNERS[x.primitive], float)
            vertices.append(c @ x.matrix[:3, :3].T + x.matrix[:3, 3])
            loose.append(_image_of_object_box(x.primitive, x.matrix))
    exact = _box(np.concatenate(vertices))
    assert np.allclose(boxes[mnt], exact, rtol=0, atol=1e-12)
    assert np.max(np.array(loose)[:, 5]) > exact[5] + 1e-3


@settings(max_examples=30, deadline=None)
@given(st.sampled_from(sorted(CORNERS)),
       st.lists(st.floats(-2, 2, allow_nan=False), min_size=12, max_size=12),
       st.integers(0, 2**32 - 1))
def test_the_tracer_culls_nothing_a_polytope_shows(name, a, seed):
    """Culling by the corners' box keeps every hit the reference finds, under any affine
    map that is not near singular, bounded by either walk, in packets and ray by ray:
    rays aimed at points of the primitive, at its corners and edges (a thousandth inside:
    exactly on them, where rounding decides, the two tracers may differ, with the object
    boxes as well)."""
    m = np.array(a).reshape(3, 4)
    if np.linalg.cond(m[:, :3]) > 1e3:
        return
    rows = ", ".join(repr(float(v)) for v in m.ravel())
    text = f"{{x = 1}} matrix({rows}) {name}"
    c = np.asarray(CORNERS[name], float)
    rng = np.random.default_rng(seed)
    w = rng.dirichlet(np.ones(len(c)), size=200)
    w[:80] = np.eye(len(c))[rng.integers(len(c), size=80)]     # corners
    w[80:140, 0] = 0.0                                           # an edge or a face
    w = 0.999 * w / w.sum(axis=1, keepdims=True) + 0.001 / len(c)
    target = m[:, 3] + (w @ c) @ m[:, :3].T
    origin = target + rng.normal(size=(200, 3)) * 3.0
    for states in (bounds.MAX_STATES, 0):      # memoised, then every instance walked
        saved, bounds.MAX_STATES = bounds.MAX_STATES, states
        try:
            obj = pcsg.loads(text)
            got = assert_agrees(obj, origin, target - origin, min_hits=150)
        finally:
            bounds.MAX_STATES = saved
        alone = obj.trace(origin, target - origin, packets=False)
        assert np.array_equal(alone.t, got.t) and np.array_equal(alone.normal, got.normal)
