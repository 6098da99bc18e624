"""A pinhole camera: #camera in the file, overridden by options, or framed
automatically on the object's bounding box. z is up."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..trace.dispatch import cached_jit
from ..graph.model import CALC, MATERIAL, PAINT, UNION
from ..scene import DEFAULT_FOV, DEFAULT_UP, FARTHEST, camera_degenerate

DEFAULT_DIRECTION = np.array([1.0, -1.6, 0.9])      # from the front right, a little above




def _unit(v: np.ndarray) -> tuple[np.ndarray, float]:
    """v's direction and length, v scaled by its largest component first: the sum of
    squares of an eye 1e-200 from at underflowed to 0 (a picture of NaN, all black), of
    one 1e300 away overflowed (with numpy's warning). v is not zero."""
    scale = float(np.abs(v).max())
    w = v / scale
    n = float(np.sqrt(w @ w))
    return w / n, scale * n         # Python's product: inf without a warning


class CameraError(ValueError):
    """A camera that cannot be placed: its eye on the point it looks at, its up along
    its view, or not finite (an object too large to frame)."""


@dataclass
class Camera:
    eye: np.ndarray
    at: np.ndarray
    up: np.ndarray
    fov: float              # vertical field of view, degrees

    def basis(self):
        for name, v in (("eye", self.eye), ("at", self.at), ("up", self.up)):
            if not np.all(np.isfinite(v)):
                raise CameraError(f"the camera's {name} is not finite: {_point(v)}")
        what = camera_degenerate(self.eye, self.at, self.up)
        if what == "same":
            raise CameraError(f"the camera's eye and at are the same point {_point(self.eye)}")
        if what == "zero":
            raise CameraError("the camera's up is (0, 0, 0), no direction: give one such as "
                              "0,0,1")
        if what == "parallel":
            raise CameraError(f"the camera's up {_point(self.up)} is parallel to its "
                              f"viewing direction: give another up")
        if what == "far":
            raise CameraError(f"the camera's eye is too far from at (at most {FARTHEST:g} "
                              f"apart)")
        fwd = _unit(np.asarray(self.at, dtype=np.float64) -
                    np.asarray(self.eye, dtype=np.float64))[0]
        right = _unit(np.cross(fwd, _unit(np.asarray(self.up, dtype=np.float64))[0]))[0]
        return fwd, right, np.cross(right, fwd)

    def rays(self, width: int, height: int, sx: np.ndarray, sy: np.ndarray):
        """Rays through image positions (sx, sy) in pixels (0,0 = top left corner);
        unit directions, so t is a distance."""
        fwd, right, up = self.basis()
        sx = np.ascontiguousarray(sx, dtype=np.float64)
        sy = np.ascontiguousarray(sy, dtype=np.float64)
        o = np.empty((len(sx), 3))
        d = np.empty((len(sx), 3))
        _rays(np.asarray(self.eye, dtype=np.float64), fwd, right, up,
              math.tan(math.radians(self.fov) / 2),
              width, height, sx, sy, o, d)
        return o, d

    def pixel_angle(self, height: int) -> float:
        """The angle one pixel subtends: the level-of-detail footprint."""
        return math.radians(self.fov) / height


@cached_jit(error_model="numpy", nogil=True)
def _rays(eye, fwd, right, up, half, width, height, sx, sy, o, d):
    """Camera.rays in one pass: numpy's temporaries took 2 ms of every 30,000 rays. The
    same operations in the same order as the numpy it replaced (the squares summed
    left to right), so the same bits."""
    for i in range(sx.shape[0]):
        u = (2 * sx[i] / width - 1) * half * width / height
        v = (1 - 2 * sy[i] / height) * half
        x = fwd[0] + u * right[0] + v * up[0]
        y = fwd[1] + u * right[1] + v * up[1]
        z = fwd[2] + u * right[2] + v * up[2]
        n = math.sqrt((x * x + y * y) + z * z)
        d[i, 0] = x / n
        d[i, 1] = y / n
        d[i, 2] = z / n
        o[i, 0] = eye[0]
        o[i, 1] = eye[1]
        o[i, 2] = eye[2]


def finite_bounds(traced) -> np.ndarray:
    """The object's box without infinite parts (a ground plane): the root's box where it
    is finite, else the memoised walk's without them (bounds.finite_root), else the union
    of the finite boxes of the root's operands, else [-1, 1]^3. The root's own box first:
    a node below a calculation block bounds every instance of it, and the root's only the
    one the axiom derives (a system's box by its states)."""
    g, boxes = traced.graph, traced.boxes
    node = g.root
    if not _finite(boxes[node]) and traced.bounds_method == "memoised":
        from ..graph.bounds import finite_root
        found = finite_root(g)
        if found is not None:
            return found
    candidates = [node]
    while not _finite(boxes[node]) and g.nodes[node].kind in (CALC, PAINT, MATERIAL):
        node = g.nodes[node].children[0]        # the same frame below these
        candidates.append(node)
    if not _finite(boxes[node]) and g.nodes[node].kind == UNION:
        candidates += g.nodes[node].children
    finite = [boxes[i] for i in candidates if _finite(boxes[i])]
    if not finite:
        return np.array([-1.0, -1.0, -1.0, 1.0, 1.0, 1.0])
    f = np.array(finite)
    return np.concatenate([f[:, :3].min(axis=0), f[:, 3:].max(axis=0)])


def _finite(box) -> bool:
    return bool(np.all(np.isfinite(box)) and box[0] <= box[3])


def _point(v) -> str:
    return "(" + ", ".join(f"{float(x):g}" for x in v) + ")"


def make_camera(traced, aspect: float, eye=None, at=None, up=None, fov=None) -> Camera:
    """Options first, then #camera, then framing the object's box. Raises CameraError
    for an object too large to frame; Camera.basis tells whether the camera can look."""
    file = traced.graph.scene.camera
    up = np.asarray(up if up is not None else file.get("up", DEFAULT_UP), float)
    fov = float(fov if fov is not None else file.get("fov", DEFAULT_FOV))
    at = at if at is not None else file.get("at")
    eye = eye if eye is not None else file.get("eye")
    # only where the view is not given: finite_bounds may walk the system once more
    box = finite_bounds(traced) if at is None or eye is None else None
    at = np.asarray(at if at is not None else (box[:3] + box[3:]) / 2, float)
    if eye is None:
        with np.errstate(over="ignore", invalid="ignore"):     # a box too large: below
            radius = np.linalg.norm(box[3:] - box[:3]) / 2
        # a point's box: some size to frame. Not a floor under every radius: an object
        # smaller than it (uscale(1e-10) sphere) was framed too far away
        radius = 1e-9 if radius <= 0 else radius
        half = math.radians(fov) / 2
        fit = radius / math.sin(min(half, half * aspect)) * 1.08
        eye = at + DEFAULT_DIRECTION / np.linalg.norm(DEFAULT_DIRECTION) * fit
        if not (np.all(np.isfinite(eye)) and np.all(np.isfinite(at))):
            raise CameraError(f"the object's box {_point(box[:3])} to {_point(box[3:])} is "
                              f"too large to frame: place the camera with #camera eye=... "
                              f"at=... (or --eye and --at)")
    return Camera(np.asarray(eye, float), at, up, fov)
