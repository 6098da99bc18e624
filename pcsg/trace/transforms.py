"""T-node matrices (notation §4), njit so that the tracer and the Python side
(expand, bounds, the reference) compute bit-identical maps."""
from __future__ import annotations

import math

import numpy as np

from ..language.names import TRANSFORMS
from .jit import kernel

CODES = {name: i for i, name in enumerate(TRANSFORMS)}
(MOVE, SCALE, USCALE, ROTX, ROTY, ROTZ, ROT, ZSHEAR, XSHEAR, YSHEAR,
 FLIPXY, FLIPXZ, FLIPYZ, MIRROR, MATRIX) = range(len(TRANSFORMS))


@kernel
def _fill(m, v):
    for i in range(m.shape[0]):
        for j in range(m.shape[1]):
            m[i, j] = v


@kernel
def _rotation(m, deg, ax, ay, az):
    n = math.sqrt(ax * ax + ay * ay + az * az)
    if not (n > 0.0):
        _fill(m, np.nan)
        return
    ax, ay, az = ax / n, ay / n, az / n
    a = deg * math.pi / 180.0
    if math.isinf(a) and not math.isinf(deg):
        # rotz(1e308): its radians overflowed, and the turn emptied its operand as if its
        # axis were zero (QA); the same turn, less whole turns, as any angle is taken
        a = (deg % 360.0) * math.pi / 180.0
    c, s = math.cos(a), math.sin(a)
    t = 1.0 - c
    m[0, 0] = t * ax * ax + c
    m[0, 1] = t * ax * ay - s * az
    m[0, 2] = t * ax * az + s * ay
    m[1, 0] = t * ax * ay + s * az
    m[1, 1] = t * ay * ay + c
    m[1, 2] = t * ay * az - s * ax
    m[2, 0] = t * ax * az - s * ay
    m[2, 1] = t * ay * az + s * ax
    m[2, 2] = t * az * az + c


@kernel
def affine(code, a, m):
    """Write the 3x4 matrix [L | t] of transformation `code` with arguments `a` into `m`.
    A point p maps to L p + t. Invalid input (a zero rotation axis) gives nan."""
    _fill(m, 0.0)
    m[0, 0] = 1.0
    m[1, 1] = 1.0
    m[2, 2] = 1.0
    if code == MOVE:
        m[0, 3] = a[0]
        m[1, 3] = a[1]
        m[2, 3] = a[2]
    elif code == SCALE:
        m[0, 0] = a[0]
        m[1, 1] = a[1]
        m[2, 2] = a[2]
    elif code == USCALE:
        m[0, 0] = a[0]
        m[1, 1] = a[0]
        m[2, 2] = a[0]
    elif code == ROTX:
        _rotation(m, a[0], 1.0, 0.0, 0.0)
    elif code == ROTY:
        _rotation(m, a[0], 0.0, 1.0, 0.0)
    elif code == ROTZ:
        _rotation(m, a[0], 0.0, 0.0, 1.0)
    elif code == ROT:
        _rotation(m, a[0], a[1], a[2], a[3])
    elif code == ZSHEAR:
        m[2, 0] = a[0]
        m[2, 1] = a[1]
    elif code == XSHEAR:
        m[0, 1] = a[0]
        m[0, 2] = a[1]
    elif code == YSHEAR:
        m[1, 0] = a[0]
        m[1, 2] = a[1]
    elif code == FLIPXY:
        m[0, 0] = -1.0
        m[1, 1] = -1.0
    elif code == FLIPXZ:
        m[0, 0] = -1.0
        m[2, 2] = -1.0
    elif code == FLIPYZ:
        m[1, 1] = -1.0
        m[2, 2] = -1.0
    elif code == MIRROR:
        n2 = a[0] * a[0] + a[1] * a[1] + a[2] * a[2]
        if not (n2 > 0.0):
            _fill(m, np.nan)
            return
        for i in range(3):
            for j in range(3):
                m[i, j] -= 2.0 * a[i] * a[j] / n2
    elif code == MATRIX:
        for i in range(3):
            for j in range(4):
                m[i, j] = a[4 * i + j]


def matrix(name: str, args) -> np.ndarray:
    """The 4x4 homogeneous matrix of a transformation, for Python callers."""
    m = np.zeros((4, 4))
    m[3, 3] = 1.0
    # its rows written in place: np.vstack was most of a call, which `check` makes for
    # every constant map (87,000 of an expanded Sierpinski at 7)
    affine(CODES[name], np.asarray(args, dtype=np.float64).reshape(-1) if len(args) else
           np.zeros(1), m[:3])
    return m
