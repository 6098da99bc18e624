"""The order in which both walks visit a union's operands (nodes.pops_before): the
cheap ones (a primitive, or a run of C-, T-, paint and material nodes down to one, not a
fractal) first, then the nearest box first. The terrain's camera rays enter its box before the sea's,
and a quarter of them walked the patches under the water down to a hit behind the sea's
surface; tested first, the sea closes their windows there."""
import numpy as np
import pytest

import pcsg
from pcsg.trace.nodes import EV_VISITS, cheap_operand, pops_before

from .conftest import GRAMMARS

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
    before = pops_before.py_func
    assert before(True, 5.0, False, 1.0) and not before(False, 1.0, True, 5.0)
    assert before(True, 1.0, True, 1.0) and not before(True, 2.0, True, 1.0)
