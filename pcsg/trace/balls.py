"""Bounding balls beside the bounding walk's boxes, for systems that rotate.

A box mapped by a rotation is bounded by a larger box, and that box, mapped by the next
level's rotation, by a larger one again: a bush of random branch angles, bounded box by
box, had a root box 1.6 to 2.1 times its own size at six levels and 2.8 to 3.2 at nine,
and its rays entered instances that a tighter box would have passed by. A ball maps through a rotation without growing
(its centre maps, its radius scales by the map's largest stretch), so the bounding walk
(trace/boxwalk.py) carries a ball beside each instance's box and cuts the box to the
ball's: the intersection of two bounds is one. The ball is kept the smaller of its own and
the box's, so that one flat or long box does not leave it the size of a union of balls.

An instance's row holds its box (6) and then its ball: BALL + (cx, cy, cz), RADIUS; a
radius below 0 is an empty ball, an infinite one bounds nothing. Every result is widened
by SLACK of its magnitude: the boxes must stay conservative under rounding (trace/pad.py
then pads them further)."""
from __future__ import annotations

import math

import numpy as np

from .jit import inline
from .transforms import MATRIX, MIRROR, ROT, ROTX, ROTY, ROTZ
from ..graph.model import TRANSFORM

BALL = 6            # the ball's centre in an instance row; its radius at RADIUS
RADIUS = 9
ROW = 10            # an instance row: box (6), ball (4)
SLACK = 1e-12


@inline
def rotates(flat):
    """Whether the system has a map that turns a box off its axes (a rotation, a mirror
    or a matrix of the grammar's own): the walk only carries balls then. The terrain's
    matrices are runs of moves and shears written out as one (flat.origin), where a ball
    of a flat patch would bound nothing. A run written out as one keeps its own T-nodes in
    the graph, out of the walks' way (graph/fuse.py), so its turns are still seen here."""
    for n in range(flat.kind.shape[0]):
        if flat.kind[n] == TRANSFORM:
            c = flat.code[n]
            if c == ROTX or c == ROTY or c == ROTZ or c == ROT or c == MIRROR or (
                    c == MATRIX and flat.origin[n] < 0):
                return True
    return False


@inline
def _set(row, x, y, z, r):
    row[BALL] = x
    row[BALL + 1] = y
    row[BALL + 2] = z
    row[RADIUS] = r


@inline
def _widened(r, x, y, z):
    return r + SLACK * (r + abs(x) + abs(y) + abs(z))


@inline
def ball_of_box(row):
    """row's ball: the one round its box."""
    if row[0] > row[3] or row[1] > row[4] or row[2] > row[5]:
        _set(row, 0.0, 0.0, 0.0, -1.0)
        return
    for a in range(3):
        if not (math.isfinite(row[a]) and math.isfinite(row[a + 3])):
            _set(row, 0.0, 0.0, 0.0, np.inf)
            return
    x = 0.5 * row[0] + 0.5 * row[3]     # halves first: a sum near the largest double is inf
    y = 0.5 * row[1] + 0.5 * row[4]
    z = 0.5 * row[2] + 0.5 * row[5]
    hx = 0.5 * (row[3] - row[0])
    hy = 0.5 * (row[4] - row[1])
    hz = 0.5 * (row[5] - row[2])
    _set(row, x, y, z, _widened(math.sqrt(hx * hx + hy * hy + hz * hz), x, y, z))


@inline
def map_ball(m, src, dst):
    """dst's ball: the image of src's under the 3x4 map m, its radius scaled by a bound
    on m's largest stretch (the square root of the largest row sum of |m^T m|, exact for
    a rotation times a scale). src and dst may be one row. A stretch or centre that
    overflows (entries over 1e154 square to inf, and inf - inf is nan, which max() would
    drop) gives a ball that bounds nothing."""
    r = src[RADIUS]
    if r < 0.0 or r == np.inf:
        _set(dst, 0.0, 0.0, 0.0, r)
        return
    p = src[BALL]
    q = src[BALL + 1]
    s = src[BALL + 2]
    x = m[0, 0] * p + m[0, 1] * q + m[0, 2] * s + m[0, 3]
    y = m[1, 0] * p + m[1, 1] * q + m[1, 2] * s + m[1, 3]
    z = m[2, 0] * p + m[2, 1] * q + m[2, 2] * s + m[2, 3]
    most = 0.0
    for i in range(3):
        total = 0.0
        for j in range(3):
            total += abs(m[0, i] * m[0, j] + m[1, i] * m[1, j] + m[2, i] * m[2, j])
        if not total < np.inf:      # inf, or nan
            _set(dst, 0.0, 0.0, 0.0, np.inf)
            return
        most = max(most, total)
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
        _set(dst, 0.0, 0.0, 0.0, np.inf)
        return
    _set(dst, x, y, z, _widened(r * math.sqrt(most), x, y, z))


@inline
def unite_ball(acc, b):
    """acc's ball: the least one round acc's and b's."""
    rb = b[RADIUS]
    ra = acc[RADIUS]
    if rb < 0.0:
        return
    if ra < 0.0 or rb == np.inf:
        _set(acc, b[BALL], b[BALL + 1], b[BALL + 2], rb)
        return
    if ra == np.inf:
        return
    dx = b[BALL] - acc[BALL]
    dy = b[BALL + 1] - acc[BALL + 1]
    dz = b[BALL + 2] - acc[BALL + 2]
    d = math.sqrt(dx * dx + dy * dy + dz * dz)
    if d + rb <= ra:
        return
    if d + ra <= rb:
        _set(acc, b[BALL], b[BALL + 1], b[BALL + 2], rb)
        return
    r = 0.5 * (d + ra + rb)
    k = (r - ra) / d
    x = acc[BALL] + k * dx
    y = acc[BALL + 1] + k * dy
    z = acc[BALL + 2] + k * dz
    _set(acc, x, y, z, _widened(r, x, y, z))


@inline
def smaller_ball(acc, b):
    """acc's ball: the smaller of acc's and b's (an intersection lies in each)."""
    if b[RADIUS] < acc[RADIUS]:
        _set(acc, b[BALL], b[BALL + 1], b[BALL + 2], b[RADIUS])


@inline
def tighten(row):
    """row's box cut to its ball's box, and its ball to the one round that box where
    that one is smaller."""
    r = row[RADIUS]
    if r < 0.0 or r == np.inf:
        return
    for a in range(3):
        row[a] = max(row[a], row[BALL + a] - r)
        row[a + 3] = min(row[a + 3], row[BALL + a] + r)
    if row[0] > row[3] or row[1] > row[4] or row[2] > row[5]:
        return
    hx = 0.5 * (row[3] - row[0])
    hy = 0.5 * (row[4] - row[1])
    hz = 0.5 * (row[5] - row[2])
    if hx * hx + hy * hy + hz * hz < r * r:
        ball_of_box(row)
