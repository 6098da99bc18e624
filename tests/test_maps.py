"""A ray mapped into a T-node's frame: moves and power-of-two scales (the Sierpinski
tetrahedron's and the terrain's maps) take a short way, with products for the three
divisions of 1/d (nodes.map_ray_scaled), which must give the general way's values bit
for bit, so that the picture does not change."""
import numpy as np
from hypothesis import given, settings, strategies as st

from pcsg.trace.nodes import (DX, F_WIDTH, INV, OX, exact_scaling, map_ray, map_ray_scaled)


def layout(forward, move):
    """transform_map's layout of x -> forward x + move: [L (9) | t (3) | L^-1 (9)]."""
    forward = np.asarray(forward, dtype=float)
    return np.concatenate([forward.ravel(), move, np.linalg.inv(forward).ravel()])


def ray(o, d):
    F = np.zeros((1, F_WIDTH))
    F[0, OX:OX + 3] = o
    F[0, DX:DX + 3] = d
    with np.errstate(divide="ignore"):
        F[0, INV:INV + 3] = 1.0 / F[0, DX:DX + 3]
    return F


power = st.integers(-30, 30).flatmap(lambda k: st.sampled_from([2.0 ** k, -(2.0 ** k)]))
coord = st.floats(-1e6, 1e6)
# directions from the camera's range: 1/d and its products stay normal numbers
component = st.one_of(st.just(0.0), st.floats(1e-6, 1e6), st.floats(-1e6, -1e-6))


@settings(max_examples=400, deadline=None)
@given(st.tuples(power, power, power), st.tuples(coord, coord, coord),
       st.tuples(coord, coord, coord), st.tuples(component, component, component))
def test_moves_and_power_of_two_scales_map_rays_as_the_general_way(scale, move, o, d):
    L = layout(np.diag(scale), move)
    assert exact_scaling(L)
    F = ray(o, d)
    general, short = F.copy(), F.copy()
    map_ray(L, F, 0, general, 0)
    map_ray_scaled(L, F, 0, short, 0)
    # == holds -0.0 and 0.0 equal: only a zero's sign may differ, which no test reads
    assert np.array_equal(short[0, :INV], general[0, :INV])
    moving = short[0, DX:DX + 3] != 0.0       # where d is 0 the slab tests skip 1/d
    assert np.array_equal(short[0, INV:INV + 3][moving], general[0, INV:INV + 3][moving])
    assert np.all(np.abs(short[0, INV:INV + 3][~moving]) == np.inf)


def test_other_maps_take_the_general_way():
    turn = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
    shear = [[1.0, 0.0, 0.5], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    for forward in (np.diag([3.0, 1.0, 1.0]),       # 1/3 is not exact
                    np.diag([0.5, 0.5, 0.75]), turn, shear):
        assert not exact_scaling(layout(forward, (0.0, 0.0, 0.0)))
    assert exact_scaling(layout(np.diag([0.5, 0.5, 1.0]), (0.5, -0.5, 0.0)))


def test_a_turn_too_large_for_its_radians_is_the_same_turn_less_whole_turns():
    """rotz(1e308): its radians overflowed, and the turn emptied its operand as if its axis
    were zero (QA). 1e308 is 296 more than a whole number of turns."""
    import pcsg
    turned, same = pcsg.loads("rotz(1e308) cube"), pcsg.loads("rotz(296) cube")
    assert not turned.warnings
    o = np.array([[x, -5.0, 0.3] for x in np.linspace(-1.5, 1.5, 31)])
    d = np.tile([0.0, 1.0, 0.0], (31, 1))
    a, b = turned.trace(o, d), same.trace(o, d)
    assert a.hit.sum() > 20 and np.array_equal(a.t, b.t)
