"""The shading model of render/shade.py as one parallel numba kernel for the graph
tracer: camera ray, shadow rays and reflection / refraction bounces of a pixel
sample run together, on every core, without numpy temporaries between them.
render/shade.py stays the readable model (and shades --reference renders); the
tests hold the two to the same colours.

A sample's pending rays (the camera ray, then its bounces) sit on a small stack,
each with the weight its colour enters the pixel with: a surface keeps
(1 - kr)(1 - kt) of its own colour, passes kr(1 - kt) to its reflection and kt
to its refraction, exactly the blend shade.py applies on the way back up.

Ambient occlusion shifts one fixed pattern of hemisphere directions by two numbers
hashed from the camera ray's id (its pixel and sample), never from the thread that
shades it, so the picture is the same at any thread count.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .jit import kernel
from .scratch import make_scratch
from .vm import hash_to_unit, splitmix64
from .walk import R_MAT, R_N, R_PAINT, R_T, R_WIDTH, first_hit

CHUNK = 64
EPS = 1e-6
# light rows: position (3), colour (3), radius; material rows as shade.py's table
L_POS, L_COLOR, L_RADIUS = 0, 3, 6
P_O, P_D, P_W, P_DEPTH, P_CONE = 0, 3, 6, 9, 10     # pending-ray columns
GOLDEN = 0.6180339887498949                    # the pattern's azimuths: k * GOLDEN mod 1


@kernel
def trace_one(flat, ox, oy, oz, dx, dy, dz, tmin, tmax, any_hit, lod, cone, max_depth, S, ev,
              res):
    """first_hit into res[0] behind one call site, so that the walk is compiled once."""
    return first_hit(flat, ox, oy, oz, dx, dy, dz, tmin, tmax, any_hit, lod, cone, max_depth,
                     S, ev, res, 0)


@njit(cache=True, parallel=True, error_model="numpy")
def shade_rays(flat, origins, directions, lights, horizon, zenith, materials, default,
               shadows, shadow_samples, max_bounces, lod, max_depth, limits, workers, ambient,
               ao_samples, ao_distance, ids, rgb, first_t, first_hit_out, rays, events):
    """rgb[i] = the linear colour of camera ray i; first_t / first_hit_out its first hit;
    rays[chunk] = rays traced; events[chunk] as trace_rays. ids[i] seeds the ambient
    occlusion pattern of ray i and of its bounces."""
    n = origins.shape[0]
    chunks = (n + CHUNK - 1) // CHUNK
    for w in prange(workers):
        S = make_scratch(flat, limits)
        res = np.empty((1, R_WIDTH))
        pend = np.empty((2 * max_bounces + 2, 11))
        for c in range(w, chunks, workers):
            ev = events[c]
            count = 0
            for i in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
                for k in range(3):
                    pend[0, P_O + k] = origins[i, k]
                    pend[0, P_D + k] = directions[i, k]
                    pend[0, P_W + k] = 1.0
                    rgb[i, k] = 0.0
                pend[0, P_DEPTH] = 0.0
                pend[0, P_CONE] = 0.0
                top = 1
                first = True
                while top > 0:
                    top -= 1
                    o0, o1, o2 = pend[top, P_O], pend[top, P_O + 1], pend[top, P_O + 2]
                    d0, d1, d2 = pend[top, P_D], pend[top, P_D + 1], pend[top, P_D + 2]
                    w0, w1, w2 = pend[top, P_W], pend[top, P_W + 1], pend[top, P_W + 2]
                    depth = int(pend[top, P_DEPTH])
                    cone = pend[top, P_CONE]
                    hit = trace_one(flat, o0, o1, o2, d0, d1, d2, 1e-9, np.inf, False, lod,
                                    cone, max_depth, S, ev, res)
                    count += 1
                    if first:
                        first_t[i] = res[0, R_T]
                        first_hit_out[i] = hit
                        first = False
                    dn = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
                    if not hit:
                        s = min(max(d2 / max(dn, 1e-300), 0.0), 1.0) ** 0.6
                        for k in range(3):
                            rgb[i, k] += (w0, w1, w2)[k] * (horizon[k] * (1 - s) + zenith[k] * s)
                        continue
                    t = res[0, R_T]
                    cone += lod * t * dn          # the pixel's width here: rays from it start so
                    u0, u1, u2 = d0 / dn, d1 / dn, d2 / dn
                    p0, p1, p2 = o0 + t * d0, o1 + t * d1, o2 + t * d2
                    n0, n1, n2 = res[0, R_N], res[0, R_N + 1], res[0, R_N + 2]
                    inside = n0 * u0 + n1 * u1 + n2 * u2 > 0.0
                    if inside:
                        n0, n1, n2 = -n0, -n1, -n2
                    # finish: the material's (or the default), the paint's colour wins
                    mat = int(res[0, R_MAT])
                    fin = materials[mat] if mat >= 0 else default
                    b0, b1, b2 = fin[0], fin[1], fin[2]
                    if not math.isnan(res[0, R_PAINT]):
                        b0 = max(res[0, R_PAINT], 0.0)
                        b1 = max(res[0, R_PAINT + 1], 0.0)
                        b2 = max(res[0, R_PAINT + 2], 0.0)
                    kd, ks, shin = fin[3], fin[4], fin[5]
                    reflect, ior, transmit = fin[6], fin[7], fin[8]
                    up = min(max(n2 * 0.5 + 0.5, 0.0), 1.0)
                    c0 = ambient * b0 * (horizon[0] * (1 - up) + zenith[0] * up)
                    c1 = ambient * b1 * (horizon[1] * (1 - up) + zenith[1] * up)
                    c2 = ambient * b2 * (horizon[2] * (1 - up) + zenith[2] * up)
                    scale = 1.0 + max(abs(p0), abs(p1), abs(p2))
                    q0, q1, q2 = (p0 + n0 * EPS * scale, p1 + n1 * EPS * scale,
                                  p2 + n2 * EPS * scale)
                    if ao_samples > 0:
                        h = splitmix64(np.uint64(ids[i]))
                        r1, r2 = hash_to_unit(h), hash_to_unit(splitmix64(h))
                        seen = 0
                        for k in range(ao_samples):
                            a0, a1, a2 = hemisphere(k, ao_samples, r1, r2, n0, n1, n2)
                            blocked = trace_one(flat, q0, q1, q2, a0, a1, a2, 1e-9,
                                                ao_distance, True, lod, cone, max_depth, S, ev,
                                                res)
                            count += 1
                            if not blocked:
                                seen += 1
                        unoccluded = seen / ao_samples
                        c0 *= unoccluded
                        c1 *= unoccluded
                        c2 *= unoccluded
                    for li in range(lights.shape[0]):
                        t0 = lights[li, L_POS] - q0
                        t1 = lights[li, L_POS + 1] - q1
                        t2 = lights[li, L_POS + 2] - q2
                        dist = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
                        l0, l1, l2 = t0 / dist, t1 / dist, t2 / dist
                        vis = 1.0
                        if shadows:
                            radius = lights[li, L_RADIUS]
                            samples = shadow_samples if radius > 0 else 1
                            seen = 0
                            for k in range(samples):
                                g0 = lights[li, L_POS]
                                g1 = lights[li, L_POS + 1]
                                g2 = lights[li, L_POS + 2]
                                if samples > 1:
                                    e0, e1, e2 = disk(k, samples, radius, l0, l1, l2)
                                    g0 += e0
                                    g1 += e1
                                    g2 += e2
                                blocked = trace_one(flat, q0, q1, q2, g0 - q0, g1 - q1,
                                                    g2 - q2, 1e-9, 1.0 - 1e-9, True, lod,
                                                    cone, max_depth, S, ev, res)
                                count += 1
                                if not blocked:
                                    seen += 1
                            vis = seen / samples
                        ndl = max(n0 * l0 + n1 * l1 + n2 * l2, 0.0)
                        ln = l0 * n0 + l1 * n1 + l2 * n2
                        r0, r1, r2 = l0 - 2 * ln * n0, l1 - 2 * ln * n1, l2 - 2 * ln * n2
                        spec = max(r0 * u0 + r1 * u1 + r2 * u2, 0.0) ** shin
                        lit = 1.0 if ndl > 0 else 0.0
                        c0 += vis * lights[li, L_COLOR] * (kd * b0 * ndl + ks * spec * lit)
                        c1 += vis * lights[li, L_COLOR + 1] * (kd * b1 * ndl + ks * spec * lit)
                        c2 += vis * lights[li, L_COLOR + 2] * (kd * b2 * ndl + ks * spec * lit)
                    keep = 1.0
                    if depth < max_bounces:
                        cos_i = -(u0 * n0 + u1 * n1 + u2 * n2)
                        eta = ior if inside else 1.0 / max(ior, 1e-9)
                        kk = 1 - eta * eta * (1 - cos_i * cos_i)
                        f0 = ((1 - ior) / (1 + ior)) ** 2
                        fresnel = 1.0 if kk < 0 else f0 + (1 - f0) * (1 - cos_i) ** 5
                        kr = min(max(reflect + transmit * fresnel, 0.0), 1.0)
                        kt = 0.0 if kk < 0 else transmit * (1 - fresnel)
                        pass_t = 1.0 - kt if kt > 1e-3 else 1.0
                        if kr > 1e-3:
                            keep *= 1.0 - kr
                            wr = kr * pass_t
                            _push(pend, top, q0, q1, q2, u0 + 2 * cos_i * n0,
                                  u1 + 2 * cos_i * n1, u2 + 2 * cos_i * n2,
                                  w0 * wr, w1 * wr, w2 * wr, depth + 1, cone)
                            top += 1
                        if kt > 1e-3:
                            keep *= 1.0 - kt
                            a = eta * cos_i - math.sqrt(max(kk, 0.0))
                            _push(pend, top, p0 - n0 * EPS * scale, p1 - n1 * EPS * scale,
                                  p2 - n2 * EPS * scale, eta * u0 + a * n0, eta * u1 + a * n1,
                                  eta * u2 + a * n2, w0 * kt, w1 * kt, w2 * kt, depth + 1, cone)
                            top += 1
                    rgb[i, 0] += w0 * keep * c0
                    rgb[i, 1] += w1 * keep * c1
                    rgb[i, 2] += w2 * keep * c2
            rays[c] = count


@kernel
def _push(pend, top, o0, o1, o2, d0, d1, d2, w0, w1, w2, depth, cone):
    pend[top, P_O], pend[top, P_O + 1], pend[top, P_O + 2] = o0, o1, o2
    pend[top, P_D], pend[top, P_D + 1], pend[top, P_D + 2] = d0, d1, d2
    pend[top, P_W], pend[top, P_W + 1], pend[top, P_W + 2] = w0, w1, w2
    pend[top, P_DEPTH] = depth
    pend[top, P_CONE] = cone


@kernel
def disk(k, n, radius, x, y, z):
    """shade._disk: sample k of n on a disk of `radius` facing (x, y, z)."""
    r = radius * math.sqrt((k + 0.5) / n)
    a = k * math.pi * (3 - math.sqrt(5))
    ux, uy, uz, vx, vy, vz = basis(x, y, z)
    ca, sa = math.cos(a), math.sin(a)
    return r * (ca * ux + sa * vx), r * (ca * uy + sa * vy), r * (ca * uz + sa * vz)


@kernel
def hemisphere(k, n, r1, r2, x, y, z):
    """shade._hemisphere: direction k of n about the unit normal (x, y, z), cosine
    weighted, so that the fraction of unblocked directions estimates the ambient light
    a Lambertian surface receives. The pattern (stratified in elevation, golden-ratio
    azimuths) is shifted by (r1, r2) mod 1 (Cranley-Patterson rotation): stratified
    within a pixel, noise rather than bands across pixels."""
    u = (k + 0.5) / n + r1
    u -= math.floor(u)
    v = k * GOLDEN + r2
    v -= math.floor(v)
    s, c = math.sqrt(u), math.sqrt(max(1.0 - u, 0.0))
    a = 2 * math.pi * v
    ux, uy, uz, vx, vy, vz = basis(x, y, z)
    ca, sa = s * math.cos(a), s * math.sin(a)
    return ca * ux + sa * vx + c * x, ca * uy + sa * vy + c * y, ca * uz + sa * vz + c * z


@kernel
def basis(x, y, z):
    """Two unit vectors perpendicular to (x, y, z) and to each other (shade._basis)."""
    hx, hy, hz = (0.0, 0.0, 1.0) if abs(z) < 0.9 else (1.0, 0.0, 0.0)
    ux, uy, uz = y * hz - z * hy, z * hx - x * hz, x * hy - y * hx
    norm = math.sqrt(ux * ux + uy * uy + uz * uz)
    ux, uy, uz = ux / norm, uy / norm, uz / norm
    return ux, uy, uz, y * uz - z * uy, z * ux - x * uz, x * uy - y * ux
