"""The centre of the smallest ball that holds a list of balls (graph/spheres.py enclose),
searched by Newton's method on a smooth stand-in of the radius function, compiled: the
fern's bounding spheres search some 250 lists of up to 128 balls, each at eight
sharpnesses, which took 0.43 s of its 0.8 s of bounds in numpy's small-array calls.
Only the centre comes from here; enclose makes the radius exact for it, so the ball
holds every ball whatever the search found."""
import math

import numpy as np

from .jit import copy_into, inline, share


@inline
def _smooth(balls, x, t, u, d, w):
    """max_j |x - c_j| + r_j as a log-sum-exp at sharpness t; fills u (unit vectors from
    the centres to x), d (distances) and w (the softmax weights)."""
    top = -np.inf
    for j in range(balls.shape[0]):
        v0, v1, v2 = x[0] - balls[j, 0], x[1] - balls[j, 1], x[2] - balls[j, 2]
        dj = max(math.sqrt(v0 * v0 + v1 * v1 + v2 * v2), 1e-300)
        d[j] = dj
        u[j, 0], u[j, 1], u[j, 2] = v0 / dj, v1 / dj, v2 / dj
        w[j] = t * (dj + balls[j, 3])
        top = max(top, w[j])
    total = 0.0
    for j in range(balls.shape[0]):
        w[j] = math.exp(w[j] - top)
        total += w[j]
    for j in range(balls.shape[0]):
        w[j] /= total
    return (top + math.log(total)) / t


@inline
def _solve3(h, g, out, a):
    """out = h^-1 g by elimination with partial pivoting (a: (3, 4) scratch); False
    where a pivot is zero, as numpy's solve raises there (one that overflowed gives
    nan, and the line search then stays where it is, as it does after numpy's solve)."""
    for r in range(3):
        for c in range(3):
            a[r, c] = h[r, c]
        a[r, 3] = g[r]
    for c in range(3):
        p = c
        for r in range(c + 1, 3):
            if abs(a[r, c]) > abs(a[p, c]):
                p = r
        if a[p, c] == 0.0:
            return False
        if p != c:
            for k in range(4):
                a[c, k], a[p, k] = a[p, k], a[c, k]
        for r in range(c + 1, 3):
            f = a[r, c] / a[c, c]
            for k in range(c, 4):
                a[r, k] -= f * a[c, k]
    for r in range(2, -1, -1):
        s = a[r, 3]
        for k in range(r + 1, 3):
            s -= a[r, k] * out[k]
        out[r] = s / a[r, r]
    return True


@share
def centre_search(balls, centre, t, sharpest, size):
    """The centre after Newton's method at sharpness t / size, then ten times sharper,
    until `sharpest`: each minimum starts the next. With balls far apart at a high
    sharpness the Hessian overflows: the step is then not finite, no step length passes
    the line search, and the centre stays where it is."""
    k = balls.shape[0]
    x = centre.copy()
    u, d, w = np.empty((k, 3)), np.empty(k), np.empty(k)
    uy, dy, wy = np.empty((k, 3)), np.empty(k), np.empty(k)
    g, step, y = np.empty(3), np.empty(3), np.empty(3)
    h, scratch = np.empty((3, 3)), np.empty((3, 4))
    while t <= sharpest:
        s = t / size
        f = _smooth(balls, x, s, u, d, w)
        for _ in range(50):
            # Hessian: sum w (I - u u^T) / d + s (sum w u u^T - g g^T)
            g[:] = 0.0
            h[:] = 0.0
            wd = 0.0
            for j in range(k):
                wd += w[j] / d[j]
                bend = s - 1.0 / d[j]
                for a in range(3):
                    g[a] += w[j] * u[j, a]
                    for b in range(3):
                        h[a, b] += w[j] * u[j, a] * u[j, b] * bend
            trace = 0.0
            for a in range(3):
                for b in range(3):
                    h[a, b] -= s * g[a] * g[b]
                h[a, a] += wd
                trace += h[a, a]
            for a in range(3):
                h[a, a] += 1e-12 * trace + 1e-300
            if not _solve3(h, g, step, scratch):
                for a in range(3):
                    step[a] = g[a] * size
            slope = g[0] * step[0] + g[1] * step[1] + g[2] * step[2]
            alpha = 1.0
            fy = f
            moved = False
            while alpha > 1e-9:
                for a in range(3):
                    y[a] = x[a] - alpha * step[a]
                fy = _smooth(balls, y, s, uy, dy, wy)
                if fy <= f - 1e-4 * alpha * slope:
                    moved = True
                    break
                alpha /= 2
            if not moved:
                break
            copy_into(x, y)
            f = fy
            u, uy = uy, u
            d, dy = dy, d
            w, wy = wy, w
            if alpha * math.sqrt(step[0] ** 2 + step[1] ** 2 + step[2] ** 2) < 1e-14 * size:
                break
        t *= 10
    return x
