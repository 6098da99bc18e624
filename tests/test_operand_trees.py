"""Trees of boxes over a wide union's operands (graph/operand_trees.py): a ray tests the
operands under the tree boxes it meets, and meets the same operands, in the same order,
with the same hashes, as the union tested operand by operand."""
import numpy as np
import pytest

import pcsg
from pcsg.graph.operand_trees import LEAF, WIDE, _item_boxes
from pcsg.trace.packet import FRAMES

from .oracle import assert_agrees, camera_rays
from .test_spheres import OCTA


def _scattered(rng, n, body):
    """n operands `body` at random places and sizes in a box of side 10, of n paints."""
    parts = []
    for k in range(n):
        x, y, z = rng.uniform(0, 10, 3)
        parts.append(f"paint({k / n:.4f}, {(k % 7) / 7:.3f}, 0.5) move({x:.4f}, {y:.4f}, "
                     f"{z:.4f}) uscale({rng.uniform(0.2, 0.9):.3f}) {body}")
    return parts


def _spheres(n):
    rng = np.random.default_rng(n)
    # and operands a ray cannot miss or cannot meet: a plane, an empty sphere
    parts = _scattered(rng, n, "sphere") + ["move(0, 0, -1) plane", "uscale(0) sphere"]
    return pcsg.loads(" ∪\n".join(parts))


def _forest(n, side=10.0):
    """Trees whose branches turn by rand(): their pictures depend on each operand's
    number, which hashes their instances."""
    rng = np.random.default_rng(n)
    parts = [f"move({x:.3f}, {y:.3f}, 0) {{d = 3}} T" for x, y in rng.uniform(0, side, (n, 2))]
    return pcsg.loads(" ∪\n".join(parts) + "\nT if(d > 0, 2, 1)\n"
                      "1: T → scale(0.2, 0.2, 1) cylinder\n"
                      "2: T → scale(0.2, 0.2, 1) cylinder ∪ move(0, 0, 1) {d = d - 1} "
                      "(rotz(rand() * 360) roty(30) uscale(0.7) T ∪ "
                      "rotz(rand() * 360) roty(-30) uscale(0.7) T)\n")


def _graftals(n):
    """Graftals bounded by spheres (graph/volumes.py), drawn at pixel size as spheres."""
    rng = np.random.default_rng(n)
    parts = _scattered(rng, n, "O")
    return pcsg.loads(" ∪\n".join(parts) + OCTA[1:], max_depth=3)


def _repainted(operand):
    """`paint(...) rest` of _scattered in another paint."""
    return "paint(0.9, 0.1, 0.1) " + operand.split(") ", 1)[1]


def _cheese(n):
    """A block with n holes, one drilled by n subtrahends, and a wide union cut by a box:
    interval lists of wide unions and differences (walk.intervals), with holes that
    coincide and holes that touch."""
    rng = np.random.default_rng(n)
    holes = _scattered(rng, n, "sphere")
    # coincident ones of other paints (the first one's shows), and touching ones
    holes += [_repainted(h) for h in holes[:5]] + [f"move({x}, 5, 5) sphere" for x in (3, 5, 7)]
    cut = _scattered(rng, n, "cube")
    cut += [_repainted(c) for c in cut[:5]] + ["move(5, 5, 5) {d = 2} T"]
    drilled = " \\ ".join(_scattered(rng, n, "sphere"))
    return pcsg.loads(f"move(5, 5, 5) uscale(4.5) cube \\ ({' ∪ '.join(holes)}) ∪\n"
                      f"move(-12, 0, 0) (move(5, 5, 5) uscale(4.5) cube \\ {drilled}) ∪\n"
                      f"move(12, 0, 0) (({' ∪ '.join(cut)}) ∩ move(5, 5, 5) uscale(4) cube)\n"
                      "T if(d > 0, 2, 1)\n1: T → sphere\n"
                      "2: T → {d = d - 1} (move(1, 0, 0) uscale(0.5) T ∪ move(-1, 0, 0) "
                      "uscale(0.5) T ∪ cube)\n")


SYSTEMS = {"spheres": lambda: _spheres(300), "forest": lambda: _forest(40),
           "graftals": lambda: _graftals(60), "cheese": lambda: _cheese(150)}


def _without_trees(obj):
    """The same object, its unions tested operand by operand."""
    plain = pcsg.Traced.__new__(pcsg.Traced)
    plain.__dict__.update(obj.__dict__)
    plain.flat = obj.flat._replace(tree_root=np.full_like(obj.flat.tree_root, -1))
    return plain


def _rays(obj):
    """Camera rays from three sides, and rays from points inside the scene."""
    rays = [camera_rays(obj.bounds, 28, view, spread=0.6)
            for view in [(1, -1, 0.5), (-0.3, 0.2, -1), (0.1, 1, 0.2)]]
    rng = np.random.default_rng(7)
    rays.append((rng.uniform(0, 10, (1000, 3)), rng.normal(size=(1000, 3))))
    return np.concatenate([o for o, _ in rays]), np.concatenate([d for _, d in rays])


@pytest.mark.parametrize("name", sorted(SYSTEMS))
def test_a_tree_meets_what_the_union_tested_operand_by_operand_meets(name):
    obj = SYSTEMS[name]()
    assert (obj.flat.tree_root >= 0).sum() == (3 if name == "cheese" else 1)
    plain = _without_trees(obj)
    o, d = _rays(obj)
    lod = 0.002 if name == "graftals" else 0.0      # graftal instances at pixel size
    for packets in (True, False):
        for any_hit in (False, True):
            a = obj.trace(o, d, packets=packets, any_hit=any_hit, lod=lod)
            b = plain.trace(o, d, packets=packets, any_hit=any_hit, lod=lod)
            assert a.hit.sum() > 200
            # the same surfaces, the same hashes (the forest's branches), bit for bit
            for field in ("t", "normal", "paint", "material", "what"):
                assert np.array_equal(getattr(a, field), getattr(b, field), equal_nan=True), \
                    (field, packets, any_hit)
            assert np.array_equal(a.events, b.events)


def test_a_block_with_many_holes_agrees_with_the_reference():
    obj = _cheese(40)
    for view in [(1, -1.2, 0.6), (-0.2, 0.3, 1)]:
        o, d = camera_rays(obj.bounds, 40, view, spread=0.3)
        assert_agrees(obj, o, d, min_hits=400)


def test_a_wide_union_of_random_trees_agrees_with_the_reference():
    obj = _forest(WIDE + 4, side=3.0)
    o, d = camera_rays(obj.bounds, 48, (1, -1.2, 0.6), spread=0.3)
    assert_agrees(obj, o, d, min_hits=400)


@pytest.mark.parametrize("n", [WIDE - 3, WIDE - 2, FRAMES + 8, 2000])
def test_every_operand_a_ray_can_meet_is_under_tree_boxes_that_hold_its_box(n):
    obj = _spheres(n)
    f = obj.flat
    union = int(np.argmax(f.child_count))
    root = f.tree_root[union]
    if n + 2 < WIDE:
        assert root == -1
        return
    end = f.tree_skip[root]
    rows = range(root, end)
    kids = f.children[f.child_start[union] + np.arange(f.child_count[union])]
    boxes = _item_boxes(f.box, f.sphere, kids)
    listed = np.concatenate([f.tree_items[f.tree_first[r]:f.tree_first[r] + f.tree_count[r]]
                             for r in rows])
    # each once, but for the empty sphere, which no ray meets
    assert sorted(listed.tolist()) == [k for k in range(n + 2) if k != n + 1]
    assert f.box[kids[n + 1], 0] > f.box[kids[n + 1], 3]

    def holds(outer, inner):
        return (outer[:3] <= inner[:3]).all() and (outer[3:] >= inner[3:]).all()

    for r in rows:
        assert f.tree_skip[r] > r and f.tree_skip[r] <= end
        if f.tree_count[r]:         # a leaf: its operands' boxes, which pad the node boxes
            assert f.tree_count[r] <= LEAF and f.tree_skip[r] == r + 1
            for k in f.tree_items[f.tree_first[r]:f.tree_first[r] + f.tree_count[r]]:
                assert holds(f.tree_box[r], boxes[k]) and holds(boxes[k], f.box[kids[k]])
        else:                       # an inner row: its two children's subtrees
            first, second = r + 1, f.tree_skip[r + 1]
            assert second < f.tree_skip[r] and f.tree_skip[second] == f.tree_skip[r]
            assert holds(f.tree_box[r], f.tree_box[first])
            assert holds(f.tree_box[r], f.tree_box[second])
    # balanced: the median splits it in halves
    depth, deepest = {root: 0}, 0
    for r in rows:
        if not f.tree_count[r]:
            depth[r + 1] = depth[f.tree_skip[r + 1]] = depth[r] + 1
        deepest = max(deepest, depth[r])
    assert deepest <= int(np.ceil(np.log2((n + 1) / LEAF))) + 1


def test_a_tree_is_built_from_the_boxes_alone():
    """The same file, the same tree (the render is the same bytes at any thread count)."""
    a, b = _spheres(500).flat, _spheres(500).flat
    for field in ("tree_root", "tree_box", "tree_skip", "tree_first", "tree_count", "tree_items"):
        assert np.array_equal(getattr(a, field), getattr(b, field))


def test_no_tree_where_no_operand_is_bounded():
    """Where nothing is bounded (the boxes are all of space), a tree would cull nothing
    and cost each ray its rows."""
    from pcsg.graph.flat import flatten_graph
    obj = _spheres(40)
    everywhere = np.tile([-np.inf] * 3 + [np.inf] * 3, (len(obj.graph.nodes), 1))
    assert (flatten_graph(obj.graph, everywhere).tree_root == -1).all()
    assert (obj.flat.tree_root >= 0).sum() == 1


@pytest.mark.parametrize("rows", [16, 20, 64])
def test_where_the_interval_rows_run_out_a_tree_does_what_the_loop_does(rows):
    """The candidates are kept apart from the interval rows, which the loop over every
    operand would use: where they run out, the loop's fallback (an operator keeps the
    list it has) meets the same lists at the same rows. The first version kept them in
    those rows, ran out sooner, and drew the far face of `long box ∩ (33 slabs)` (QA)."""
    from pcsg.trace.nodes import EV_INTERVALS
    slabs = " ∪ ".join(f"paint({k / 33:.4f}, 0, 0) move({2 * k + 1}, 0, 0) uscale(0.5) cube"
                       for k in range(33))
    thin = " \\ ".join(f"move({0.03 * k - 4.5:.3f}, 0, 0) scale(0.01, 2, 0.2) cube"
                       for k in range(300))
    rng = np.random.default_rng(rows)
    for text, o in ((f"scale(100000, 1, 1) cube ∩ ({slabs})", [-5.0, 0.0, 0.01]),
                    (f"paint(0, 0, 1) scale(5, 1, 1) cube \\ {thin}", [-8.0, 0.0, 0.01])):
        obj = pcsg.loads(text, interval_rows=rows)
        plain = _without_trees(obj)
        origins = np.array(o) + rng.uniform(-0.3, 0.3, (200, 3)) * [0, 1, 0.1]
        d = np.tile([1.0, 0.0, 0.0], (200, 1)) + rng.uniform(-0.02, 0.02, (200, 3))
        a, b = obj.trace(origins, d, packets=False), plain.trace(origins, d, packets=False)
        for field in ("t", "normal", "paint", "material", "what"):
            assert np.array_equal(getattr(a, field), getattr(b, field), equal_nan=True), field
        # the merges it skips (an operand's empty list) are ones the loop may find full
        assert (a.events[EV_INTERVALS] <= b.events[EV_INTERVALS]).all()
        assert b.events[EV_INTERVALS].sum() > 0 or rows > 16
