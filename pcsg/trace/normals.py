"""Normals and sizes in world space, through a frame's accumulated world-from-local
map M: the shading normal of a hit, the running average of box normals that shades a
graftal at pixel size, and the world extent of an instance that the level of detail
compares with a pixel."""
from __future__ import annotations

import math

import numpy as np

from .jit import inline, kernel
from .nodes import M0, NAVG
from .windows import volume_normal


@kernel
def world_normal(F, f, nx, ny, nz, out, row, k):
    """out[row, k:k+3] = unit world normal of the local normal n."""
    x, y, z = unit_world_normal(F, f, nx, ny, nz)
    out[row, k] = x
    out[row, k + 1] = y
    out[row, k + 2] = z


@inline
def average_box_normal(flat, node, F, f, t):
    """Fold the world normal of this box (or sphere) where the ray enters it into the
    frame's running average (Hart & DeFanti, as Bekaert & Willems shade graftals): the
    finer the box, the more it weighs; returns the average, normalised."""
    nx, ny, nz = volume_normal(flat, node, F, f, t)
    x, y, z = unit_world_normal(F, f, nx, ny, nz)
    d = flat.normal_decay
    x += d * F[f, NAVG]
    y += d * F[f, NAVG + 1]
    z += d * F[f, NAVG + 2]
    F[f, NAVG] = x
    F[f, NAVG + 1] = y
    F[f, NAVG + 2] = z
    length = math.sqrt(x * x + y * y + z * z)
    if length > 0.0:
        return x / length, y / length, z / length
    return 0.0, 0.0, 0.0


@kernel
def unit_world_normal(F, f, nx, ny, nz):
    """The unit world normal of the local normal n: the inverse transpose of M applied
    to n, written as sign(det M) times the cofactor matrix, which needs no division."""
    m0, m1, m2 = F[f, M0], F[f, M0 + 1], F[f, M0 + 2]
    m3, m4, m5 = F[f, M0 + 3], F[f, M0 + 4], F[f, M0 + 5]
    m6, m7, m8 = F[f, M0 + 6], F[f, M0 + 7], F[f, M0 + 8]
    c00 = m4 * m8 - m5 * m7
    c01 = m5 * m6 - m3 * m8
    c02 = m3 * m7 - m4 * m6
    c10 = m2 * m7 - m1 * m8
    c11 = m0 * m8 - m2 * m6
    c12 = m1 * m6 - m0 * m7
    c20 = m1 * m5 - m2 * m4
    c21 = m2 * m3 - m0 * m5
    c22 = m0 * m4 - m1 * m3
    det = m0 * c00 + m1 * c01 + m2 * c02
    s = 1.0 if det >= 0.0 else -1.0
    x = s * (c00 * nx + c01 * ny + c02 * nz)
    y = s * (c10 * nx + c11 * ny + c12 * nz)
    z = s * (c20 * nx + c21 * ny + c22 * nz)
    length = math.sqrt(x * x + y * y + z * z)
    if not 1e-150 < length < 1e150:
        # the squares of the vector over- or underflow (scale(1e155, 1, 1) gave a normal
        # of zeros, scale(1e-160, 1e-160, 1) one of nan): its largest component is 1 after
        # this. (A map whose determinant overflows empties its instance: graph/bounds.py)
        a = max(abs(x), abs(y), abs(z))
        if 0.0 < a < np.inf:
            x, y, z = x / a, y / a, z / a
            length = math.sqrt(x * x + y * y + z * z)
    if length > 0.0:
        x /= length
        y /= length
        z /= length
    return x, y, z


@inline
def world_size(boxes, b, F, f):
    """An upper bound of the world extent of this instance of boxes[b]."""
    size = 0.0
    for a in range(3):
        e = boxes[b, a + 3] - boxes[b, a]
        if not math.isfinite(e):
            return np.inf
        col = math.sqrt(F[f, M0 + a] ** 2 + F[f, M0 + 3 + a] ** 2 + F[f, M0 + 6 + a] ** 2)
        size += e * col
    return size


@inline
def world_diameter(boxes, b, F, f):
    """The world length of the longest diagonal of this instance of boxes[b]: the
    diameter of the parallelepiped it maps to."""
    e0 = boxes[b, 3] - boxes[b, 0]
    e1 = boxes[b, 4] - boxes[b, 1]
    e2 = boxes[b, 5] - boxes[b, 2]
    if not (math.isfinite(e0) and math.isfinite(e1) and math.isfinite(e2)):
        return np.inf
    best = 0.0
    for s1 in (-1.0, 1.0):
        for s2 in (-1.0, 1.0):
            d = 0.0
            for r in range(3):
                c = (F[f, M0 + 3 * r] * e0 + s1 * F[f, M0 + 3 * r + 1] * e1
                     + s2 * F[f, M0 + 3 * r + 2] * e2)
                d += c * c
            best = max(best, d)
    return math.sqrt(best)


@inline
def footprint_scale(F, f, dx, dy, dz, dnorm):
    """The object units of one world unit of a ray's footprint in frame f, whose map M
    takes the object to the world: 1 / (M's largest singular value), bounded here from
    above by the rows of M^T M (so the threshold is never too large). The object
    direction d of a world direction of length dnorm gave |d| / dnorm, the stretch along
    the ray only: where M stretches the object across the ray more than along it (the
    QA's scale(3, 0.5, 1) julia seen along y), the surface was taken that much farther
    off, 3 to 4 pixels fatter each side. Where M is uniform (a turn and one scale) the
    two agree but for rounding, and the stretch along the ray is kept, bit for bit."""
    m0, m1, m2 = F[f, M0], F[f, M0 + 1], F[f, M0 + 2]
    m3, m4, m5 = F[f, M0 + 3], F[f, M0 + 4], F[f, M0 + 5]
    m6, m7, m8 = F[f, M0 + 6], F[f, M0 + 7], F[f, M0 + 8]
    a00 = m0 * m0 + m3 * m3 + m6 * m6
    a11 = m1 * m1 + m4 * m4 + m7 * m7
    a22 = m2 * m2 + m5 * m5 + m8 * m8
    a01 = abs(m0 * m1 + m3 * m4 + m6 * m7)
    a02 = abs(m0 * m2 + m3 * m5 + m6 * m8)
    a12 = abs(m1 * m2 + m4 * m5 + m7 * m8)
    largest = max(a00 + a01 + a02, a01 + a11 + a12, a02 + a12 + a22)
    dd = math.sqrt(dx * dx + dy * dy + dz * dz)
    across = 1.0 / math.sqrt(largest)
    return across * dnorm if across < dd / dnorm * (1.0 - 1e-9) else dd
