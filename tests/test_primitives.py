"""Ray / primitive intersection (pcsg.trace.primitives) against independent
inside tests and dense sampling along the line."""
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from pcsg.trace import primitives as P

INF = math.inf
SOLIDS = ["sphere", "cube", "cylinder", "cone", "tetrahedron", "plane"]
CORNERS = np.array([[1, 1, 1], [-1, -1, 1], [1, -1, -1], [-1, 1, -1]], dtype=float)
_BARY = np.linalg.inv(np.vstack([CORNERS.T, np.ones(4)]))     # (p, 1) -> barycentric


# ---- independent descriptions of the solids ----------------------------------------
# g(p) <= 0 inside, = 0 on the surface, > 0 outside; |g| is within a small factor
# of the distance to the surface near it. Vectorised over p of shape (..., 3).

def g_sphere(p):
    return np.linalg.norm(p, axis=-1) - 1.0


def g_cube(p):
    return np.max(np.abs(p), axis=-1) - 1.0


def g_cylinder(p):
    r = np.hypot(p[..., 0], p[..., 1])
    return np.maximum.reduce([r - 1.0, -p[..., 2], p[..., 2] - 1.0])


def g_cone(p):
    r = np.hypot(p[..., 0], p[..., 1])
    return np.maximum.reduce([(r - (1.0 - p[..., 2])) / math.sqrt(2), -p[..., 2],
                              p[..., 2] - 1.0])


def g_tetrahedron(p):
    # barycentric coordinates in the corners: inside iff all >= 0; scaled so that
    # -lambda_i is about the distance to the face opposite corner i
    q = np.concatenate([p, np.ones(p.shape[:-1] + (1,))], axis=-1)
    lam = q @ _BARY.T
    return np.max(-lam, axis=-1) * (4 / math.sqrt(3))


def g_plane(p):
    return p[..., 2]


G = {"sphere": g_sphere, "cube": g_cube, "cylinder": g_cylinder, "cone": g_cone,
     "tetrahedron": g_tetrahedron, "plane": g_plane}


def hit(name, o, d):
    out = np.full(8, np.nan)
    ok = P.intersect(P.CODES[name], float(o[0]), float(o[1]), float(o[2]),
                     float(d[0]), float(d[1]), float(d[2]), out)
    return bool(ok), out


def random_rays(rng, n):
    """Rays from around the solids, about half of them aimed at them; directions
    of random length over many orders of magnitude."""
    o = rng.uniform(-3, 3, (n, 3))
    aim = rng.uniform(-1.2, 1.2, (n, 3)) - o
    free = rng.normal(size=(n, 3))
    d = np.where(rng.random((n, 1)) < 0.5, aim, free)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return o, d * 10.0 ** rng.uniform(-4, 4, (n, 1))


# ---- constants -------------------------------------------------------------------

def test_codes_and_constants():
    assert list(P.CODES) == ["sphere", "cube", "cylinder", "cone", "tetrahedron", "plane",
                             "tri1", "tri2", "mandelbulb", "julia"]
    assert P.FLAT == {P.CODES["tri1"], P.CODES["tri2"]}
    assert P.UNION_ONLY == P.FLAT | {P.MANDELBULB, P.JULIA}
    assert P.BOXES.shape == (10, 6)
    assert list(P.object_box("mandelbulb", (2.0,))) == pytest.approx([-2, -2, -2, 2, 2, 2])
    assert list(P.box(P.CODES["plane"])) == [-INF, -INF, -INF, INF, INF, 0.0]
    assert list(P.box(P.CODES["cylinder"])) == [-1, -1, 0, 1, 1, 1]
    assert list(P.box(P.CODES["tri2"])) == [-1, -1, 0, 0, 0, 0]


@pytest.mark.parametrize("name", ["sphere", "cube", "cylinder", "cone", "tetrahedron"])
def test_boxes_contain_the_solids(name):
    rng = np.random.default_rng(1)
    p = rng.uniform(-1.5, 1.5, (20000, 3))
    inside = p[G[name](p) <= 0]
    b = P.BOXES[P.CODES[name]]
    assert len(inside) > 500
    assert np.all(inside >= b[:3]) and np.all(inside <= b[3:])


# ---- solids: random lines ------------------------------------------------------------

@pytest.mark.parametrize("name", SOLIDS)
def test_random_lines(name):
    g = G[name]
    rng = np.random.default_rng(list(P.CODES).index(name))
    o, d = random_rays(rng, 400)
    s = np.linspace(-12, 12, 6001)                 # arc length along the line
    step = s[1] - s[0]
    hits = 0
    for k in range(len(o)):
        ok, out = hit(name, o[k], d[k])
        dn = np.linalg.norm(d[k])
        samples = o[k] + (s / dn)[:, None] * d[k]
        gs = g(samples)
        if not ok:
            assert not np.any(gs < -1e-7), (o[k], d[k])
            continue
        hits += 1
        t0, t1 = out[0], out[1]
        assert t0 <= t1
        # the samples strictly inside lie within [t0, t1]
        ts = s / dn
        inside = gs < -1e-7
        if np.any(inside):
            assert ts[inside].min() >= t0 - 1e-9 / dn and ts[inside].max() <= t1 + 1e-9 / dn
        if (t1 - t0) * dn > 2 * step and np.isfinite(t0) and np.isfinite(t1):
            assert np.any(gs <= 1e-9)
        # the mid-interval point is inside
        if np.isfinite(t0) and np.isfinite(t1):
            mid = 0.5 * (t0 + t1)
        elif np.isfinite(t0):
            mid = t0 + 1.0 / dn
        elif np.isfinite(t1):
            mid = t1 - 1.0 / dn
        else:
            mid = 0.0
        assert g(o[k] + mid * d[k]) <= 1e-9
        # finite ends: on the surface, outward normal
        for t, n in ((t0, out[2:5]), (t1, out[5:8])):
            if not np.isfinite(t):
                continue
            p = o[k] + t * d[k]
            assert abs(g(p)) < 1e-9, (t, p, g(p))
            assert np.all(np.isfinite(n)) and np.linalg.norm(n) > 0
            u = n / np.linalg.norm(n)
            eps = 1e-5
            assert g(p + eps * u) > 0.1 * eps
            assert g(p - eps * u) < eps
    assert hits > 50


@pytest.mark.parametrize("name", SOLIDS)
def test_unnormalised_directions_give_the_same_points(name):
    rng = np.random.default_rng(7)
    o, d = random_rays(rng, 100)
    for k in range(len(o)):
        u = d[k] / np.linalg.norm(d[k])
        ok, ref = hit(name, o[k], u)
        for scale in (1e-9, 1e-3, 0.37, 5.0, 1e6, 1e12):
            ok2, out = hit(name, o[k], u * scale)
            assert ok2 == ok
            if ok:
                for i in (0, 1):
                    if np.isfinite(ref[i]):
                        np.testing.assert_allclose(o[k] + out[i] * u * scale,
                                                   o[k] + ref[i] * u, atol=1e-9)
                    else:
                        assert out[i] == ref[i]


@pytest.mark.parametrize("name", SOLIDS)
def test_origins_far_along_the_line_give_the_same_points(name):
    """A camera far from a small or flattened object puts the ray's origin far off in the
    object's frame (scale(1e-8, 1, 1) cone seen from 6 units: 6e8 along x). Moving the
    origin back along the line changes the hits by no more than rounding at that
    distance; the cone's quadratic lost everything there and hit its whole box (QA)."""
    rng = np.random.default_rng(11)
    o, d = random_rays(rng, 300)
    for k in range(len(o)):
        u = d[k] / np.linalg.norm(d[k])
        ok, ref = hit(name, o[k], u)
        chord = ref[1] - ref[0] if ok else 0.0
        for far in (1e4, 1e8, 6e8):
            start = o[k] - far * u
            ok2, out = hit(name, start, u)
            if ok2 != ok:
                # only a line that grazes the solid may flip at rounding's distance
                assert max(chord, out[1] - out[0] if ok2 else 0.0) < 1e-6, (k, far, ref, out)
                continue
            if ok and name != "plane":
                np.testing.assert_allclose(out[:2] - far, ref[:2], atol=1e-6 + far * 1e-14)


def test_a_flattened_cone_seen_side_on_from_far_is_a_triangle():
    """The QA's scene in the cone's frame: scale(1e-8, 1, 1) cone seen along -x from
    x = 6, every line through the yz plane hits where |y| <= 1 - z, 0 <= z <= 1."""
    rng = np.random.default_rng(3)
    y = rng.uniform(-1.2, 1.2, 3000)
    z = rng.uniform(-0.2, 1.2, 3000)
    inside = (z >= 0) & (z <= 1) & (np.abs(y) <= 1 - z)
    edge = np.minimum.reduce([np.abs(np.abs(y) - (1 - z)), np.abs(z), np.abs(z - 1)]) < 1e-9
    got = np.array([hit("cone", (6e8, y[k], z[k]), (-1e8, 0, 0))[0] for k in range(len(y))])
    assert inside.sum() > 500
    assert np.array_equal(got[~edge], inside[~edge])


# ---- solids: exact cases ---------------------------------------------------------------

AXIS_CASES = [
    # name, origin, direction, expected (t_in, t_out) or None
    ("sphere", (0, 0, -5), (0, 0, 1), (4, 6)),
    ("sphere", (0.6, 0, -5), (0, 0, 2), ((5 - 0.8) / 2, (5 + 0.8) / 2)),
    ("sphere", (1, 0, -5), (0, 0, 1), (5, 5)),                 # grazing
    ("sphere", (1.0000001, 0, -5), (0, 0, 1), None),
    ("sphere", (-3, 0, 0), (1, 0, 0), (2, 4)),
    ("cube", (-5, 0.5, 0.5), (1, 0, 0), (4, 6)),
    ("cube", (0.5, -5, 1.0), (0, 1, 0), (4, 6)),               # in the plane of a face
    ("cube", (0.5, 1.5, 3), (0, 0, -1), None),
    ("cube", (1, 1, -3), (0, 0, 1), (2, 4)),                   # along an edge
    ("cube", (0, 0, 0), (0, 0, -0.5), (-2, 2)),
    ("cylinder", (0, 0, -1), (0, 0, 1), (1, 2)),
    ("cylinder", (0.3, 0.4, 5), (0, 0, -1), (4, 5)),
    ("cylinder", (-3, 0, 0.5), (1, 0, 0), (2, 4)),
    ("cylinder", (-3, 0, 1.5), (1, 0, 0), None),
    ("cylinder", (1, 0, -2), (0, 0, 1), (2, 3)),               # on the side, along it
    ("cylinder", (1.5, 0, 0.5), (0, 0, 1), None),
    ("cone", (0, 0, -1), (0, 0, 1), (1, 2)),                   # along the axis to the apex
    ("cone", (-3, 0, 0.5), (1, 0, 0), (2.5, 3.5)),
    ("cone", (0.5, 0, -2), (0, 0, 1), (2, 2.5)),
    ("cone", (2, 0, -1), (-1, 0, 1), (1, 2)),                  # along a generator
    ("cone", (1.5, 0, -1), (-1, 0, 1), (1, 1.75)),             # parallel to a generator
    ("cone", (3, 0, 1), (-1, 0, 0), (3, 3)),                   # through the apex only
    ("cone", (0, 0, 2), (0, 1, 0), None),
    ("cone", (0, 0, 0.5), (0, 0, 0), (-INF, INF)),             # zero direction, inside
    ("tetrahedron", (0, 0, -5), (0, 0, 1), (4, 6)),
    ("tetrahedron", (1, 1, -5), (0, 0, 1), (6, 6)),            # touches the corner (1,1,1)
    ("tetrahedron", (0.9, 0.9, -5), (0, 0, 1), (5.8, 6)),
    ("tetrahedron", (2, 0, 0), (0, 0, 1), None),
    ("tetrahedron", (-3, 0, 0), (1, 0, 0), (2, 4)),
    ("plane", (0, 0, 1), (0, 0, -1), (1, INF)),
    ("plane", (0, 0, 1), (0, 0, 2), (-INF, -0.5)),
    ("plane", (3, 4, -1), (1, 0.5, 0), (-INF, INF)),           # parallel, inside
    ("plane", (3, 4, 0), (1, 0.5, 0), (-INF, INF)),            # parallel, on the boundary
    ("plane", (3, 4, 1e-300), (1, 0.5, 0), None),              # parallel, outside
    ("sphere", (0, 0, 0), (0, 0, 0), (-INF, INF)),
    ("sphere", (2, 0, 0), (0, 0, 0), None),
    ("sphere", (0, 0, -5), (1e-310, 0, 1e-300), (4e300, 6e300)),
    ("cube", (-5, 0.5, 0.5), (5e-324, 0, 0), (INF, INF)),      # t overflows: both ends inf
]


@pytest.mark.parametrize("name, o, d, expect", AXIS_CASES)
def test_exact_cases(name, o, d, expect):
    ok, out = hit(name, o, d)
    if expect is None:
        assert not ok
        return
    assert ok
    np.testing.assert_allclose(out[:2], expect, rtol=1e-12, atol=1e-12)
    assert np.all(np.isfinite(out[2:8]))


def test_plane_normals():
    ok, out = hit("plane", (0, 0, 1), (0, 0, -1))
    assert ok and list(out[2:5]) == [0, 0, 1] and list(out[5:8]) == [0, 0, 1]
    ok, out = hit("plane", (0, 0, -1), (0.3, 0, 1))
    assert ok and out[0] == -INF and out[1] == pytest.approx(1.0)
    assert out[7] > 0 and out[5] == 0 and out[6] == 0


def test_normals_of_axis_cases():
    _, out = hit("cube", (-5, 0.5, 0.5), (1, 0, 0))
    assert list(out[2:5]) == [-1, 0, 0] and list(out[5:8]) == [1, 0, 0]
    _, out = hit("cylinder", (0.3, 0.4, 5), (0, 0, -1))
    assert list(out[2:5]) == [0, 0, 1] and list(out[5:8]) == [0, 0, -1]
    _, out = hit("cone", (-3, 0, 0.5), (1, 0, 0))
    assert np.allclose(out[2:5] / np.linalg.norm(out[2:5]), [-1 / math.sqrt(2), 0, 1 / math.sqrt(2)])
    _, out = hit("tetrahedron", (0, 0, -5), (0, 0, 1))
    # enters through a face whose outward normal points down, leaves through one pointing up
    assert out[4] < 0 and out[7] > 0


@given(st.sampled_from(SOLIDS + ["tri1", "tri2"]),
       st.lists(st.one_of(st.floats(-4, 4), st.sampled_from([0.0, -0.0, 1.0, -1.0, 1e-300,
                                                              5e-324, 1e300])),
                min_size=6, max_size=6))
@settings(max_examples=400, deadline=None)
def test_any_input_is_safe(name, v):
    ok, out = hit(name, v[:3], v[3:])
    if ok:
        assert not np.isnan(out[0]) and not np.isnan(out[1]) and out[0] <= out[1]
        assert not np.any(np.isnan(out[2:8]))


def test_non_finite_input_misses():
    for name in SOLIDS + ["tri1"]:
        assert not hit(name, (np.nan, 0, 0), (0, 0, 1))[0]
        assert not hit(name, (0, 0, 0), (0, np.inf, 1))[0]


# ---- flat triangles ---------------------------------------------------------------------

@pytest.mark.parametrize("name, sign", [("tri1", 1.0), ("tri2", -1.0)])
def test_triangle_hits_edges_and_misses(name, sign):
    inside = [(0.2, 0.3), (0.0, 0.5), (0.5, 0.0), (0.5, 0.5), (0.0, 0.0), (1.0, 0.0),
              (0.0, 1.0), (0.25, 0.75), (1e-17, 1e-17)]
    outside = [(-1e-6, 0.5), (0.5, -1e-6), (0.5, 0.5 + 1e-6), (1.1, 0.0), (-0.2, -0.2),
               (0.6, 0.6)]
    for (x, y), expect in [(p, True) for p in inside] + [(p, False) for p in outside]:
        for d in ((0, 0, -1), (0.3, -0.2, -2.0), (0, 0, 1e-8)):
            d = np.array(d, dtype=float)
            # the line through (sign*x, sign*y, 0) with direction d
            o = np.array([sign * x, sign * y, 0.0]) - 3.0 * d
            ok, out = hit(name, o, d)
            assert ok == expect, (name, x, y, d)
            if ok:
                assert out[0] == out[1] == pytest.approx(3.0)
                assert list(out[2:5]) == [0, 0, 1] and list(out[5:8]) == [0, 0, 1]


@pytest.mark.parametrize("name", ["tri1", "tri2"])
def test_triangle_parallel_rays_miss(name):
    assert not hit(name, (0.1, 0.1, 0.0), (1, 0, 0))[0]
    assert not hit(name, (0.1, 0.1, 1.0), (1, 1, 0))[0]
    assert not hit(name, (-0.1, -0.1, 0.0), (0, 0, 0))[0]


def test_triangles_sharing_an_edge_leave_no_gap():
    """tri1 and tri2 moved by (1, 1) share the hypotenuse x + y = 1 (world); rays
    through random points of it hit at least one of them."""
    rng = np.random.default_rng(3)
    for x in rng.uniform(0, 1, 2000):
        p = np.array([x, 1.0 - x, 0.0])
        d = rng.normal(size=3)
        d[2] = -abs(d[2]) - 0.01
        o = p - 1.7 * d
        a, _ = hit("tri1", o, d)
        b, _ = hit("tri2", o - np.array([1.0, 1.0, 0.0]), d)
        assert a or b
