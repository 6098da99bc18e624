"""The reference tracer (pcsg.trace.reference): the expanded CSG tree traced
with interval CSG, against analytic answers and independent point tests."""
import math

import numpy as np
import pytest

from pcsg.compiler import compile_file, compile_text
from pcsg.graph.flatten import flatten
from pcsg.language.errors import PcsgError
from pcsg.trace.reference import LEAF, Op, Reference

from .conftest import GRAMMARS


def ref(text, **overrides):
    return Reference(compile_text(text, "t.pcsg", overrides))


def rays_at(rng, n, target=(0, 0, 0), spread=1.5, dist=6.0):
    """Rays from a sphere of radius `dist` around `target`, aimed near it."""
    target = np.asarray(target, dtype=float)
    o = rng.normal(size=(n, 3))
    o = target + dist * o / np.linalg.norm(o, axis=1, keepdims=True)
    d = target + rng.uniform(-spread, spread, (n, 3)) - o
    return o, d / np.linalg.norm(d, axis=1, keepdims=True)


def sphere_interval(o, d, c, r):
    """Analytic [t0, t1] of the unit-direction ray o + t d in the sphere (c, r), or None."""
    oc = o - c
    b = np.dot(oc, d)
    disc = b * b - (np.dot(oc, oc) - r * r)
    if disc < 0:
        return None
    s = math.sqrt(disc)
    return -b - s, -b + s


# ---- the tree ----------------------------------------------------------------------

def test_tree_structure_keeps_operators_and_order():
    r = ref("paint(1,0,0) sphere \\ move(1,0,0) cube \\ cone ∪ material(gold) cylinder\n"
            "#material gold color=(1,0.8,0)")
    root = r.nodes[r.root]
    assert isinstance(root, Op) and root.name == "union"
    diff = r.nodes[root.children[0]]
    assert diff.name == "difference" and len(diff.children) == 3
    names = [r.nodes[c].name for c in diff.children]
    assert names == ["sphere", "cube", "cone"]
    cyl = r.nodes[root.children[1]]
    assert cyl.material == 0 and cyl.paint == (1.0, 0.8, 0.0)     # gold's own colour
    assert r.nodes[diff.children[0]].paint == (1.0, 0.0, 0.0)
    np.testing.assert_array_equal(r.nodes[diff.children[1]].matrix[:3, 3], [1, 0, 0])
    assert LEAF == -1
    tree = r.as_tree()
    assert tree[0] == "union" and tree[1][0][0] == "difference"
    code, matrix, paint, material = tree[1][0][1][0]
    assert code == 0 and paint == (1.0, 0.0, 0.0) and material == -1
    assert tree[1][1][0] == 2 and tree[1][1][3] == 0


def test_leaves_match_flatten():
    g = compile_file(GRAMMARS / "sympodial_tree.pcsg", {"cnt": 3})
    r = Reference(g)
    flat = flatten(g)
    assert [l.name for l in r.leaves] == [i.primitive for i in flat]
    for leaf, inst in zip(r.leaves, flat):
        np.testing.assert_array_equal(leaf.matrix, inst.matrix)
        assert leaf.paint == (tuple(inst.paint) if inst.paint is not None else None)


def test_too_many_primitives():
    g = compile_file(GRAMMARS / "sierpinski.pcsg", {"c": 3})
    with pytest.raises(PcsgError):
        Reference(g, max_primitives=20)


# ---- single transformed primitives ---------------------------------------------------------

def test_moved_and_scaled_sphere():
    r = ref("paint(0.1, 0.2, 0.3) move(1, 2, 3) uscale(2) sphere")
    rng = np.random.default_rng(0)
    o, d = rays_at(rng, 300, (1, 2, 3), spread=2.5, dist=8)
    res = r.trace(o, d)
    c = np.array([1.0, 2, 3])
    for k in range(len(o)):
        iv = sphere_interval(o[k], d[k], c, 2.0)
        assert res["hit"][k] == (iv is not None)
        if iv is None:
            assert res["t"][k] == np.inf and res["primitive"][k] == ""
            assert res["material"][k] == -1 and np.all(np.isnan(res["paint"][k]))
            continue
        assert res["t"][k] == pytest.approx(iv[0], abs=1e-9)
        p = o[k] + iv[0] * d[k]
        np.testing.assert_allclose(res["normal"][k], (p - c) / 2, atol=1e-7)
        np.testing.assert_allclose(res["paint"][k], [0.1, 0.2, 0.3])
        assert res["primitive"][k] == "sphere"
    assert res["hit"].sum() > 100


def test_ellipsoid_normal_is_the_gradient():
    """scale(2, 1, 0.5) sphere: x^2/4 + y^2 + 4 z^2 = 1; normal ~ (x/4, y, 4 z)."""
    r = ref("move(0.5, 0, 0) scale(2, 1, 0.5) sphere")
    rng = np.random.default_rng(1)
    o, d = rays_at(rng, 200, (0.5, 0, 0), spread=1.0)
    res = r.trace(o, d)
    assert res["hit"].sum() > 100
    for k in np.flatnonzero(res["hit"]):
        p = o[k] + res["t"][k] * d[k] - [0.5, 0, 0]
        assert p[0] ** 2 / 4 + p[1] ** 2 + 4 * p[2] ** 2 == pytest.approx(1.0, abs=1e-9)
        grad = np.array([p[0] / 4, p[1], 4 * p[2]])
        np.testing.assert_allclose(res["normal"][k], grad / np.linalg.norm(grad), atol=1e-7)
        assert np.dot(res["normal"][k], d[k]) <= 1e-12


@pytest.mark.parametrize("transform", ["scale(-1, 1, 1)", "mirror(1, 0, 0)", "mirror(1, 1, 0)",
                                       "mirror(0.3, -1, 2) rotz(30)", "flipxz"])
def test_mirrored_solids_have_outward_normals(transform):
    r = ref(f"{transform} move(0.2, 0.1, 0) rotx(20) cone")
    g = r.leaves[0]
    inv = np.linalg.inv(g.matrix)

    def inside(p):                                # the cone, tested in its own frame
        q = p @ inv[:3, :3].T + inv[:3, 3]
        return (q[..., 2] >= 0) & (q[..., 2] <= 1) & \
            (np.hypot(q[..., 0], q[..., 1]) <= 1 - q[..., 2])

    rng = np.random.default_rng(2)
    o, d = rays_at(rng, 300, g.matrix[:3, 3], spread=1.0)
    res = r.trace(o, d)
    assert res["hit"].sum() > 100
    for k in np.flatnonzero(res["hit"]):
        p = o[k] + res["t"][k] * d[k]
        n = res["normal"][k]
        assert np.linalg.norm(n) == pytest.approx(1.0)
        assert not inside(p + 1e-6 * n)
        assert np.dot(n, d[k]) <= 1e-12             # entering: the outward normal faces the ray
        if np.dot(n, d[k]) < -0.1:
            assert inside(p + 1e-6 * d[k])          # and the ray goes in


def test_mirrored_sphere_analytic():
    r = ref("scale(-1, 1, 1) move(0.5, 0, 0) sphere")   # the unit sphere at (-0.5, 0, 0)
    rng = np.random.default_rng(3)
    o, d = rays_at(rng, 200, (-0.5, 0, 0), spread=1.2)
    res = r.trace(o, d)
    c = np.array([-0.5, 0, 0])
    for k in range(len(o)):
        iv = sphere_interval(o[k], d[k], c, 1.0)
        assert res["hit"][k] == (iv is not None)
        if iv is not None:
            assert res["t"][k] == pytest.approx(iv[0], abs=1e-9)
            np.testing.assert_allclose(res["normal"][k], o[k] + iv[0] * d[k] - c, atol=1e-7)


def test_singular_transform_is_empty():
    r = ref("scale(0, 1, 1) sphere ∪ move(5, 0, 0) sphere")
    res = r.trace([[-3, 0, 0], [5, 0, 3]], [[1, 0, 0], [0, 0, -1]])
    assert list(res["hit"]) == [True, True]
    assert res["t"][0] == pytest.approx(7.0)            # passes the empty one, hits the other
    assert res["t"][1] == pytest.approx(2.0)


# ---- CSG of two spheres vs analytic --------------------------------------------------------

A, B = np.array([0.0, 0, 0]), np.array([1.0, 0, 0])
TWO = "paint(1, 0, 0) sphere {op} paint(0, 0, 1) move(1, 0, 0) sphere"


def expected_two(op, o, d):
    """(t, normal, paint) of the first hit, by the interval logic of two spheres."""
    a = sphere_interval(o, d, A, 1.0)
    b = sphere_interval(o, d, B, 1.0)
    red, blue = (1, 0, 0), (0, 0, 1)

    def on(c, t, sign=1.0):
        return sign * (o + t * d - c)

    if op == "∪":
        cands = [(x[0], on(c, x[0]), p) for x, c, p in ((a, A, red), (b, B, blue)) if x]
        return min(cands, key=lambda z: z[0]) if cands else None
    if op == "∩":
        if not a or not b or max(a[0], b[0]) >= min(a[1], b[1]):
            return None
        return (a[0], on(A, a[0]), red) if a[0] >= b[0] else (b[0], on(B, b[0]), blue)
    assert op == "\\"
    if not a:
        return None
    if not b or a[0] < b[0] or a[0] > b[1]:
        return a[0], on(A, a[0]), red
    if b[1] < a[1]:
        return b[1], on(B, b[1], -1.0), blue          # the inside of B, exposed
    return None


@pytest.mark.parametrize("op", ["∪", "∩", "\\"])
def test_two_spheres(op):
    r = ref(TWO.format(op=op))
    rng = np.random.default_rng(4)
    o, d = rays_at(rng, 400, (0.5, 0, 0), spread=1.3)
    res = r.trace(o, d)
    for k in range(len(o)):
        e = expected_two(op, o[k], d[k])
        assert res["hit"][k] == (e is not None), k
        if e is None:
            continue
        t, n, paint = e
        assert res["t"][k] == pytest.approx(t, abs=1e-9)
        np.testing.assert_allclose(res["normal"][k], n, atol=1e-7)
        np.testing.assert_allclose(res["paint"][k], paint)
    assert 50 < res["hit"].sum() < 400


def test_difference_chain_is_n_ary():
    """A \\ B \\ C = A minus both: a ray along x through the chain."""
    r = ref("scale(3, 1, 1) cube \\ move(-1, 0, 0) uscale(0.5) cube \\ move(1, 0, 0) uscale(0.5) cube")
    res = r.trace([[-5, 0, 0], [-5, 0.9, 0], [0, 0, 5]], [[1, 0, 0], [1, 0, 0], [0, 0, -1]])
    assert list(res["hit"]) == [True, True, True]
    assert res["t"][0] == pytest.approx(2.0)        # the outer face at x = -3
    assert res["t"][2] == pytest.approx(4.0)        # between the two holes
    r2 = ref("move(-1, 0, 0) uscale(0.5) cube \\ scale(3, 1, 1) cube")
    assert not r2.trace([[-5, 0, 0]], [[1, 0, 0]])["hit"][0]


@pytest.mark.parametrize("solid", ["sphere", "cube", "cone", "move(1,2,3) rotx(33) scale(1,2,3) tetrahedron",
                                   "(sphere ∪ move(0.5,0,0) cube)"])
def test_a_minus_a_is_empty(solid):
    r = ref(f"{solid} \\ {solid}")
    rng = np.random.default_rng(5)
    o, d = rays_at(rng, 300, spread=1.5)
    assert not r.trace(o, d)["hit"].any()
    assert ref(solid).trace(o, d)["hit"].any()


def test_union_is_commutative_on_hits():
    a = "paint(1, 0, 0) rotz(20) cube"
    b = "paint(0, 1, 0) move(0.7, 0.3, 0.2) uscale(0.8) sphere"
    c = "paint(0, 0, 1) move(-0.5, 0, 0.4) cylinder"
    rng = np.random.default_rng(6)
    o, d = rays_at(rng, 400, spread=1.6)
    results = [ref(" ∪ ".join(order)).trace(o, d) for order in ((a, b, c), (c, b, a), (b, a, c))]
    for res in results[1:]:
        np.testing.assert_array_equal(res["hit"], results[0]["hit"])
        h = res["hit"]
        np.testing.assert_allclose(res["t"][h], results[0]["t"][h], atol=1e-12)
        np.testing.assert_allclose(res["normal"][h], results[0]["normal"][h], atol=1e-9)
        np.testing.assert_array_equal(res["paint"][h], results[0]["paint"][h])
    assert results[0]["hit"].sum() > 100


def test_origin_inside_a_solid_sees_past_it():
    r = ref("sphere ∪ move(5, 0, 0) sphere")
    res = r.trace([[0, 0, 0]], [[1, 0, 0]])
    assert res["hit"][0] and res["t"][0] == pytest.approx(4.0)
    res = r.trace([[-3, 0, 0]], [[1, 0, 0]], tmin=0.0, tmax=1.5)
    assert not res["hit"][0]
    res = r.trace([[-3, 0, 0]], [[1, 0, 0]], tmax=2.5)
    assert res["hit"][0] and res["t"][0] == pytest.approx(2.0)
    # exits=True: a ray from inside reports where it leaves, with the outward normal
    res = r.trace([[0, 0, 0], [0, 0, 0], [-3, 0, 0]], [[1, 0, 0], [0, 0, -1], [1, 0, 0]],
                  exits=True)
    np.testing.assert_allclose(res["t"], [1.0, 1.0, 2.0])
    np.testing.assert_allclose(res["normal"], [[1, 0, 0], [0, 0, -1], [-1, 0, 0]], atol=1e-12)
    assert not r.trace([[0, 0, 0]], [[1, 0, 0]], tmax=0.5, exits=True)["hit"][0]
    # from inside a difference's cavity wall: the exit is the cavity's (flipped) surface
    r2 = ref("cube \\ uscale(0.5) cube")
    res = r2.trace([[0, 0, 0.75]], [[0, 0, -1]], exits=True)
    assert res["t"][0] == pytest.approx(0.25)
    np.testing.assert_allclose(res["normal"][0], [0, 0, -1], atol=1e-12)


def test_flat_triangles_face_the_ray():
    r = ref("paint(0, 1, 0) rotx(10) tri1 ∪ move(1, 1, 0) tri2")
    res = r.trace([[0.2, 0.2, 3], [0.2, 0.2, -3], [0.8, 0.8, 2], [5, 5, 1]],
                  [[0, 0, -1], [0, 0, 1], [0, 0, -1], [0, 0, -1]])
    assert list(res["hit"]) == [True, True, True, False]
    assert res["normal"][0][2] > 0 and res["normal"][1][2] < 0
    np.testing.assert_allclose(res["normal"][2], [0, 0, 1])
    np.testing.assert_allclose(res["paint"][0], [0, 1, 0])
    assert np.all(np.isnan(res["paint"][2])) and res["primitive"][2] == "tri2"


def test_material_index():
    r = ref("material(b) sphere ∪ material(a) move(3, 0, 0) sphere ∪ move(6, 0, 0) sphere\n"
            "#material a color=(1, 0, 0)\n#material b color=(0, 1, 0)")
    names = r.graph.material_names
    res = r.trace([[0, 0, 5], [3, 0, 5], [6, 0, 5]], [[0, 0, -1]] * 3)
    assert [names[m] if m >= 0 else None for m in res["material"]] == ["b", "a", None]


def test_unnormalised_directions_scale_t():
    r = ref("move(1, 2, 3) sphere")
    res1 = r.trace([[1, 2, 10]], [[0, 0, -1]])
    res2 = r.trace([[1, 2, 10]], [[0, 0, -4]])
    assert res2["t"][0] == pytest.approx(res1["t"][0] / 4)
    np.testing.assert_allclose(res1["normal"], res2["normal"])


# ---- the Sierpinski sample at order 1 ----------------------------------------------------------

TETRA = np.array([[1, 1, 1], [-1, -1, 1], [1, -1, -1], [-1, 1, -1]], dtype=float)
# barycentric coordinates in each half-size copy (the copy at corner c has the
# corners (v + c) / 2): lambda = INV @ (p, 1)
COPIES = [np.linalg.inv(np.vstack([(0.5 * TETRA + 0.5 * c).T, np.ones(4)])) for c in TETRA]


def sierpinski_inside(p, tol=0.0):
    """Point-in-solid for order 1, written from the corners: four half-size
    tetrahedra, one at each corner, and the ground z <= -1. Returns 0 (outside),
    1 (tetrahedron) or 2 (ground)."""
    p = np.atleast_2d(p)
    q = np.concatenate([p, np.ones((len(p), 1))], axis=1)
    res = np.zeros(len(p), dtype=int)
    res[p[:, 2] <= -1 + tol] = 2
    for inv in COPIES:
        res[np.all(q @ inv.T >= -tol, axis=1)] = 1
    return res


def test_sierpinski_order_1():
    g = compile_file(GRAMMARS / "sierpinski.pcsg", {"c": 1})
    r = Reference(g)
    assert sorted(l.name for l in r.leaves) == ["plane"] + ["tetrahedron"] * 4
    eye = np.array([3.2, -4.2, 2.6])
    at = np.array([0.0, 0.0, -0.3])
    fw = (at - eye) / np.linalg.norm(at - eye)
    right = np.cross(fw, [0, 0, 1])
    right /= np.linalg.norm(right)
    up = np.cross(right, fw)
    d = np.array([fw + x * right + y * up for y in np.linspace(-0.3, 0.75, 50)
                  for x in np.linspace(-0.3, 0.3, 36)])
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.tile(eye, (len(d), 1))
    res = r.trace(o, d)

    # independent: the first sample inside a tetrahedron along the part of the
    # ray in the box [-1, 1]^3, and the ground analytically. A ray may graze a
    # thin sliver between samples, so the reference may hit a tetrahedron before
    # the first sample inside, never after; its hit point must be on the solid.
    tetra_hits = 0
    for k in range(len(d)):
        with np.errstate(divide="ignore"):
            a = (-1.0 - o[k]) / d[k]
            b = (1.0 - o[k]) / d[k]
        t_box0, t_box1 = np.max(np.minimum(a, b)), np.min(np.maximum(a, b))
        t_ground = (-1.0 - o[k, 2]) / d[k, 2] if d[k, 2] < 0 else np.inf
        first = np.inf
        if t_box0 < t_box1:
            ts = np.linspace(t_box0, t_box1, 1500)
            inside = sierpinski_inside(o[k] + ts[:, None] * d[k]) == 1
            if inside.any():
                first = ts[np.argmax(inside)]
        expect = min(first, t_ground)
        if not res["hit"][k]:
            assert expect == np.inf
            continue
        assert res["t"][k] <= expect + 1e-9
        if first < t_ground:
            assert res["primitive"][k] == "tetrahedron"
        p = o[k] + res["t"][k] * d[k]
        kind = sierpinski_inside(p, tol=1e-9)[0]
        assert kind != 0                               # the hit point is on the solid
        n = res["normal"][k]
        assert np.dot(n, d[k]) < 0
        assert sierpinski_inside(p + 1e-6 * n)[0] == 0
        if res["primitive"][k] == "plane":
            assert res["t"][k] == pytest.approx(t_ground, rel=1e-12)
            np.testing.assert_allclose(res["paint"][k], [0.55, 0.58, 0.55])
            np.testing.assert_allclose(n, [0, 0, 1], atol=1e-12)
        else:
            assert res["primitive"][k] == "tetrahedron" and kind == 1
            assert res["t"][k] < t_ground
            np.testing.assert_allclose(res["paint"][k], [0.86, 0.62, 0.36])
            tetra_hits += 1
    assert tetra_hits > 150
    assert (res["primitive"] == "plane").sum() > 500
    assert (~res["hit"]).sum() > 200


def test_trace_polls_its_caller_within_a_chunk():
    """--timeout stops a reference render: its per-ray walk is Python's, and a chunk of
    4096 rays over the Sierpinski tetrahedron at 6 took minutes between two checks."""
    r = ref("{c = 2} S\nS if(c > 0, 2, 1)\n1: S → tetrahedron\n"
            "2: S → {c = c - 1} (uscale(0.5) S ∪ move(1, 0, 0) uscale(0.5) S)\n")
    o, d = rays_at(np.random.default_rng(3), 1000)
    calls = []

    def poll():
        calls.append(1)
        if len(calls) == 3:
            raise TimeoutError

    with pytest.raises(TimeoutError):
        r.trace(o, d, poll=poll)
    assert len(calls) == 3          # stopped at the third poll, 128 rays in: one chunk
    full = []
    r.trace(o, d, poll=lambda: full.append(1))
    assert len(full) == 1000 // 64 + 1
