"""Fractals given by a distance estimate (Hart, Sandin & Kauffman; Hong & Kook):
`mandelbulb(power)` and `julia(cx, cy, cz, cw)` (the quaternion Julia set of
q -> q^2 + c, the slice k = 0), sphere-traced in their object frame.

Both sets lie in a ball of radius R that follows from their arguments (see
`bound_radius`): outside it every orbit escapes. A line is marched from where it
enters that ball (or from tmin, if later) by steps of the distance estimate,
until the estimate falls below the hit threshold: the larger of `MIN_EPS` and
half the ray's pixel footprint there, so that a camera ray stops refining at
pixel size (B & W's level of detail) and marching costs the same at any
distance. The normal is the estimate's gradient by central differences at that
scale, which averages the surface over about a pixel.

What the march finds is the first surface only: like the flat triangles, these
primitives have no interval along the ray, so the notation combines them by union
only. The graph tracer and the reference call the same `march`, so they agree up
to the rounding of their object-frame rays.
"""
from __future__ import annotations

import math

from .jit import kernel

MANDELBULB_ITERATIONS = 12
JULIA_ITERATIONS = 14
MIN_EPS = 1e-4          # hit threshold in object units when there is no pixel footprint
MAX_STEPS = 500
LEAVE = 4.0             # thresholds a ray that starts on the surface may travel to leave it
GRAZE = 8.0             # thresholds from the surface that count as touching it, out of steps
# row of per-node fractal data: the arguments, then the bounding radius
A_R = 4
ARG_WIDTH = 5


def fractal_row(name: str, args) -> list[float]:
    """The row of per-node fractal data the kernels read: arguments, then the bound."""
    row = list(args) + [0.0] * (A_R - len(args))
    return row + [bound_radius(name, args)]


def bound_radius(name: str, args) -> float:
    """A ball around the origin that holds the whole set: past it every orbit grows.
    mandelbulb: |z^n + c| >= |z|^n - |z| > |z| once |z|^(n-1) > 2 (c is the start).
    julia: |q^2 + c| > |q| once |q|^2 - |q| > |c|."""
    if name == "mandelbulb":
        return 2.0 ** (1.0 / (args[0] - 1.0)) * (1 + 1e-9)
    c = math.sqrt(sum(a * a for a in args[:4]))
    return (1.0 + math.sqrt(1.0 + 4.0 * c)) / 2.0 * (1 + 1e-9)


def check_arguments(name: str, args) -> str | None:
    """Why these arguments cannot be rendered, or None."""
    if name == "mandelbulb":
        if not 2.0 <= args[0] <= 32.0:
            return f"mandelbulb's power must be between 2 and 32, got {args[0]:g}"
        return None
    for k, a in enumerate(args):
        if not (math.isfinite(a) and abs(a) <= 4.0):
            return (f"julia's constant c must have components between -4 and 4, got "
                    f"{('cx', 'cy', 'cz', 'cw')[k]} = {a:g}")
    return None


@kernel
def mandelbulb_de(x, y, z, power, bail):
    """Distance estimate 0.5 r ln r / |dz| of the triplex power `power` (White & Nylander)."""
    cx, cy, cz = x, y, z
    dr = 1.0
    r = math.sqrt(x * x + y * y + z * z)
    for _ in range(MANDELBULB_ITERATIONS):
        if r > bail:
            break
        if r == 0.0:
            x, y, z = cx, cy, cz           # 0^n = 0: the next point is c
            r = math.sqrt(x * x + y * y + z * z)
            continue
        theta = math.acos(max(-1.0, min(1.0, z / r))) * power
        phi = math.atan2(y, x) * power
        rp = r ** (power - 1.0)
        dr = power * rp * dr + 1.0
        rp *= r
        st = math.sin(theta)
        x = rp * st * math.cos(phi) + cx
        y = rp * st * math.sin(phi) + cy
        z = rp * math.cos(theta) + cz
        r = math.sqrt(x * x + y * y + z * z)
    if r <= 1.0:
        return 0.0                          # did not escape: inside
    return 0.5 * math.log(r) * r / dr


@kernel
def julia_de(x, y, z, c0, c1, c2, c3, bail):
    """Distance estimate 0.5 |q| ln |q| / |q'| of q -> q^2 + c from q = (x, y, z, 0)."""
    q0, q1, q2, q3 = x, y, z, 0.0
    d0, d1, d2, d3 = 1.0, 0.0, 0.0, 0.0
    m = q0 * q0 + q1 * q1 + q2 * q2
    for _ in range(JULIA_ITERATIONS):
        if m > bail * bail:
            break
        # q' <- 2 q q' (quaternion product), q <- q^2 + c
        e0 = 2.0 * (q0 * d0 - q1 * d1 - q2 * d2 - q3 * d3)
        e1 = 2.0 * (q0 * d1 + q1 * d0 + q2 * d3 - q3 * d2)
        e2 = 2.0 * (q0 * d2 - q1 * d3 + q2 * d0 + q3 * d1)
        e3 = 2.0 * (q0 * d3 + q1 * d2 - q2 * d1 + q3 * d0)
        d0, d1, d2, d3 = e0, e1, e2, e3
        p0 = q0 * q0 - q1 * q1 - q2 * q2 - q3 * q3 + c0
        p1 = 2.0 * q0 * q1 + c1
        p2 = 2.0 * q0 * q2 + c2
        p3 = 2.0 * q0 * q3 + c3
        q0, q1, q2, q3 = p0, p1, p2, p3
        m = q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3
    r = math.sqrt(m)
    if r <= 1.0:
        return 0.0
    dq = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2 + d3 * d3)
    if dq == 0.0:
        return 0.0
    return 0.5 * math.log(r) * r / dq


@kernel
def distance(is_julia, args, row, x, y, z):
    """The distance estimate at (x, y, z), object units; 0 inside. Escape radius: twice
    the bound, where the estimate is already good."""
    bail = max(2.0 * args[row, A_R], 4.0)
    if is_julia:
        return julia_de(x, y, z, args[row, 0], args[row, 1], args[row, 2], args[row, 3], bail)
    return mandelbulb_de(x, y, z, args[row, 0], bail)


@kernel
def march(is_julia, args, row, ox, oy, oz, dx, dy, dz, tmin, tmax, lod, lod0, scale, out):
    """The first surface of the line o + t d with t in (tmin, tmax]: out[0] = out[1] = t
    and out[2:5] = out[5:8] = the gradient there (object frame). False if none.
    args[row] holds the arguments and the bounding radius (A_R). The ray's footprint
    is (lod0 + lod t) scale in object units: lod0 > 0 for a ray that leaves a surface seen
    by a pixel; scale the object units of a world unit, |d| where the map is uniform
    (walk.footprint_scale)."""
    dd = math.sqrt(dx * dx + dy * dy + dz * dz)
    if not (dd > 0.0 and dd < math.inf and abs(ox) < math.inf and abs(oy) < math.inf
            and abs(oz) < math.inf):
        return False
    # the ball of radius R: |o + t d|^2 = R^2
    R = args[row, A_R]
    b = (ox * dx + oy * dy + oz * dz) / (dd * dd)
    px, py, pz = ox - b * dx, oy - b * dy, oz - b * dz      # the point nearest the centre
    h = R * R - (px * px + py * py + pz * pz)
    if not h >= 0.0:
        return False
    half = math.sqrt(h) / dd
    start = -b - half
    t = max(start, tmin)
    end = min(-b + half, tmax)
    if not t <= end:
        return False
    foot = 0.5 * lod * scale                                 # object units per unit t
    base = 0.5 * lod0 * scale
    # A ray that starts on the surface (a shadow or reflected ray) sees only what is
    # ahead: it steps out until the estimate clears the threshold, for a few thresholds
    # at most, so that it cannot slide through the solid it starts on.
    leave_until = t + LEAVE * max(MIN_EPS, base + foot * t) / dd if t > start else t
    leaving = t < leave_until
    d = 0.0
    eps = MIN_EPS
    for _ in range(MAX_STEPS):
        eps = max(MIN_EPS, base + foot * t)
        d = distance(is_julia, args, row, ox + t * dx, oy + t * dy, oz + t * dz)
        if d < eps:
            if not leaving or t >= leave_until:
                _surface(is_julia, args, row, ox + t * dx, oy + t * dy, oz + t * dz, eps, t, out)
                return t > tmin
            d = eps
        else:
            leaving = False
        t += d / dd
        if t > end:
            return False
    # Out of steps: a ray still within a few thresholds of the surface is grazing it,
    # which at this scale is touching it; one further away is lost in a crevice.
    if d < GRAZE * eps:
        _surface(is_julia, args, row, ox + t * dx, oy + t * dy, oz + t * dz, eps, t, out)
        return t > tmin
    return False


@kernel
def _surface(is_julia, args, row, x, y, z, eps, t, out):
    h = eps
    gx = distance(is_julia, args, row, x + h, y, z) - distance(is_julia, args, row, x - h, y, z)
    gy = distance(is_julia, args, row, x, y + h, z) - distance(is_julia, args, row, x, y - h, z)
    gz = distance(is_julia, args, row, x, y, z + h) - distance(is_julia, args, row, x, y, z - h)
    if gx == 0.0 and gy == 0.0 and gz == 0.0:
        gx, gy, gz = x, y, z                # flat estimate (deep inside): point outwards
    out[0] = t
    out[1] = t
    out[2] = out[5] = gx
    out[3] = out[6] = gy
    out[4] = out[7] = gz
