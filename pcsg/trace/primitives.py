"""Ray / primitive intersection in the primitive's object frame (notation §5),
njit so that the graph tracer and the Python reference compute the same hits.

``intersect(code, ox, oy, oz, dx, dy, dz, out)`` intersects the whole LINE
p(t) = o + t d (t from -inf to +inf; d need not be normalised and may have zero
or tiny components) with primitive ``code`` and writes into ``out`` (float64,
at least 8 long):

    out[0] = t_in, out[1] = t_out,
    out[2:5] = outward normal at t_in, out[5:8] = outward normal at t_out

(object frame, not normalised).  It returns False when the line misses (``out``
is then unspecified).

Solids are closed convex sets (the plane is the half-space z <= 0), so the part
of the line inside is one closed interval; a grazing line may give t_in ==
t_out.  Unbounded ends are -inf / +inf with the normal (0, 0, 1) (the plane's).
A zero direction gives (-inf, +inf) if o is inside, else a miss.  Non-finite
input is a miss.

Flat triangles (tri1, tri2) give one t: out[0] = out[1] = t and both normals
(0, 0, 1); the consumer orients it.  A line parallel to the triangle's plane
misses.  The inside test is inclusive with a tolerance of ``EDGE_EPS`` in the
triangle's own coordinates, the same ``>=`` test on every edge, so that two
triangles that share an edge leave no gap even when their frames round
differently.

Nothing allocates, raises or recurses (error_model='numpy': a division by zero
gives inf; every place where 0 * inf could appear is tested before).
"""
from __future__ import annotations

import math

import numpy as np

from ..language.names import FLAT_PRIMITIVES, PRIMITIVES
from .fractals import bound_radius
from .jit import kernel as _jit

CODES = {name: i for i, name in enumerate(PRIMITIVES)}
SPHERE, CUBE, CYLINDER, CONE, TETRAHEDRON, PLANE, TRI1, TRI2, MANDELBULB, JULIA = (
    CODES[n] for n in ("sphere", "cube", "cylinder", "cone", "tetrahedron", "plane", "tri1",
                       "tri2", "mandelbulb", "julia"))
FLAT = frozenset(CODES[n] for n in FLAT_PRIMITIVES)      # {TRI1, TRI2}
FRACTAL_MIN = MANDELBULB      # codes from here on are fractals (trace/fractals.py)
UNION_ONLY = FLAT | {MANDELBULB, JULIA}                   # a surface, not an interval

EDGE_EPS = 1e-12     # inclusive tolerance of the triangle edge tests (object frame)

_INF = math.inf

# object-frame bounding boxes (xmin, ymin, zmin, xmax, ymax, zmax), by code
BOXES = np.array([
    [-1.0, -1.0, -1.0, 1.0, 1.0, 1.0],          # sphere
    [-1.0, -1.0, -1.0, 1.0, 1.0, 1.0],          # cube
    [-1.0, -1.0, 0.0, 1.0, 1.0, 1.0],           # cylinder
    [-1.0, -1.0, 0.0, 1.0, 1.0, 1.0],           # cone
    [-1.0, -1.0, -1.0, 1.0, 1.0, 1.0],          # tetrahedron
    [-_INF, -_INF, -_INF, _INF, _INF, 0.0],     # plane
    [0.0, 0.0, 0.0, 1.0, 1.0, 0.0],             # tri1
    [-1.0, -1.0, 0.0, 0.0, 0.0, 0.0],           # tri2
    [-_INF, -_INF, -_INF, _INF, _INF, _INF],    # mandelbulb, julia: their arguments
    [-_INF, -_INF, -_INF, _INF, _INF, _INF],    #   decide (object_box)
])
BOXES.setflags(write=False)

# tetrahedron corners; the solid is {p : -v.p <= 1 for every corner v}, the
# face opposite v having the outward normal -v
TETRA_CORNERS = np.array([[1.0, 1.0, 1.0], [-1.0, -1.0, 1.0], [1.0, -1.0, -1.0],
                          [-1.0, 1.0, -1.0]])
TETRA_CORNERS.setflags(write=False)


# the corners of the primitives that are polytopes (HULL_COUNT of them, by code; 0 for
# the others): a primitive's box under a map is the box of its mapped corners, exact,
# where its object box's image is not (a sheared triangle's box reached the height of
# the corner (1, 1) it does not have: the terrain's patches were 1.3 times too tall)
HULL = np.zeros((len(PRIMITIVES), 4, 3))
HULL_COUNT = np.zeros(len(PRIMITIVES), dtype=np.int64)
for _code, _corners in ((TRI1, [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
                        (TRI2, [[0.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]),
                        (TETRAHEDRON, TETRA_CORNERS)):
    HULL[_code, :len(_corners)] = _corners
    HULL_COUNT[_code] = len(_corners)
HULL.setflags(write=False)
HULL_COUNT.setflags(write=False)


def hull(code: int) -> np.ndarray | None:
    """The corners (k, 3) of a polytope primitive, None for the others."""
    return HULL[code, :HULL_COUNT[code]].copy() if HULL_COUNT[code] else None


def box(code: int) -> np.ndarray:
    """The object-frame bounding box (xmin, ymin, zmin, xmax, ymax, zmax) of a primitive."""
    return BOXES[code].copy()


def object_box(name: str, args=()) -> np.ndarray:
    """box() for a primitive with its arguments: a fractal's box holds its bounding ball."""
    if CODES[name] >= FRACTAL_MIN:
        r = bound_radius(name, args)
        return np.array([-r, -r, -r, r, r, r])
    return box(CODES[name])


# ---- building blocks: out[0:2] is the running interval, out[2:8] its normals ----

@_jit
def _start(out):
    out[0] = -_INF
    out[1] = _INF
    out[2] = 0.0
    out[3] = 0.0
    out[4] = 1.0
    out[5] = 0.0
    out[6] = 0.0
    out[7] = 1.0


@_jit
def _enter(out, t, nx, ny, nz):
    """Intersect the running interval with [t, inf)."""
    if t > out[0]:
        out[0] = t
        out[2] = nx
        out[3] = ny
        out[4] = nz


@_jit
def _leave(out, t, nx, ny, nz):
    """Intersect the running interval with (-inf, t]."""
    if t < out[1]:
        out[1] = t
        out[5] = nx
        out[6] = ny
        out[7] = nz


@_jit
def _halfspace(out, nx, ny, nz, h, ox, oy, oz, dx, dy, dz):
    """Intersect with the half-space n.p <= h (outward normal n). False if the
    line lies entirely outside it."""
    nd = nx * dx + ny * dy + nz * dz
    no = nx * ox + ny * oy + nz * oz
    if nd == 0.0:
        return no <= h
    t = (h - no) / nd
    if nd > 0.0:
        _leave(out, t, nx, ny, nz)
    else:
        _enter(out, t, nx, ny, nz)
    return True


# ---- the primitives ------------------------------------------------------------

@_jit
def _roots(a, b, c, disc):
    """Sorted roots of a t^2 + 2 b t + c with disc = b^2 - a c >= 0, without cancellation."""
    q = -(b + math.copysign(math.sqrt(disc), b))
    if q == 0.0:
        return True, 0.0, 0.0
    r1 = q / a
    r2 = c / q
    if r1 > r2:
        r1, r2 = r2, r1
    return r1 <= r2, r1, r2                      # False for nan


@_jit
def _sphere(out, ox, oy, oz, dx, dy, dz):
    a = dx * dx + dy * dy + dz * dz
    c = ox * ox + oy * oy + oz * oz - 1.0
    if a == 0.0:
        return c <= 0.0
    b = ox * dx + oy * dy + oz * dz
    # b^2 - a c = |d|^2 - |o x d|^2 (Lagrange's identity), free of cancellation
    cx = oy * dz - oz * dy
    cy = oz * dx - ox * dz
    cz = ox * dy - oy * dx
    disc = a - (cx * cx + cy * cy + cz * cz)
    if not (disc >= 0.0):                        # also nan (overflow far away)
        return False
    ok, r1, r2 = _roots(a, b, c, disc)
    if not ok:
        return False
    _enter(out, r1, ox + r1 * dx, oy + r1 * dy, oz + r1 * dz)
    _leave(out, r2, ox + r2 * dx, oy + r2 * dy, oz + r2 * dz)
    return True


@_jit
def _cube(out, ox, oy, oz, dx, dy, dz):
    if not _halfspace(out, 1.0, 0.0, 0.0, 1.0, ox, oy, oz, dx, dy, dz):
        return False
    if not _halfspace(out, -1.0, 0.0, 0.0, 1.0, ox, oy, oz, dx, dy, dz):
        return False
    if not _halfspace(out, 0.0, 1.0, 0.0, 1.0, ox, oy, oz, dx, dy, dz):
        return False
    if not _halfspace(out, 0.0, -1.0, 0.0, 1.0, ox, oy, oz, dx, dy, dz):
        return False
    if not _halfspace(out, 0.0, 0.0, 1.0, 1.0, ox, oy, oz, dx, dy, dz):
        return False
    if not _halfspace(out, 0.0, 0.0, -1.0, 1.0, ox, oy, oz, dx, dy, dz):
        return False
    return out[0] <= out[1]


@_jit
def _tetrahedron(out, ox, oy, oz, dx, dy, dz):
    # -v.p <= 1 for v = (1,1,1), (-1,-1,1), (1,-1,-1), (-1,1,-1)
    if not _halfspace(out, -1.0, -1.0, -1.0, 1.0, ox, oy, oz, dx, dy, dz):
        return False
    if not _halfspace(out, 1.0, 1.0, -1.0, 1.0, ox, oy, oz, dx, dy, dz):
        return False
    if not _halfspace(out, -1.0, 1.0, 1.0, 1.0, ox, oy, oz, dx, dy, dz):
        return False
    if not _halfspace(out, 1.0, -1.0, 1.0, 1.0, ox, oy, oz, dx, dy, dz):
        return False
    return out[0] <= out[1]


@_jit
def _unit_slab(out, ox, oy, oz, dx, dy, dz):
    """Intersect with the slab 0 <= z <= 1: the caps of the cylinder and the cone."""
    return (_halfspace(out, 0.0, 0.0, 1.0, 1.0, ox, oy, oz, dx, dy, dz)
            and _halfspace(out, 0.0, 0.0, -1.0, 0.0, ox, oy, oz, dx, dy, dz))


@_jit
def _cylinder(out, ox, oy, oz, dx, dy, dz):
    if not _unit_slab(out, ox, oy, oz, dx, dy, dz):
        return False
    a = dx * dx + dy * dy
    c = ox * ox + oy * oy - 1.0
    if a == 0.0:                                 # parallel to the axis
        if c > 0.0:
            return False
    else:
        b = ox * dx + oy * dy
        cr = ox * dy - oy * dx
        disc = a - cr * cr                       # = b^2 - a c
        if not (disc >= 0.0):
            return False
        ok, r1, r2 = _roots(a, b, c, disc)
        if not ok:
            return False
        _enter(out, r1, ox + r1 * dx, oy + r1 * dy, 0.0)
        _leave(out, r2, ox + r2 * dx, oy + r2 * dy, 0.0)
    return out[0] <= out[1]


@_jit
def _cone_normal(x, y, z):
    """Outward normal of the lateral surface x^2 + y^2 = (1 - z)^2: the gradient
    (x, y, 1 - z); the apex (where it vanishes) gets (0, 0, 1)."""
    w = 1.0 - z
    if x == 0.0 and y == 0.0 and w == 0.0:
        return 0.0, 0.0, 1.0
    return x, y, w


@_jit
def _cone(out, ox, oy, oz, dx, dy, dz):
    # the cone is {x^2 + y^2 <= (1 - z)^2} (a double cone, apex (0,0,1)) cut by
    # the slab 0 <= z <= 1, which also picks the lower nappe
    if not _unit_slab(out, ox, oy, oz, dx, dy, dz):
        return False
    s0 = out[0]                      # the slab interval
    s1 = out[1]
    if s0 > s1:
        return False
    # the quadratic is solved from the ray's point nearest the frame's origin, t measured
    # from there (tc): from the origin itself, B^2 - A C cancelled to nothing where the
    # origin was far, and a cone seen side on from 6e8 away (scale(1e-8, 1, 1) cone,
    # 6 units from the camera) was drawn as its bounding rectangle (QA)
    dd = dx * dx + dy * dy + dz * dz
    tc = -(ox * dx + oy * dy + oz * dz) / dd if dd > 0.0 else 0.0
    px = ox + tc * dx
    py = oy + tc * dy
    w0 = 1.0 - (oz + tc * dz)
    # f(tc + u) = |xy|^2 - w^2 = A u^2 + 2 B u + C, w(u) = w0 - u dz
    A = dx * dx + dy * dy - dz * dz
    B = px * dx + py * dy + w0 * dz
    C = px * px + py * py - w0 * w0
    # {f <= 0} is up to two pieces [p0, p1], [p2, p3]
    n = 0
    p0 = -_INF
    p1 = _INF
    p2 = -_INF
    p3 = _INF
    if A == 0.0:
        if B == 0.0:
            if C > 0.0:
                return False
            n = 1                                    # the whole line
        else:
            r = -C / (2.0 * B)
            if r != r:
                return False
            n = 1
            if B > 0.0:
                p1 = r
            else:
                p0 = r
    else:
        disc = B * B - A * C
        if disc != disc:                             # nan: overflow far away
            return False
        if disc < 0.0:
            if A > 0.0:
                return False
            n = 1                                    # f < 0 everywhere (rounding)
        else:
            sq = math.sqrt(disc)
            q = -(B + math.copysign(sq, B))
            if q == 0.0:
                r1 = 0.0
                r2 = 0.0
            else:
                r1 = q / A
                r2 = C / q
                if r1 > r2:
                    r1, r2 = r2, r1
                if not (r1 <= r2):               # nan
                    return False
            if A > 0.0:
                n = 1
                p0 = r1
                p1 = r2
            else:
                n = 2
                p1 = r1
                p2 = r2
    p0 += tc
    p1 += tc
    p2 += tc
    p3 += tc
    # each piece clipped to the slab; the hull of the non-empty ones (the result
    # is convex, so it is their union)
    tin = _INF
    tout = -_INF
    inx = 0.0
    iny = 0.0
    inz = 1.0
    outx = 0.0
    outy = 0.0
    outz = 1.0
    for k in range(n):
        a0 = p0 if k == 0 else p2
        a1 = p1 if k == 0 else p3
        lo = a0 if a0 > s0 else s0
        hi = a1 if a1 < s1 else s1
        if not (lo <= hi):
            continue
        if lo < tin:
            tin = lo
            if a0 > s0:
                inx, iny, inz = _cone_normal(ox + lo * dx, oy + lo * dy, oz + lo * dz)
            else:
                inx, iny, inz = out[2], out[3], out[4]
        if hi > tout:
            tout = hi
            if a1 < s1:
                outx, outy, outz = _cone_normal(ox + hi * dx, oy + hi * dy, oz + hi * dz)
            else:
                outx, outy, outz = out[5], out[6], out[7]
    if not (tin <= tout):
        return False
    out[0] = tin
    out[1] = tout
    out[2] = inx
    out[3] = iny
    out[4] = inz
    out[5] = outx
    out[6] = outy
    out[7] = outz
    return True


@_jit
def _triangle(out, code, ox, oy, oz, dx, dy, dz):
    if dz == 0.0:
        return False
    t = -oz / dz
    if not (abs(t) < _INF):
        return False
    x = ox + t * dx
    y = oy + t * dy
    if code == TRI2:
        x = -x
        y = -y
    # tri1: x >= 0, y >= 0, x + y <= 1 (tri2 is tri1 turned by 180 degrees about z)
    if not (x >= -EDGE_EPS and y >= -EDGE_EPS and 1.0 - x - y >= -EDGE_EPS):
        return False
    _start(out)                 # both normals (0, 0, 1)
    out[0] = t
    out[1] = t
    return True


@_jit
def intersect(code, ox, oy, oz, dx, dy, dz, out):
    """Intersect the line o + t d (all t) with primitive `code` in its object
    frame; see the module docstring for the layout of `out`. Fractals are marched
    instead (fractals.march); here they miss."""
    if not (abs(ox) < _INF and abs(oy) < _INF and abs(oz) < _INF
            and abs(dx) < _INF and abs(dy) < _INF and abs(dz) < _INF):
        return False
    if code == TRI1 or code == TRI2:
        return _triangle(out, code, ox, oy, oz, dx, dy, dz)
    # scale d to a largest component of magnitude 1 so that tiny or huge
    # directions neither underflow nor overflow in the quadratics; t scales back
    s = max(abs(dx), abs(dy), abs(dz))
    if s == 0.0:
        s = 1.0
    ex = dx / s
    ey = dy / s
    ez = dz / s
    _start(out)
    if code == SPHERE:
        hit = _sphere(out, ox, oy, oz, ex, ey, ez)
    elif code == CUBE:
        hit = _cube(out, ox, oy, oz, ex, ey, ez)
    elif code == CYLINDER:
        hit = _cylinder(out, ox, oy, oz, ex, ey, ez)
    elif code == CONE:
        hit = _cone(out, ox, oy, oz, ex, ey, ez)
    elif code == TETRAHEDRON:
        hit = _tetrahedron(out, ox, oy, oz, ex, ey, ez)
    elif code == PLANE:
        hit = _halfspace(out, 0.0, 0.0, 1.0, 0.0, ox, oy, oz, ex, ey, ez)
    else:
        return False
    if not hit or not (out[0] <= out[1]):
        return False
    out[0] = out[0] / s
    out[1] = out[1] / s
    return True
