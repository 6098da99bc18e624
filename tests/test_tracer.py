"""The cyclic-graph tracer agrees ray by ray with a brute-force trace of the fully
expanded primitive list (pcsg.trace.reference), and behaves on hostile systems."""
import itertools

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import pcsg
from pcsg.compiler import compile_text
from pcsg.graph import bounds
from pcsg.graph.bounds import hyper_boxes
from pcsg.graph.flatten import flatten
from pcsg.trace import boxwalk
from pcsg.trace.boxwalk import walk_boxes
from pcsg.trace.nodes import EV_DEPTH

from .conftest import GRAMMARS
from .oracle import assert_agrees, camera_rays

VIEWS = [(1.0, -1.3, 0.8), (-0.4, 0.3, 1.5), (0.2, -1.5, 0.15), (1.2, 0.9, -0.6)]


@pytest.mark.parametrize("name, overrides", [("sierpinski", {"c": 3}),
                                             ("sympodial_tree", {"cnt": 5}),
                                             ("carpenter_terrain", {"cnt": 3})])
@pytest.mark.parametrize("view", VIEWS)
def test_samples_agree_with_the_reference(name, overrides, view):
    obj = pcsg.load(GRAMMARS / f"{name}.pcsg", **overrides)
    # the samples' grounds and seas are infinite; aim at the finite part of the object
    bounds = _finite_bounds(obj)
    # the tree's reference walks its expansion in Python, 7 s a view at 40x40
    n = 28 if name == "sympodial_tree" else 40
    o, d = camera_rays(bounds, n, view, seed=hash(view) & 0xFFFF)
    o = _outside_half_spaces(obj, o)
    assert_agrees(obj, o, d, min_hits=50)


def _finite_bounds(obj):
    inst = flatten(obj.graph)
    pts = []
    for x in inst:
        if x.primitive == "plane":
            continue
        corners = np.array([[i, j, k, 1.0] for i in (-1, 1) for j in (-1, 1) for k in (0, 1)])
        pts.append((corners @ x.matrix.T)[:, :3])
    pts = np.concatenate(pts)
    return np.concatenate([pts.min(0), pts.max(0)])


def _outside_half_spaces(obj, origins):
    """Lift eyes above any ground or sea so that no ray starts inside a solid."""
    tops = [x.matrix[2, 3] for x in flatten(obj.graph) if x.primitive == "plane"]
    if tops:
        origins = origins.copy()
        origins[:, 2] = np.maximum(origins[:, 2], max(tops) + 0.05)
    return origins


def test_csg_operators_on_recursive_operands():
    # ∩ and \ whose operands are themselves cycles
    obj = pcsg.loads("""{n = 3} ((S ∩ move(0.3, 0.2, 0.1) S) \\ uscale(0.6) rotz(20) S)
S if(n > 0, 2, 1)
1: S → cube
2: S → {n = n - 1} (move(0.5,0.5,0) uscale(0.55) S ∪ move(-0.5,-0.4,0.1) uscale(0.5) S ∪
                     rotx(30) uscale(0.4) sphere)""")
    for view in VIEWS:
        o, d = camera_rays(obj.bounds, 40, view, spread=0.3)
        assert_agrees(obj, o, d, min_hits=40)


def test_normals_under_shear_mirror_and_non_uniform_scale():
    obj = pcsg.loads("mirror(1, 0.3, 0) zshear(0.4, -0.2) scale(2, 0.5, 1) rotz(30) "
                     "(sphere \\ move(0.5, 0, 0.5) uscale(0.7) cube)")
    for view in VIEWS:
        o, d = camera_rays(obj.bounds, 40, view)
        got = assert_agrees(obj, o, d, min_hits=10)
        assert np.allclose(np.linalg.norm(got.normal[got.hit], axis=1), 1.0)


def test_difference_exposes_the_inside_with_flipped_normals():
    obj = pcsg.loads("cube \\ move(0, 0, 1) uscale(0.5) sphere")
    h = obj.trace([[0.0, 0.0, 5.0]], [[0.0, 0.0, -1.0]])
    assert h.hit[0] and h.t[0] == pytest.approx(5.0 - 0.5)
    assert np.allclose(h.normal[0], [0, 0, 1])        # facing the ray: the cavity's floor


def test_a_minus_a_is_empty_and_union_commutes():
    assert not pcsg.loads("sphere \\ sphere").trace([[0, 0, 5.0]], [[0, 0, -1.0]]).hit[0]
    a = pcsg.loads("move(0.5,0,0) sphere ∪ cube")
    b = pcsg.loads("cube ∪ move(0.5,0,0) sphere")
    o, d = camera_rays(a.bounds, 30, (1, -1, 0.5))
    ha, hb = a.trace(o, d), b.trace(o, d)
    assert np.array_equal(ha.hit, hb.hit) and np.array_equal(ha.t, hb.t)


def test_rays_starting_inside_report_the_exit():
    h = pcsg.loads("sphere").trace([[0, 0, 0.0]], [[0, 0, 1.0]])
    assert h.hit[0] and h.t[0] == pytest.approx(1.0) and np.allclose(h.normal[0], [0, 0, 1])


@pytest.mark.parametrize("name, overrides", [("sympodial_tree", {"cnt": 6}),
                                             ("carpenter_terrain", {"cnt": 3})])
def test_hyper_boxes_contain_every_primitive(name, overrides, monkeypatch):
    """Both box walks are conservative. Where no map turns a box off its axes (the
    terrain), the memoised one (corner points carried through the transformations) is at
    least as tight as the per-instance box arithmetic; the tree's turns have that walk
    carry balls (trace/balls.py), which can bound tighter than 256 corner points."""
    # the small terrain memoises, though not a state repeats: keep the probe from giving up
    monkeypatch.setattr(bounds, "PROBE_STATES", bounds.MAX_STATES)
    monkeypatch.setattr(bounds, "PROBE_RANDOM", bounds.MAX_STATES)
    g = pcsg.load(GRAMMARS / f"{name}.pcsg", **overrides).graph
    boxes, how, _, _ = hyper_boxes(g)
    assert how == "memoised"
    walked, complete, _, depth = walk_boxes(g)
    assert complete and depth == 64
    # nodes that the walk reaches (a constant T-node folded into its parent's map is not)
    reached = walked[:, 0] <= walked[:, 3]
    assert reached[g.root] and reached.sum() > len(g.nodes) // 2
    tighter = np.all(boxes[reached, :3] >= walked[reached, :3] - 1e-12) and \
        np.all(boxes[reached, 3:] <= walked[reached, 3:] + 1e-12)
    assert tighter == (name == "carpenter_terrain")
    corners = np.array([[i, j, k, 1.0] for i in (-1, 1) for j in (-1, 1) for k in (0, 1)])
    for x, root in itertools.product(flatten(g), (boxes[g.root], walked[g.root])):
        if x.primitive == "plane":
            continue
        p = (corners @ x.matrix.T)[:, :3]
        if x.primitive in ("tri1", "tri2"):        # flat: the triangle, not a cube
            p = (np.array([[0, 0, 0, 1.0], [1, 0, 0, 1], [0, 1, 0, 1]]) *
                 (1 if x.primitive == "tri1" else -1))
            p[:, 3] = 1
            p = (p @ x.matrix.T)[:, :3]
        scale = 1 + np.abs(p)
        assert np.all(p >= root[:3] - 1e-12 * scale) and np.all(p <= root[3:] + 1e-12 * scale)


def test_rotation_cycle_boxes_do_not_grow_turn_after_turn():
    # the paper's Fig. 9: a cylinder rotated by 45° again and again
    obj = pcsg.loads("{n = 24} S\nS if(n > 0, 2, 1)\n1: S → cylinder\n"
                     "2: S → cylinder ∪ {n = n - 1} rotx(45) S")
    box = obj.bounds
    # the rim (y, z) = (±1, 1) lies √2 from the axis: that is the true extent, and boxes
    # transformed box by box would have grown to thousands (3283 before this was fixed)
    r = np.sqrt(2) + 1e-9
    assert np.allclose(box[[0, 3]], [-1, 1]) and np.all(np.abs(box[[1, 2, 4, 5]]) <= r)


def test_endless_system_renders_with_a_depth_notice():
    obj = pcsg.loads("S\n1: S → sphere ∪ move(1.5, 0, 0) uscale(0.5) S", max_depth=20)
    # the spheres shrink towards x = 3; this ray needs ~30 levels to get there
    h = obj.trace([[3 - 1e-9, 0, 5.0], [0.0, 0.0, 5.0]], [[0, 0, -1.0], [0, 0, -1.0]])
    assert h.hit.all()
    notes = obj.describe_events(h.events)
    assert any(n.startswith("depth limit") and "'S'" in n for n in notes), notes


def test_graftal_is_hit_at_its_box_below_the_pixel_footprint():
    # no primitive below the cycle: only the box can ever be hit (Bekaert & Willems)
    obj = pcsg.loads("{s = 0} S\n1: S → move(0.5,0,0) uscale(0.5) S ∪ move(-0.5,0,0) uscale(0.5) "
                     "S ∪ move(0,0.5,0) uscale(0.5) S ∪ {s = 1} sphere")
    h = obj.trace([[0.0, 0.0, 5.0]], [[0.0, 0.0, -1.0]], lod=0.01)
    assert h.hit[0]


def test_level_of_detail_finishes_small_instances_with_the_terminating_rule():
    obj = pcsg.load(GRAMMARS / "sierpinski.pcsg", c=12)
    o, d = camera_rays(np.array([-1, -1, -1, 1, 1, 1.0]), 30, (1, -1.3, 0.8))
    exact = obj.trace(o, d)
    lod = obj.trace(o, d, lod=0.03)
    assert any("level of detail" in n for n in obj.describe_events(lod.events))
    # coverage stays (the tetrahedron is the hull of its refinement) and depth moves little
    assert np.array_equal(exact.hit, lod.hit) or (exact.hit != lod.hit).mean() < 0.02


def test_runtime_errors_make_instances_empty_and_are_counted():
    obj = pcsg.loads("{c = 3} S ∪ move(3,0,0) scale(0, 1, 1) sphere\nS c\n1: S → sphere\n"
                     "2: S → cube")
    h = obj.trace([[0, 0, 5.0], [3, 0, 5.0]], [[0, 0, -1.0], [0, 0, -1.0]])
    assert not h.hit.any()
    # both are met while bounding, before any ray: said once, the selection with values
    assert sorted(w.message for w in obj.warnings) == [
        "the selection of module 'S' gives 3, which names rule 3, but 'S' has rules 1..2 "
        "(with c = 3); that instance is empty",
        # constant arguments: every instance, as check says it
        "this transformation is singular (a zero scale) or too large to invert: it empties "
        "its operand"]


# ---- random systems --------------------------------------------------------------

SOLIDS = ["sphere", "cube", "cylinder", "cone", "tetrahedron"]


@st.composite
def csg(draw, depth, recursive):
    choice = draw(st.integers(0, 9 if depth > 0 else 2))
    if choice <= 1 or depth == 0:
        return draw(st.sampled_from(SOLIDS))
    if choice == 2 and recursive:
        f = draw(st.floats(0.3, 0.6))
        x, y, z = (draw(st.floats(-0.6, 0.6)) for _ in range(3))
        return f"move({x:.3f}, {y:.3f}, {z:.3f}) uscale({f:.3f}) S"
    if choice <= 5:
        op = draw(st.sampled_from(["∪", "∩", "\\"]))
        return f"({draw(csg(depth - 1, recursive))} {op} {draw(csg(depth - 1, recursive))})"
    t = draw(st.sampled_from(["move", "scale", "rotx", "rot", "zshear", "xshear", "flipxy",
                              "mirror", "paint", "calc"]))
    inner = draw(csg(depth - 1, recursive))
    num = lambda lo, hi: f"{draw(st.floats(lo, hi)):.3f}"
    head = {
        "move": lambda: f"move({num(-1, 1)}, {num(-1, 1)}, {num(-1, 1)})",
        "scale": lambda: f"scale({num(0.3, 1.5)}, {num(0.3, 1.5)}, {num(0.3, 1.5)})",
        "rotx": lambda: f"rotx({num(-180, 180)})",
        "rot": lambda: f"rot({num(-180, 180)}, {num(-1, 1)}, {num(0.1, 1)}, {num(-1, 1)})",
        "zshear": lambda: f"zshear({num(-0.5, 0.5)}, {num(-0.5, 0.5)})",
        "xshear": lambda: f"xshear({num(-0.5, 0.5)}, {num(-0.5, 0.5)})",
        "flipxy": lambda: "flipxy",
        "mirror": lambda: f"mirror({num(-1, 1)}, {num(0.1, 1)}, {num(-1, 1)})",
        "paint": lambda: f"paint({num(0, 1)}, {num(0, 1)}, n / 4)",
        "calc": lambda: f"{{k = k + {num(-1, 1)}}} move(0, 0, k * 0.1)",
    }[t]()
    return f"{head} {inner}"


@st.composite
def random_system(draw):
    order = draw(st.integers(0, 2))
    return (f"{{n = {order}; k = 0}} S\nS if(n > 0, 2, 1)\n"
            f"1: S → {draw(csg(2, False))}\n"
            f"2: S → {{n = n - 1}} ({draw(csg(3, True))} ∪ move(0.2, 0.1, 0) uscale(0.5) S)\n")


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(random_system(), st.sampled_from(VIEWS))
def test_random_systems_agree_with_the_reference(text, view):
    obj = pcsg.loads(text)
    o, d = camera_rays(obj.bounds, 16, view, seed=7)
    assert_agrees(obj, o, d, min_hits=0)


def test_too_many_instances_to_bound_stop_refining_where_the_bounds_stop(monkeypatch):
    """Past the visit budget the boxes hold the instances down to the deepest depth that
    fits, and the tracer finishes deeper instances with their terminating rule, as
    --max-depth would; it says so. The terrain's calculations read cnt only in its
    selections, so the order-7 terrain stopped at depth d is the order-(d-1) terrain:
    ray by ray what the reference of that order sees."""
    monkeypatch.setattr(bounds, "MAX_STATES", 0)
    # a budget that stops at depth 5, so that the reference derives the order-4 terrain
    obj = pcsg.load(GRAMMARS / "carpenter_terrain.pcsg", cnt=7, bounds_budget=10_000)
    assert obj.bounds_method == "every instance"
    assert 3 <= obj.max_depth <= 7 and obj.asked_depth == 64     # it ends at depth 9
    warned = [w for w in obj.warnings if w.code == "depth-bounded"]
    assert len(warned) == 1 and f"max_depth={obj.max_depth}:" in warned[0].message
    assert "bounds_budget=10,000 node visits" in warned[0].message
    same = pcsg.load(GRAMMARS / "carpenter_terrain.pcsg", cnt=obj.max_depth - 1)
    assert same.max_depth == 64 and not [w for w in same.warnings if w.code == "depth-bounded"]
    # every view's rays in one reference trace, whose cost is mostly per primitive
    o, d = _rays_of_every_view(_finite_bounds(same), 16, seed=5)
    got = assert_agrees(obj, _outside_half_spaces(obj, o), d, min_hits=200,
                        reference_graph=same.graph)
    assert got.events[EV_DEPTH].sum() > 0
    line = [x for x in obj.describe_events(obj.events) if x.startswith("depth limit")][0]
    assert f"instances at depth {obj.max_depth}, where the bounds stop" in line


def test_a_system_that_ends_within_the_budget_is_not_cut(monkeypatch):
    """The walks deepen until the depth bound changes no instance: the order-4 terrain
    ends at depth 5 (its last instances select the terminating rule themselves), and
    its boxes are those of one walk to the full depth, with no warning."""
    monkeypatch.setattr(bounds, "MAX_STATES", 0)
    g = pcsg.load(GRAMMARS / "carpenter_terrain.pcsg", cnt=4).graph
    assert boxwalk.FIRST_DEPTH < 5                      # so the walks are stepped
    stepped, complete, _, depth = walk_boxes(g, budget=400_000)
    assert complete and depth == 64
    monkeypatch.setattr(boxwalk, "FIRST_DEPTH", 64)     # one walk, to the full depth
    whole, complete, _, depth = walk_boxes(g, budget=400_000)
    assert complete and depth == 64
    assert np.array_equal(stepped, whole)
    # too small a budget for even the first walk: the deepest depth below it that fits,
    # depth 0 whatever the budget (it was no box at all: every ray walked every instance)
    shallow, complete, _, depth = walk_boxes(g, budget=10)
    assert complete and depth == 0 and np.isfinite(shallow[g.modules["MNT"]]).all()
    cut, complete, _, depth = walk_boxes(g, budget=400)
    assert complete and 0 < depth < 5 and np.isfinite(cut[g.modules["MNT"]]).all()


def test_a_graftal_that_cannot_fit_is_left_unbounded_without_walking_to_the_bound(monkeypatch):
    """A graftal's boxes come from a walk to the depth bound or from none. When the walks
    to depths 4 and 5 show that the bound will not fit, no walk goes there: this one
    doubles at every level and never contracts, and a walk to depth 30 would spend the
    whole budget before giving up (depth 24, with a smaller budget, once took 15 s). With
    a bound that fits it is walked there and bounded."""
    g = compile_text("{ n = 1 } S\nS 1\n1: S → sphere ∪ move(3, 0, 0) S ∪ move(0, 3, 0) S")
    walked = []
    real = boxwalk._walk_to

    def recording(flat, empty, depth, max_depth, budget, instances, *watch):
        walked.append(depth)
        return real(flat, empty, depth, max_depth, budget, instances, *watch)

    monkeypatch.setattr(boxwalk, "_walk_to", recording)
    space, complete, _, depth = walk_boxes(g, max_depth=30)
    assert walked == [4, 5] and not complete and depth == 30 and np.all(np.isinf(space))
    walked.clear()
    boxes, complete, _, depth = walk_boxes(g, max_depth=8)
    assert walked == [4, 5, 8] and complete and depth == 8
    # the spheres of levels 1 to 8: unit spheres moved by 3 in x or y up to 7 times
    assert np.array_equal(boxes[g.root], [-1, -1, -1, 22, 22, 1])


def table_entries(table):
    keys, used, vals = table
    return {int(keys[i]): (int(used[i]), tuple(vals[i])) for i in np.flatnonzero(used)}


def test_a_deeper_walk_over_budget_falls_back_to_the_last_walks_table(monkeypatch):
    """While a deeper walk runs, the last walk's table (the list of its entries) is kept;
    when the deeper walk goes over budget, that table is the result: the same entries as
    a walk to that depth makes."""
    monkeypatch.setattr(bounds, "MAX_STATES", 0)
    g = pcsg.load(GRAMMARS / "carpenter_terrain.pcsg", cnt=6).graph
    real = boxwalk._walk_to

    def over_budget_below_5(flat, empty, depth, max_depth, budget, instances, *watch):
        if depth > 5:
            return (empty.copy(), -1, boxwalk.new_counts(1)[0],
                    boxwalk.empty_table(boxwalk.TABLE_SLOTS))
        return real(flat, empty, depth, max_depth, budget, instances, *watch)

    monkeypatch.setattr(boxwalk, "_walk_to", over_budget_below_5)
    boxes, complete, table, depth = walk_boxes(g, instances=True)
    assert complete and depth == 5
    monkeypatch.setattr(boxwalk, "FIRST_DEPTH", 5)      # one walk, straight to depth 5
    direct, complete, direct_table, depth = walk_boxes(g, max_depth=5, instances=True)
    assert complete and depth == 5
    assert np.array_equal(boxes, direct)
    got = table_entries(table)
    # levels 0 to 4: a walk to depth 5 ends at level 6, and the table keeps a level only
    # where there are instances two levels below it (instance_table.levels_kept)
    assert len(got) == 2 + 3 + 10 + 40 + 160 and got == table_entries(direct_table)


@pytest.mark.parametrize("name, params, n", [("carpenter_terrain", {"cnt": 4}, 24),
                                             # fewer rays: the reference walks its expansion
                                             ("sympodial_tree", {"cnt": 6}, 16)])
def test_instance_box_table_agrees_with_the_reference(monkeypatch, name, params, n):
    """Systems with too many states for memoising get per-instance boxes from the compiled
    walk; culling by them must not lose anything the reference sees. The terrain's maps
    keep boxes exact (its S-nodes' own boxes are skipped after their operands'); the
    tree's rotate."""
    monkeypatch.setattr(bounds, "MAX_STATES", 0)
    obj = pcsg.load(GRAMMARS / f"{name}.pcsg", **params)
    assert obj.bounds_method == "every instance"
    assert obj.flat.inst_used.sum() > 100
    o, d = _rays_of_every_view(_finite_bounds(obj), n, seed=3)
    o = _outside_half_spaces(obj, o)
    assert_agrees(obj, o, d, min_hits=200)
    for lod in (0.0, 0.004):    # packets and single rays skip the same boxes
        a, b = obj.trace(o, d, lod=lod), obj.trace(o, d, lod=lod, packets=False)
        assert np.array_equal(a.t, b.t) and np.array_equal(a.normal, b.normal)


def _rays_of_every_view(bounds_, n, seed):
    """camera_rays from each of VIEWS, as one array of rays."""
    rays = [camera_rays(bounds_, n, view, seed=seed) for view in VIEWS]
    return np.concatenate([o for o, _ in rays]), np.concatenate([d for _, d in rays])


def test_padding_widens_every_finite_side_by_its_hair():
    """Each finite side moves outwards by 1e-9 of the axis's magnitude plus 1e-12 (the
    formula in numpy below); infinite sides and empty boxes stay."""
    from pcsg import tracer
    rng = np.random.default_rng(7)
    boxes = rng.normal(size=(50, 6)) * 10.0 ** rng.integers(-6, 6, size=(50, 6))
    boxes[::5, 2] = np.inf
    boxes[::7, 3] = -np.inf
    boxes[::9] = [np.inf, np.inf, np.inf, -np.inf, -np.inf, -np.inf]     # empty
    whole = tracer._pad(boxes)
    assert not np.array_equal(whole, boxes)
    finite = np.isfinite(boxes)
    scale = np.where(finite, np.abs(boxes), 0.0)
    ext = 1e-9 * (scale[:, :3] + scale[:, 3:]) + 1e-12
    want = boxes.copy()
    want[:, :3] -= np.where(finite[:, :3], ext, 0.0)
    want[:, 3:] += np.where(finite[:, 3:], ext, 0.0)
    assert np.array_equal(whole, want)
    assert np.all(whole[:, :3][finite[:, :3]] < boxes[:, :3][finite[:, :3]])
    assert np.all(whole[:, 3:][finite[:, 3:]] > boxes[:, 3:][finite[:, 3:]])
    assert np.array_equal(whole[~finite], boxes[~finite])


def test_a_ray_from_inside_a_union_stops_at_the_inner_surface_unless_intersected():
    # the documented limit (README, "How the tracer works"): under a union the nearest
    # surface of any operand; inside an ∩ the solid's exit, as the reference's
    import pcsg
    o, d = [[0.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]]
    assert pcsg.loads("sphere ∪ move(0.5, 0, 0) sphere").trace(o, d).t[0] == 1.0
    whole = pcsg.loads("(sphere ∪ move(0.5, 0, 0) sphere) ∩ uscale(10) cube").trace(o, d)
    assert whole.t[0] == pytest.approx(1.5)
    # a union that glass is made of is traced as one solid (graph/solidglass.py)
    glass = pcsg.loads("#material glass transmit=0.9\n"
                       "material(glass) (sphere ∪ move(0.5, 0, 0) sphere)").trace(o, d)
    assert glass.t[0] == pytest.approx(1.5) and glass.normal[0].tolist() == [1.0, 0.0, 0.0]


@pytest.mark.parametrize("shape", [(3, 2), (2, 3, 3), (1, 2), (4,)])
def test_rays_of_another_shape_are_refused(shape):
    # a (3, 2) array was read as two rays of garbage
    import pcsg
    obj = pcsg.loads("sphere")
    with pytest.raises(ValueError, match=r"must be real numbers of shape \(N, 3\)"):
        obj.trace(np.zeros(shape), np.ones(shape))
    assert obj.trace([0, 0, 5], [0, 0, -1]).t[0] == 4.0          # (3,): one ray
    hits = obj.trace([0, 0, 5], [0, 0, -1])
    assert obj.trace([], []).t.shape == (0,)                      # no rays
    with pytest.raises(ValueError, match="origins must be real numbers of shape .* rows of "
                                         "different lengths"):
        obj.trace([[0, 0, 5], [0, 0]], [[0, 0, -1], [0, 0, -1]])     # numpy's message (QA)
    assert hits == hits and hits != obj.trace([0, 0, 5], [0, 0, -1])   # identity, not arrays


@pytest.mark.parametrize("text, origin, want", [
    ("scale(1e155, 1, 1) sphere", (0, 0.5, -5), (0, 0.5, -0.75 ** 0.5)),
    ("scale(1e200, 1e-200, 1) sphere", (0, 0, -5), (0, 0, -1)),
    ("scale(1e-160, 1e-160, 1) sphere", (0, 0, -5), (0, 0, -1)),
])
def test_normals_of_extreme_maps_are_unit_vectors(text, origin, want):
    # the cofactors' squares overflowed (a normal of zeros, or nan) or underflowed
    hits = pcsg.loads(text).trace(origin, (0, 0, 1))
    assert hits.hit[0]
    np.testing.assert_allclose(hits.normal[0], want, atol=1e-12)


def test_a_depth_of_another_integer_type_does_not_compile_the_kernel_again():
    """`obj.max_depth = np.int32(3)` went to the kernel as an int32: numba compiled the
    trace again for it, minutes with no word (QA)."""
    import pcsg
    from pcsg.trace.kernel import trace_share
    obj = pcsg.loads("sphere")
    assert obj.trace([0, 0, 5], [0, 0, -1]).t[0] == 4.0
    compiled = list(trace_share.signatures)
    obj.max_depth = np.int32(3)
    assert obj.trace([0, 0, 5], [0, 0, -1]).t[0] == 4.0
    assert list(trace_share.signatures) == compiled


def test_a_cone_flattened_to_a_sheet_keeps_its_outline():
    """`scale(1e-8, 1, 1) cone` seen side on from 6 units is the triangle that
    `scale(0.01, 1, 1) cone` is: it was drawn as its bounding rectangle, the cone's
    quadratic solved 6e8 away in its frame (QA)."""
    y, z = np.meshgrid(np.linspace(-1.2, 1.2, 61), np.linspace(-0.2, 1.2, 37))
    origins = np.column_stack([np.full(y.size, 6.0), y.ravel(), z.ravel()])
    directions = np.tile([-1.0, 0.0, 0.0], (y.size, 1))
    sheet = pcsg.loads("scale(1e-8, 1, 1) cone").trace(origins, directions).hit
    thick = pcsg.loads("scale(0.01, 1, 1) cone").trace(origins, directions).hit
    edge = np.abs(np.abs(y.ravel()) - (1 - z.ravel())) < 1e-9
    assert 400 < thick.sum() < 0.6 * y.size
    assert np.array_equal(sheet[~edge], thick[~edge])
