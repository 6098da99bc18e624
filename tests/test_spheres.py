"""Bounding spheres of graftals (graph/spheres.py) and Bekaert & Willems' choice between
a box and a sphere by average projected area (graph/volumes.py)."""
import math

import numpy as np
import pytest

import pcsg
from pcsg.compiler import compile_file, compile_text
from pcsg.graph.bounds import bound
from pcsg.graph.spheres import enclose, geodesic, node_spheres
from pcsg.graph.volumes import bounding_volumes
from pcsg.trace.reference import Reference
from pcsg.trace.transforms import matrix

from .conftest import GRAMMARS
from .oracle import camera_rays
from .test_graftals import chaos_game

# Six half-size copies of a ball on the axes, the whole turned: the attractor is round
# and twisted, so its box is poor and the unit ball holds it (each copy's ball lies in
# it): the sphere must win.
TURN = "rotz(30) roty(20)"
OCTA_MAPS = [(x, y, z) for x, y, z in [(0.5, 0, 0), (-0.5, 0, 0), (0, 0.5, 0), (0, -0.5, 0),
                                       (0, 0, 0.5), (0, 0, -0.5)]]
OCTA_RULE = f"{TURN} (" + " ∪ ".join(f"move({x}, {y}, {z}) uscale(0.5) O"
                                      for x, y, z in OCTA_MAPS) + ")"
OCTA = f"O\nO 1\n1: O → {OCTA_RULE}\n"


def _m(name, *args):
    return matrix(name, list(args))


def _octa_maps():
    turn = _m("rotz", 30) @ _m("roty", 20)
    return [turn @ _m("move", *v) @ _m("uscale", 0.5) for v in OCTA_MAPS]


def _words(maps, n, rng, length, start):
    """n points start(point) mapped by random words of `maps` of 0..length maps."""
    out = np.empty((n, 3))
    for p in range(n):
        m = np.eye(4)
        for k in rng.integers(len(maps), size=rng.integers(length + 1)):
            m = m @ maps[k]
        x = start(rng)
        out[p] = m[:3, :3] @ x + m[:3, 3]
    return out


def _inside(points, sphere, rel=1e-9):
    d = np.linalg.norm(points - sphere[:3], axis=1)
    return d <= sphere[3] * (1 + rel)


def _choice(volumes, name):
    return next(c for c in volumes.choices if c.name == name)


@pytest.fixture(scope="module")
def fern():
    return bounding_volumes(compile_file(GRAMMARS / "barnsley_fern.pcsg", {}))


@pytest.mark.parametrize("module", ["FERN", "PINNA", "LOBE"])
def test_the_fern_spheres_hold_their_attractors(fern, module):
    sphere = _choice(fern, module).sphere
    rng = np.random.default_rng(3)
    pts = np.concatenate([chaos_game(500, rng, p, start=module) for p in (0.3, 0.6, 0.95)])
    assert _inside(pts, sphere).all()
    # and it is no loose ball: the attractor comes within 5 % of its surface
    assert np.linalg.norm(pts - sphere[:3], axis=1).max() > 0.95 * sphere[3]


def test_the_temple_sphere_holds_the_hall_and_all_its_copies():
    volumes = bounding_volumes(compile_file(GRAMMARS / "cifs_temple.pcsg", {}))
    sphere = _choice(volumes, "TEMPLE").sphere
    maps = [_m("move", x, y, 1.1) @ _m("uscale", 0.42) for x in (0.6, -0.6) for y in (0.6, -0.6)]
    # the hall's solids: plinth, columns, architrave, roof steps (cube/cylinder frames)
    col = _m("move", 0, 0, 0.1) @ _m("scale", 0.11, 0.11, 0.9)
    solids = [(_m("move", 0, 0, 0.05) @ _m("scale", 1, 1, 0.05), "cube"),
              *[(_m("move", x, y, 0) @ col, "cylinder") for x in (0.8, -0.8) for y in (0.8, -0.8)],
              (_m("move", 0, 0, 1.05) @ _m("scale", 0.95, 0.95, 0.05), "cube"),
              (_m("move", 0, 0, 1.15) @ _m("scale", 0.6, 0.6, 0.05), "cube"),
              (_m("move", 0, 0, 1.25) @ _m("scale", 0.35, 0.35, 0.05), "cube")]

    def on_the_hall(rng):           # a point on a solid's rim or corner: its far points
        m, kind = solids[rng.integers(len(solids))]
        if kind == "cube":
            p = rng.choice([-1.0, 1.0], size=3)
        else:
            a = rng.uniform(0, 2 * math.pi)
            p = np.array([math.cos(a), math.sin(a), rng.integers(2)])
        return m[:3, :3] @ p + m[:3, 3]

    pts = _words(maps, 4000, np.random.default_rng(4), 12, on_the_hall)
    assert _inside(pts, sphere).all()
    assert np.linalg.norm(pts - sphere[:3], axis=1).max() > 0.97 * sphere[3]


def test_the_tree_sphere_holds_branches_and_leaves():
    """The tree ends (its leaves), so the tracer keeps its box; its sphere, from the same
    walk, still has to hold every branch and leaf down to n = 40."""
    graph = compile_file(GRAMMARS / "graftal_tree.pcsg", {})
    spheres, _ = node_spheres(graph, bound(graph)[4])
    sphere = spheres[graph.modules["TREE"]]
    maps = [_m("move", 0, 0, 1) @ _m("rotz", 137) @ _m("roty", 12) @ _m("uscale", 0.66),
            _m("move", 0, 0, 0.82) @ _m("roty", 48) @ _m("uscale", 0.52),
            _m("move", 0, 0, 0.6) @ _m("rotz", 180) @ _m("roty", 42) @ _m("uscale", 0.48)]
    rng = np.random.default_rng(5)
    pts = []
    for _ in range(3000):
        depth = rng.integers(41)
        m = np.eye(4)
        for k in rng.integers(3, size=depth):
            m = m @ maps[k]
        a = rng.uniform(0, 2 * math.pi)
        if depth == 40:         # a leaf clump
            u = rng.normal(size=3)
            p = np.array([0, 0, 0.9]) + np.array([0.75, 0.75, 0.9]) * u / np.linalg.norm(u)
        else:                   # the branch's rim
            p = np.array([0.07 * math.cos(a), 0.07 * math.sin(a), rng.uniform()])
        pts.append(m[:3, :3] @ p + m[:3, 3])
    assert _inside(np.array(pts), sphere).all()


@pytest.fixture(scope="module")
def octa():
    return pcsg.loads(OCTA)


def test_a_round_attractor_is_bounded_by_a_sphere(octa):
    node = octa.graph.modules["O"]
    [c] = octa.volume_choices
    assert c.node == node and c.volume == "sphere" and c.nested
    # the areas are B & W's criterion: a box's surface over 4, a sphere's pi r^2
    a, b, h = c.box[3:] - c.box[:3]
    assert c.box_area == pytest.approx(2 * (a * b + b * h + h * a) / 4, rel=1e-12)
    assert c.sphere_area == pytest.approx(math.pi * c.sphere[3] ** 2, rel=1e-12)
    assert c.sphere_area < 0.5 * c.box_area
    # the ball of radius 1 about the centre is invariant; rounds converge onto it
    assert np.allclose(c.sphere[:3], 0, atol=1e-6) and 1 <= c.sphere[3] < 1 + 1e-5
    maps = _octa_maps()
    x0 = np.linalg.solve(np.eye(3) - maps[0][:3, :3], maps[0][:3, 3])   # on the attractor
    pts = _words(maps, 4000, np.random.default_rng(6), 40, lambda rng: x0)
    assert _inside(pts, c.sphere).all()
    # the tracer culls and hits by it (a hair wider); the node's box row is the sphere's
    assert np.array_equal(octa.spheres[node], c.sphere)
    assert c.sphere[3] < octa.flat.sphere[node, 3] < c.sphere[3] * (1 + 1e-8)
    ball_box = np.concatenate([c.sphere[:3] - c.sphere[3], c.sphere[:3] + c.sphere[3]])
    assert np.array_equal(octa.boxes[node], ball_box)


def test_every_graftal_takes_the_volume_with_the_smaller_average_projected_area(fern, octa):
    for c in [*fern.choices, *octa.volume_choices]:
        assert c.volume == ("sphere" if c.sphere_area < c.box_area else "box")
    for c in fern.choices:
        # where a sphere won, the tracer has it; elsewhere the box row is the hyper box
        has = fern.spheres is not None and fern.spheres[c.node, 3] >= 0
        assert has == (c.volume == "sphere")


def test_systems_without_graftals_have_no_spheres():
    for name in ("sierpinski", "graftal_tree", "sympodial_tree"):
        obj = pcsg.load(GRAMMARS / f"{name}.pcsg")
        assert obj.spheres is None and obj.volume_choices == []
        assert obj.flat.sphere.shape == (0, 4)


@pytest.mark.parametrize("average, axiom", [(False, "O"), (True, "O"),
                                           (False, "(O ∩ move(0.6, 0, 0) cube)")])
def test_the_tracer_hits_the_spheres_of_the_reference_expansion(average, axiom):
    """Cut at depth N, each instance of the round graftal is hit at its sphere: the same
    surface as the system expanded N levels with that sphere as its leaf, traced by the
    reference, ray by ray (the spheres nest, so no parent clips a child's); also as the
    operand of an intersection, whose interval lists take the sphere's ends."""
    depth = 3
    obj = pcsg.loads(axiom + OCTA[1:], max_depth=depth)
    traced = pcsg.Traced(obj.graph, max_depth=depth, average_normals=average)
    c, r = obj.spheres[obj.graph.modules["O"]][:3], obj.spheres[obj.graph.modules["O"]][3]
    leaf = f"move({float(c[0])!r}, {float(c[1])!r}, {float(c[2])!r}) uscale({float(r)!r}) sphere"
    expanded = pcsg.loads(f"{{n = {depth}}} {axiom}\nO if(n > 0, 2, 1)\n1: O → {leaf}\n"
                          f"2: O → {{n = n - 1}} ({OCTA_RULE})\n")
    o, d = camera_rays(np.array([-1, -1, -1, 1, 1, 1.0]), 40, (1, -1.3, 0.8), spread=0.3)
    got = traced.trace(o, d)
    ref = Reference(expanded.graph).trace(o, d)
    assert np.array_equal(got.hit, ref["hit"]) and got.hit.sum() > 100
    both = got.hit
    assert np.abs(got.t[both] - ref["t"][both]).max() <= 1e-6 * np.abs(ref["t"][both]).max()
    assert "depth limit" in " ".join(traced.describe_events(got.events))
    turn = np.sum(got.normal[both] * ref["normal"][both], axis=1)
    if average:     # Hart & DeFanti: the coarser spheres' normals are folded in
        assert np.allclose(np.linalg.norm(got.normal[both], axis=1), 1.0)
        assert (turn < 1 - 1e-6).any() and (turn > 0).all()
    else:
        assert np.abs(got.normal[both] - ref["normal"][both]).max() <= 1e-6


def test_enclose_holds_every_ball_and_is_the_smallest_for_two():
    rng = np.random.default_rng(7)
    balls = np.hstack([rng.normal(size=(30, 3)), rng.uniform(0, 0.5, (30, 1))])
    b = enclose(balls)
    assert np.all(np.linalg.norm(balls[:, :3] - b[:3], axis=1) + balls[:, 3] <= b[3] * (1 + 1e-12))
    # no centre nearby does better
    near = b[:3] + rng.normal(size=(2000, 3)) * 1e-3
    worse = (np.linalg.norm(near[:, None] - balls[None, :, :3], axis=2) + balls[:, 3]).max(1)
    assert worse.min() >= b[3] * (1 - 1e-9)
    two = enclose(np.array([[0, 0, 0, 1.0], [4, 0, 0, 0.5]]))
    assert np.allclose(two, [1.75, 0, 0, 2.75])
    assert enclose(np.zeros((0, 4))) is None


def test_enclose_from_a_nearby_centre_at_any_scale_and_strided():
    """The compiled centre search (trace/enclose.py) from a warm start, on balls whose
    coordinates are near the square root of the largest double, and on balls that are a
    view into a bigger array."""
    rng = np.random.default_rng(11)
    balls = np.hstack([rng.normal(size=(40, 3)), rng.uniform(0, 0.3, (40, 1))])
    cold = enclose(balls)
    warm = enclose(balls, cold + np.array([1e-3, -2e-3, 1e-3, 0.0]))
    assert abs(warm[3] - cold[3]) <= 1e-9 * cold[3]
    huge = enclose(balls * 1e150)
    assert np.allclose(huge / 1e150, cold, rtol=1e-8, atol=1e-8)
    wide = np.zeros((40, 8))
    wide[:, ::2] = balls
    assert np.array_equal(enclose(wide[:, ::2]), cold)


def test_the_sphere_points_span_a_hull_that_holds_the_ball():
    """How a sphere enters the box walk: the hull of ball_points must hold the ball; its
    inradius is the smallest distance of a face, checked here against many directions."""
    GEODESIC, INRADIUS = geodesic()
    assert len(GEODESIC) == 42 and np.allclose(np.linalg.norm(GEODESIC, axis=1), 1)
    u = np.random.default_rng(8).normal(size=(20000, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    support = (u @ GEODESIC.T).max(axis=1)       # the hull's extent in each direction
    assert support.min() >= INRADIUS and support.min() < INRADIUS * 1.01
    assert 0.93 < INRADIUS < 0.94


def test_stats_shows_each_graftal_modules_volume(capsys, tmp_path):
    from pcsg.cli import main
    octa = tmp_path / "octa.pcsg"
    octa.write_text(OCTA)
    assert main(["stats", str(GRAMMARS / "cifs_temple.pcsg"), str(octa)]) == 0
    out = capsys.readouterr().out
    assert ("primitives   endless: a graftal, refined to pixel size when rendered (`pcsg "
            "export --max-depth N` writes it cut at depth N)") in out
    assert "bounds       TEMPLE: box 2.07 x 2.07 x 1.9, mean projected area 6.064 " \
           "(sphere of radius 1.724: 9.333)" in out
    assert "bounds       O: sphere of radius 1, mean projected area 3.142 (box " in out
    assert main(["stats", str(octa), "--json"]) == 0
    data = __import__("json").loads(capsys.readouterr().out)
    assert data["primitives"] is None and data["endless"]
    o = data["bounding_volumes"]["O"]
    assert o["volume"] == "sphere" and o["nested"] and o["sphere_area"] < o["box_area"]


@pytest.mark.parametrize("balls", [np.zeros((3, 4)), np.array([[1.0, 2.0, 3.0, 0.0]] * 5),
                                   np.array([[1.0, 2.0, 3.0, 0.5]] * 2)])
def test_enclosing_a_single_point_or_ball_ends(balls):
    """A hull that is one point made the sharpness loop run forever (found by the fuzz
    test through `pcsg stats`)."""
    ball = enclose(balls)
    assert np.allclose(ball[:3], balls[0, :3]) and ball[3] == balls[0, 3]
