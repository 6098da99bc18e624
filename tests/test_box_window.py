"""The slab test every box test of both walks makes (windows.box_window, windows.slabs, and
simd.quad_windows for four boxes at once), against the textbook definition: a ray
parallel to a slab is inside it for all t or for none, decided by its origin, sides
included. The kernel reads no direction, only 1/d, and has no branch for d = 0 or -0:
these are the cases where that must come out the same."""
import math

import numpy as np
from hypothesis import assume, given, settings, strategies as st
from numba import njit

from pcsg.trace.nodes import DX, F_WIDTH, INV, OX, map_ray_scaled, set_inverse
from pcsg.trace.windows import FAR, box_window, slabs
from pcsg.trace.simd import quad_windows

# few distinct values, so that origins fall on side planes and sides coincide often
value = st.sampled_from([-2.0, -1.0, -0.5, 0.0, 0.5, 1.0, 2.0, 3.0, math.inf, -math.inf])
finite = st.sampled_from([-2.0, -1.0, -0.5, 0.0, 0.5, 1.0, 2.0, 3.0])
direction = st.sampled_from([0.0, -0.0, 1.0, -1.0, 0.25, -3.0, 1e-300])


def textbook(box, o, d):
    """(t0, t1) with the parallel case as its own branch; empty as (inf, -inf); the
    ends of an unbounded box's window at ±FAR, as slabs leaves them."""
    t0, t1 = -math.inf, math.inf
    for a in range(3):
        lo, hi = box[a], box[a + 3]
        if d[a] == 0.0:
            if not lo <= o[a] <= hi:
                return math.inf, -math.inf
            continue
        inv = 1.0 / d[a]
        ta, tb = sorted(((lo - o[a]) * inv, (hi - o[a]) * inv))
        t0, t1 = max(t0, ta), min(t1, tb)
    return max(t0, -FAR), min(t1, FAR)


def kernel(box, o, d):
    F = np.zeros((1, F_WIDTH))
    F[0, OX:OX + 3] = o
    F[0, DX:DX + 3] = d
    set_inverse(F, 0)
    return box_window(np.asarray(box, dtype=float)[None], 0, F, 0)


@settings(max_examples=2000, deadline=None)
@given(st.lists(value, min_size=6, max_size=6), st.tuples(finite, finite, finite),
       st.tuples(direction, direction, direction))
def test_box_window_agrees_with_the_textbook_slab_test(ends, o, d):
    assume(any(v != 0.0 for v in d))        # (0, 0, 0) is no ray
    box = np.sort(np.reshape(ends, (2, 3)), axis=0).ravel()
    want = textbook(box, o, d)
    got = kernel(box, o, d)
    assert (got[0] <= got[1]) == (want[0] <= want[1]), (box, o, d, got, want)
    if want[0] <= want[1]:
        assert got == want


def test_a_ray_in_a_side_plane_of_the_box_is_inside_that_slab():
    """0 * inf is nan there: the comparisons must leave it out, not empty the window."""
    box = (0.0, 0.0, 0.0, 1.0, 1.0, 1.0)
    assert kernel(box, (0.0, 0.5, -1.0), (0.0, 0.0, 1.0)) == (1.0, 2.0)
    assert kernel(box, (1.0, 1.0, -1.0), (-0.0, 0.0, 1.0)) == (1.0, 2.0)
    t0, t1 = kernel(box, (1.5, 0.5, -1.0), (0.0, 0.0, 1.0))
    assert t0 > t1


@given(st.tuples(finite, finite, finite), st.tuples(direction, direction, direction),
       st.sampled_from([-2.0, -0.5, 0.25, 4.0]), st.lists(value, min_size=6, max_size=6))
def test_a_ray_mapped_by_a_power_of_two_scale_gets_the_window_of_its_own_inverse(o, d, s,
                                                                                  ends):
    """map_ray_scaled multiplies 1/d by the scale instead of dividing: where d is 0 that
    would give -inf for a negative scale, which _slab must not see."""
    assume(any(v != 0.0 for v in d))
    L = np.zeros(21)
    L[[0, 4, 8]] = s                     # [L (9) | t (3) | L^-1 (9)], a scale by s
    L[[12, 16, 20]] = 1.0 / s
    F = np.zeros((1, F_WIDTH))
    F[0, OX:OX + 3] = o
    F[0, DX:DX + 3] = d
    set_inverse(F, 0)
    G = np.zeros((1, F_WIDTH))
    map_ray_scaled(L, F, 0, G, 0)
    assert not np.any(G[0, INV:INV + 3] == -np.inf)
    box = np.sort(np.reshape(ends, (2, 3)), axis=0).ravel()
    want = textbook(box, tuple(G[0, OX:OX + 3]), tuple(G[0, DX:DX + 3]))
    got = box_window(box[None], 0, G, 0)
    assert (got[0] <= got[1]) == (want[0] <= want[1])
    if want[0] <= want[1]:
        assert got == want


@njit
def four_at_once(boxes, F, w0, w1):
    return np.array(quad_windows(boxes, F[0, OX], F[0, OX + 1], F[0, OX + 2], F[0, INV],
                                 F[0, INV + 1], F[0, INV + 2], w0, w1))


@njit
def one_by_one(boxes, F, w0, w1):
    """What packet.split_each does for each child: slabs, then max and min with the
    ray's window."""
    out = np.empty(8)
    for k in range(4):
        t0, t1 = slabs(boxes[0, k], boxes[1, k], boxes[2, k], boxes[3, k], boxes[4, k],
                       boxes[5, k], F, 0)
        out[k] = max(t0, w0)
        out[4 + k] = min(t1, w1)
    return out


@settings(max_examples=1000, deadline=None)
@given(st.lists(value, min_size=24, max_size=24), st.tuples(finite, finite, finite),
       st.tuples(direction, direction, direction), finite, value)
def test_four_boxes_at_once_give_each_box_window_to_the_bit(ends, o, d, w0, w1):
    """simd.quad_windows (packet.split_quad) against the scalar test, on any four boxes,
    inverted and with infinite sides too (the lanes of absent children hold zeros): the
    same windows to the bit, nan and the sign of zero included."""
    F = np.zeros((1, F_WIDTH))
    F[0, OX:OX + 3] = o
    F[0, DX:DX + 3] = d
    set_inverse(F, 0)
    boxes = np.reshape(np.asarray(ends), (6, 4))
    got, want = four_at_once(boxes, F, w0, w1), one_by_one(boxes, F, w0, w1)
    assert np.array_equal(got.view(np.int64), want.view(np.int64)), (boxes, o, d, got, want)
