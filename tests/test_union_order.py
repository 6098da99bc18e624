"""The order in which both walks visit a union's operands (nodes.sort_visits): the
cheap ones (a primitive, or a run of C-, T-, paint and material nodes down to one, not a
fractal) first, then the nearest box first. The terrain's camera rays enter its box before the sea's,
and a quarter of them walked the patches under the water down to a hit behind the sea's
surface; tested first, the sea closes their windows there."""
import numpy as np
import pytest

import pcsg
from pcsg.trace.nodes import EV_VISITS, SORT_FEW, cheap_operand
from pcsg.trace.packet import FRAMES

from .conftest import GRAMMARS
from .oracle import assert_agrees, camera_rays

SEA = "material(sea) move(0, 0, sealevel) plane"


def _terrain(sea_in_a_module: bool, budget: int):
    text = (GRAMMARS / "carpenter_terrain.pcsg").read_text()
    assert SEA in text
    if sea_in_a_module:         # an S-node is not cheap: the sea is visited by its box
        text = text.replace(SEA, "SEA") + f"\nSEA 1\n1: SEA → {SEA}\n"
    return pcsg.loads(text, "terrain.pcsg", cnt=6, max_instances=budget)


def _rays_onto_the_sea_over_the_drowned_corner():
    """Rays down onto the sea where the terrain lies under it (the corner (1, 1))."""
    xy = np.array([(x, y) for x in np.linspace(0.75, 0.98, 6) for y in np.linspace(0.75, 0.98, 6)])
    o = np.c_[xy + 0.3, np.ones(len(xy))]
    return o, np.tile([-0.3, -0.3, -1.0], (len(xy), 1))


@pytest.mark.parametrize("packets", [True, False])
def test_the_sea_is_tested_before_the_terrain_under_it(packets):
    o, d = _rays_onto_the_sea_over_the_drowned_corner()
    # with eight instances a ray, each ray finds the sea, and stops for no budget
    h = _terrain(False, 8).trace(o, d, packets=packets)
    assert h.events[EV_VISITS].sum() == 0
    assert h.hit.all() and np.allclose(h.t, 1.0, rtol=0, atol=1e-12)
    # the same sea in a module is visited by its box, after the terrain's: each ray
    # walks the patches under the water first, and the budget stops every one
    late = _terrain(True, 8).trace(o, d, packets=packets)
    assert late.events[EV_VISITS].sum() == len(o)
    # given the instances, both find the same surface
    full = _terrain(True, 10_000).trace(o, d, packets=packets)
    assert full.events[EV_VISITS].sum() == 0
    assert np.array_equal(full.t, h.t) and np.array_equal(full.normal, h.normal)


def test_cheap_operands_come_first_and_the_nearest_among_them():
    """A primitive's run is cheap, a module (S-node) is not, a fractal is not."""
    obj = pcsg.loads("{n = 1} (S ∪ move(0, 0, 4) sphere ∪ sphere ∪ mandelbulb(8) ∪ "
                     "paint(1, 0, 0) rotx(30) cube)\nS 1\n1: S → cube\n")
    f = obj.flat
    union = next(i for i in range(len(f.kind)) if f.child_count[i] == 5)
    # the Python functions: the jitted ones would compile for this Flat's types
    cheap = [bool(cheap_operand.py_func(f, union, k)) for k in range(5)]
    assert cheap == [False, True, True, False, True]


def _many_operands(rng, n):
    """A flat union of n operands, cheap and not, of different paints: many overlap,
    and groups of them coincide."""
    parts = []
    for k in range(n):
        x, y, z = rng.uniform(-2, 2, 3) if k % 5 else (0.0, 0.0, 0.0)
        paint = f"paint({k / n:.3f}, {(k % 7) / 7:.3f}, 0.5)"
        body = ("S" if k % 3 == 0 else "cube" if k % 4 == 0 else "sphere")
        parts.append(f"{paint} move({x:.3f}, {y:.3f}, {z:.3f}) uscale(0.6) {body}")
    return pcsg.loads(" ∪\n".join(parts) + "\nS 1\n1: S → rotz(20) cube\n")


@pytest.mark.parametrize("n", [SORT_FEW - 3, SORT_FEW + 1, FRAMES - 8, FRAMES + 8])
def test_a_union_of_many_operands_agrees_with_the_reference(n):
    """Past SORT_FEW operands met at once the walks sort them by a heap, not by
    insertion: the same surfaces, and the same ones among coincident operands. A packet
    splits a union of fewer than FRAMES operands, whose rows it holds; past them its
    rays go on alone."""
    obj = _many_operands(np.random.default_rng(n), n)
    for view in [(1, -1, 0.5), (-0.3, 0.2, -1)]:
        o, d = camera_rays(obj.bounds, 24, view, spread=0.2)
        single = assert_agrees(obj, o, d, min_hits=150)
        packed = obj.trace(o, d, packets=True)
        alone = obj.trace(o, d, packets=False)
        for h in (packed, alone):
            assert np.array_equal(h.t, single.t) and np.array_equal(h.normal, single.normal)
            assert np.array_equal(h.paint, single.paint, equal_nan=True)


@pytest.mark.parametrize("packets", [True, False])
@pytest.mark.parametrize("n", [3, SORT_FEW + 5, 200])
def test_of_coincident_operands_the_first_keeps_the_surface(n, packets):
    """As a union merges: among operands whose surfaces coincide the earliest listed
    shows, however many there are and whichever way they are sorted."""
    spheres = " ∪ ".join(f"paint({k / n:.4f}, 0.25, 0.5) sphere" for k in range(n))
    # the cubes under them are met too, and sorted with them
    obj = pcsg.loads(f"move(0, 0, -3) cube ∪ {spheres} ∪ move(0, 0, -6) cube")
    xy = np.array([(x, y) for x in np.linspace(-0.6, 0.6, 16) for y in np.linspace(-0.6, 0.6, 16)])
    o = np.c_[xy, np.full(len(xy), 5.0)]
    h = obj.trace(o, np.tile([0.0, 0.0, -1.0], (len(o), 1)), packets=packets)
    assert h.hit.all()
    assert np.allclose(h.t, 5.0 - np.sqrt(1.0 - (xy ** 2).sum(axis=1)), rtol=0, atol=1e-9)
    assert np.array_equal(np.unique(h.paint, axis=0), [[0.0, 0.25, 0.5]])


def test_a_run_of_steps_ends_in_what_it_ends_in_however_long_it_is():
    """Flat.chain, which cheap_operand reads: each run of C-, T-, paint and material nodes
    is followed once, not from each of its nodes (5,000 C-nodes took 6 s of each flatten);
    a run into a cycle of maps ends in no primitive."""
    from pcsg.graph.flat import _chains
    from pcsg.graph.model import CALC, PRIMITIVE, SELECT, TRANSFORM
    calcs = "{x = x + 1} " * 3000
    obj = pcsg.loads(f"{{x = 0}} ({calcs}sphere ∪ {calcs}mandelbulb(8) ∪ {calcs}S)\n"
                     "S 1\n1: S → cube\n")
    f = obj.flat
    union = int(np.argmax(f.child_count))
    heads = f.children[f.child_start[union]:f.child_start[union] + 3]
    assert [int(f.chain[h]) for h in heads] == [1, 2, 0]
    # node 0 → 1 → 0, and 2 → 1 (into that cycle); 3 → 4, a primitive
    kind = np.array([TRANSFORM, TRANSFORM, CALC, CALC, PRIMITIVE, SELECT], dtype=np.int8)
    starts = np.array([0, 1, 2, 3, 4, 4], dtype=np.int32)
    children = np.array([1, 0, 1, 4], dtype=np.int32)
    assert _chains(kind, starts, children, np.zeros(6, dtype=bool)).tolist() == [0, 0, 0, 1, 0, 0]
