"""A pinhole camera: #camera in the file, overridden by options, or framed
automatically on the object's bounding box. z is up."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..graph.model import CALC, MATERIAL, PAINT, UNION

DEFAULT_DIRECTION = np.array([1.0, -1.6, 0.9])      # from the front right, a little above
DEFAULT_FOV = 35.0


@dataclass
class Camera:
    eye: np.ndarray
    at: np.ndarray
    up: np.ndarray
    fov: float              # vertical field of view, degrees

    def basis(self):
        fwd = self.at - self.eye
        norm = np.linalg.norm(fwd)
        if not norm > 0:
            raise ValueError("the camera's eye and at are the same point")
        fwd = fwd / norm
        right = np.cross(fwd, self.up)
        if np.linalg.norm(right) < 1e-12:
            raise ValueError("the camera's up is parallel to its viewing direction")
        right /= np.linalg.norm(right)
        return fwd, right, np.cross(right, fwd)

    def rays(self, width: int, height: int, sx: np.ndarray, sy: np.ndarray):
        """Rays through image positions (sx, sy) in pixels (0,0 = top left corner);
        unit directions, so t is a distance."""
        fwd, right, up = self.basis()
        half = math.tan(math.radians(self.fov) / 2)
        u = (2 * sx / width - 1) * half * width / height
        v = (1 - 2 * sy / height) * half
        d = fwd + u[:, None] * right + v[:, None] * up
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        return np.broadcast_to(self.eye, d.shape).copy(), d

    def pixel_angle(self, height: int) -> float:
        """The angle one pixel subtends: the level-of-detail footprint."""
        return math.radians(self.fov) / height


def finite_bounds(traced) -> np.ndarray:
    """The object's box without infinite parts (a ground plane): the union of the
    finite boxes of the root's operands, else [-1, 1]^3."""
    g, boxes = traced.graph, traced.boxes
    node = g.root
    candidates = [node]
    while g.nodes[node].kind in (CALC, PAINT, MATERIAL):    # same frame below these
        node = g.nodes[node].children[0]
        candidates.append(node)
    if g.nodes[node].kind == UNION:
        candidates += g.nodes[node].children
    finite = [boxes[i] for i in candidates if np.all(np.isfinite(boxes[i])) and
              boxes[i][0] <= boxes[i][3]]
    if not finite:
        return np.array([-1.0, -1.0, -1.0, 1.0, 1.0, 1.0])
    f = np.array(finite)
    return np.concatenate([f[:, :3].min(axis=0), f[:, 3:].max(axis=0)])


def make_camera(traced, aspect: float, eye=None, at=None, up=None, fov=None) -> Camera:
    """Options first, then #camera, then framing the object's box."""
    file = traced.graph.scene.camera
    up = np.asarray(up if up is not None else file.get("up", (0.0, 0.0, 1.0)), float)
    fov = float(fov if fov is not None else file.get("fov", DEFAULT_FOV))
    box = finite_bounds(traced)
    centre = (box[:3] + box[3:]) / 2
    at = np.asarray(at if at is not None else file.get("at", centre), float)
    eye = eye if eye is not None else file.get("eye")
    if eye is None:
        radius = max(np.linalg.norm(box[3:] - box[:3]) / 2, 1e-9)
        half = math.radians(fov) / 2
        fit = radius / math.sin(min(half, half * aspect)) * 1.08
        eye = at + DEFAULT_DIRECTION / np.linalg.norm(DEFAULT_DIRECTION) * fit
    return Camera(np.asarray(eye, float), at, up, fov)
