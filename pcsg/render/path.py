"""A camera path as a Bezier control polygon, evaluated by de Casteljau's algorithm
(as Hong & Kook move their camera): the curve starts at the first control point, ends at
the last, and is pulled towards the ones between."""
from __future__ import annotations

import math
import re

import numpy as np


def parse_points(text: str) -> np.ndarray:
    """'X,Y,Z X,Y,Z ...' (points separated by spaces or ';') as a (k, 3) array."""
    points = []
    for item in re.split(r"[\s;]+", text.strip()):
        if not item:
            continue
        parts = item.split(",")
        try:
            values = [float(v) for v in parts]
        except ValueError:
            values = []
        if len(values) != 3 or not all(math.isfinite(v) for v in values):
            raise ValueError(f"'{item}' is not a point X,Y,Z")
        points.append(values)
    if not points:
        raise ValueError("no points: give the control polygon as 'X,Y,Z X,Y,Z ...'")
    return np.array(points, float)


def bezier(points: np.ndarray, s: float) -> np.ndarray:
    """The point at parameter s in [0, 1] of the Bezier curve of `points`."""
    p = np.array(points, float)
    for k in range(len(p) - 1, 0, -1):
        p[:k] = (1 - s) * p[:k] + s * p[1:k + 1]
    return p[0]
