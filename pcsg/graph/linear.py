"""Which maps empty an instance, one test for every walk. The tracer tests a T-node's
map by the determinant of its linear part from cofactors (trace/nodes.py singular_map);
numpy's LU gives -7.1e-15 for matrix(1,2,3,4, 5,6,7,8, 9,10,11,12), whose cofactors give
0, and meets an exact zero pivot where the cofactors are not 0 (a flat map's product with
turns below it). A map is taken as invertible where both say so; LU still inverts
(its inverse of scale(1e-160, 1e-160, 1) is finite, 1/det of the cofactors is not)."""
from __future__ import annotations

import math

import numpy as np


# the faults of a map that empty its instance, in every walk and in the tracer (as
# trace/boxwalk.py counts them)
NONFINITE, SINGULAR = 0, 1


def map_fault(m: np.ndarray) -> int | None:
    """NONFINITE or SINGULAR where the map m empties its instance, else None."""
    if not np.isfinite(m).all():
        return NONFINITE
    return SINGULAR if singular(m) else None


def singular(m: np.ndarray) -> bool:
    """Whether one map's linear part is singular or its determinant not finite, by the
    cofactors: the bounding walks empty such an instance. Python's floats: inf without a
    warning, and quicker than numpy's for one map."""
    (a, b, c), (d, e, g), (p, q, r) = np.asarray(m)[:3, :3].tolist()
    det = a * (e * r - g * q) + b * (g * p - d * r) + c * (d * q - e * p)
    return not (det != 0.0 and math.isfinite(det))


def determinants(a: np.ndarray) -> np.ndarray:
    """Of the linear part of each map of (..., 3, >=3), by the cofactors in the tracer's
    order."""
    (x, y, z), (d, e, g), (p, q, r) = np.moveaxis(np.asarray(a, float)[..., :3, :3],
                                                 (-2, -1), (0, 1))
    with np.errstate(all="ignore"):
        return x * (e * r - g * q) + y * (g * p - d * r) + z * (d * q - e * p)


def flat(m: np.ndarray) -> bool:
    """Whether one map's cofactor determinant is exactly 0: the map itself is singular
    (a zero scale), whatever the product it joins comes to by rounding."""
    return bool(determinants(m) == 0.0)


def invertible(a: np.ndarray) -> np.ndarray:
    """Whether each map of (..., 3, >=3) is finite with a non-zero finite determinant of
    its linear part by LU and non-zero by the cofactors."""
    a = np.asarray(a, float)
    ok = np.isfinite(a).all(axis=(-2, -1))
    lin = np.where(ok[..., None, None], a[..., :3, :3], 0.0)
    with np.errstate(all="ignore"):
        lu = np.linalg.det(lin)
    return ok & (lu != 0.0) & np.isfinite(lu) & (determinants(lin) != 0.0)
