"""3x3 determinants and inverses by cofactors, in the order the tracer computes them
(trace/nodes.py singular_map, transform_map), for every part of pcsg that decides
whether a map empties an instance. numpy's LU gives -7.1e-15 for the linear part of
matrix(1,2,3,4, 5,6,7,8, 9,10,11,12), where the cofactors give 0, and meets an exact
zero pivot where the cofactors do not give 0: one test for all of them keeps check,
render, the reference and export drawing the same instances."""
from __future__ import annotations

import math

import numpy as np


def singular(m: np.ndarray) -> bool:
    """Whether one map's linear part is singular or its determinant not finite (the
    instance under it is empty). Python's floats: inf without a warning, and quicker than
    numpy's for one map."""
    (a, b, c), (d, e, g), (p, q, r) = np.asarray(m)[:3, :3].tolist()
    det = a * (e * r - g * q) + b * (g * p - d * r) + c * (d * q - e * p)
    return not (det != 0.0 and math.isfinite(det))


def determinants(a: np.ndarray) -> np.ndarray:
    """Of each 3x3 of (..., 3, 3)."""
    (x, y, z), (d, e, g), (p, q, r) = np.moveaxis(np.asarray(a, float)[..., :3, :3],
                                                 (-2, -1), (0, 1))
    with np.errstate(all="ignore"):
        return x * (e * r - g * q) + y * (g * p - d * r) + z * (d * q - e * p)


def invertible(a: np.ndarray) -> np.ndarray:
    """Whether each map of (..., 3, >=3) is finite with a non-zero finite determinant of
    its linear part (an instance under any other map is empty)."""
    a = np.asarray(a, float)
    det = determinants(a)
    return np.isfinite(a).all(axis=(-2, -1)) & (det != 0.0) & np.isfinite(det)


def inverses(a: np.ndarray) -> np.ndarray:
    """The inverse of each 3x3 linear part of (..., 3, >=3): the transposed cofactors
    over the determinant (not finite where the map is not invertible)."""
    (x, y, z), (d, e, g), (p, q, r) = np.moveaxis(np.asarray(a, float)[..., :3, :3],
                                                 (-2, -1), (0, 1))
    with np.errstate(all="ignore"):
        c00, c01, c02 = e * r - g * q, g * p - d * r, d * q - e * p
        inv = 1.0 / (x * c00 + y * c01 + z * c02)
        rows = [[c00, z * q - y * r, y * g - z * e],
                [c01, x * r - z * p, z * d - x * g],
                [c02, y * p - x * q, x * e - y * d]]
        return np.moveaxis(np.array(rows) * inv, (0, 1), (-2, -1))


def affine_inverses(m: np.ndarray) -> np.ndarray:
    """The 4x4 inverse of each affine map of (..., 3 or 4, 4): [L^-1 | -L^-1 t]."""
    m = np.asarray(m, float)
    lin = inverses(m)
    out = np.zeros(m.shape[:-2] + (4, 4))
    out[..., :3, :3] = lin
    with np.errstate(all="ignore"):
        out[..., :3, 3] = -np.einsum("...ij,...j->...i", lin, m[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out
