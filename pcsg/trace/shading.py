"""The shading model of render/shade.py as one parallel numba kernel for the graph
tracer: camera rays, shadow rays and reflection / refraction bounces run together,
on every core, without numpy temporaries between them. render/shade.py stays the
readable model (and shades --reference renders); the tests hold the two to the same
colours.

The rays of a chunk of 256 pixel samples are traced as packets (packet.py): the
camera rays; for the surfaces they hit, one packet per occlusion direction and one
per light sample; then the reflected and the refracted rays as two more packets.
Pending packets sit on a small stack, the one of bounce depth d at d, each ray with
its pixel and the weight its colour enters the pixel with: a surface keeps
1 - kr - kt of its own colour, passes kr to its reflection and kt to its refraction,
exactly the blend shade.py applies on the way back up; rays of a weight under
MIN_WEIGHT are not traced. A pixel gets
its terms in the order a depth-first walk of its own rays adds them.

Ambient occlusion shifts one fixed pattern of hemisphere directions by two numbers
hashed from the camera ray's id (its pixel and sample), never from the thread that
shades it, so the picture is the same at any thread count.
"""
from __future__ import annotations

import math

import numpy as np

from .jit import inline, kernel, share, stoppable
from .packet import PACKET, make_packet, trace
from .scratch import make_scratch
from .vm import hash_to_unit, splitmix64
from .walk import HIT_SHEET, HIT_SHELL, R_HIT, R_MAT, R_N, R_PAINT, R_T, R_WIDTH

CHUNK = PACKET
EPS = 1e-6
# of a point's largest coordinate, beside EPS of the object's size: the rounding of a point
# far from the origin is a few parts in 1e16 of it. At EPS of it, a scene 1e6 from the
# origin moved its shaded points 1.4 units off their surfaces, past the shadows of its
# neighbours (QA)
EPS_FAR = 1e-9
# a reflected or refracted ray whose colour would enter its pixel with less than this
# weight is not traced (its share stays with the surface's own colour): with glass, every
# bounce doubled the rays, and --bounces 20 took 4 times as long as 16 for the same picture
MIN_WEIGHT = 1e-3


@inline
def off_surface(unit, p0, p1, p2):
    """How far a shaded point at p moves off its surface: EPS of the object's size (unit,
    Lighting.unit) and EPS_FAR of its largest coordinate (shade.off_surface's model)."""
    return EPS * unit + EPS_FAR * max(abs(p0), abs(p1), abs(p2))


# light rows: position (3), colour (3), radius; material rows as shade.py's table
L_POS, L_COLOR, L_RADIUS = 0, 3, 6
P_O, P_D, P_W, P_CONE, P_PIX = 0, 3, 6, 9, 10     # pending-ray columns
P_WIDTH = 11
# a surface being shaded: offset point, unit normal, unit ray direction, hit point,
# colour so far, weight, base colour; then its finish and what its bounces need
SH_Q, SH_N, SH_U, SH_P, SH_C, SH_W, SH_B = 0, 3, 6, 9, 12, 15, 18
(SH_KD, SH_KS, SH_SHIN, SH_REFL, SH_IOR, SH_TRANS, SH_INSIDE, SH_CONE, SH_LIFT, SH_PIX,
 SH_SEEN, SH_FACING, SH_PASS) = range(21, 34)
SH_G = 34                   # the point on the light a surface's shadow ray aims at
SH_WIDTH = 37
M_TRANSMIT = 8              # the material table's transmit column (shade.FINISH_KEYS)
# the surfaces a shadow ray passes through, at most: past them the light is taken as
# blocked (0.9 ** 16 of it would be left through glass of transmit 0.9)
MAX_CROSSINGS = 16
GOLDEN = 0.6180339887498949                    # the pattern's azimuths: k * GOLDEN mod 1
# the streams a pixel's shift of a pattern is drawn from (pixel_shift): the hemisphere's,
# and an area light's, one per light from LIGHT_STREAM on
AO_STREAM = np.uint64(0)
LIGHT_STREAM = np.uint64(0x2545F4914F6CDD1D)


def shade_rays(flat, origins, directions, lights, horizon, zenith, materials, default,
               shadows, shadow_samples, max_bounces, lod, max_depth, limits, workers, ambient,
               ao_samples, ao_distance, unit, ids, together, rgb, first_t, first_hit_out, rays,
               events, tick=None):
    """rgb[i] = the linear colour of camera ray i; first_t / first_hit_out its first hit;
    rays[chunk] = rays traced; events[worker] as trace_rays' events[chunk]: counts add and
    levels are maxima, so the totals are the same however the chunks are shared out, and
    one array per worker is cheaper to clear and fold than one per chunk. ids[i] seeds
    the ambient occlusion pattern of ray i and of its bounces. With `together` the rays
    of each packet walk the graph together. Ctrl-C, or an exception from tick() (called
    every 50 ms), stops it after the chunk each worker is shading (jit.stoppable). A
    point is moved off its surface by off_surface (`unit`: Lighting.unit)."""
    stoppable(shade_share, workers, flat, origins, directions, lights, horizon, zenith,
              materials, default, shadows, shadow_samples, max_bounces, lod, max_depth,
              limits, ambient, ao_samples, ao_distance, unit, ids, together, rgb, first_t,
              first_hit_out, rays, events, tick=tick)


@share
def shade_share(w, workers, stop, flat, origins, directions, lights, horizon, zenith,
                materials, default, shadows, shadow_samples, max_bounces, lod, max_depth,
                limits, ambient, ao_samples, ao_distance, unit, ids, together, rgb, first_t,
                first_hit_out, rays, events):
    """Worker w's share of shade_rays: every workers-th chunk, with scratch of its own,
    until stop[0] is set."""
    n = origins.shape[0]
    chunks = (n + CHUNK - 1) // CHUNK
    S = make_scratch(flat, limits)
    P = make_packet(flat)
    res = np.empty((PACKET, R_WIDTH))
    occ = np.empty((PACKET, R_WIDTH))
    sh = np.empty((PACKET, SH_WIDTH))
    pend = np.empty((max_bounces + 2, PACKET, P_WIDTH))
    count = np.zeros(max_bounces + 2, dtype=np.int64)
    depths = np.zeros(max_bounces + 2, dtype=np.int64)
    # any_hit of the nearest-hit and of the shadow rays as values, not constants: numba
    # compiles a call with a literal True or False as a specialisation of its own, and
    # the walk twice took 50 s more
    nearest = n < 0
    blocker = not nearest
    # glass lets light through to what it shades; without any, shadow rays stop at the
    # first surface they meet, as they did before there was glass
    glass = False
    for r in range(materials.shape[0]):
        glass = glass or materials[r, M_TRANSMIT] > 0.0
    slot = np.empty(PACKET, dtype=np.int64)
    ev = events[w]
    for c in range(w, chunks, workers):
        if stop[0] != 0:
            break
        i0 = c * CHUNK
        m = min(n, i0 + CHUNK) - i0
        for k in range(m):
            for a in range(3):
                pend[0, k, P_O + a] = origins[i0 + k, a]
                pend[0, k, P_D + a] = directions[i0 + k, a]
                pend[0, k, P_W + a] = 1.0
                rgb[i0 + k, a] = 0.0
            pend[0, k, P_CONE] = 0.0
            pend[0, k, P_PIX] = i0 + k
        count[0] = m
        depths[0] = 0
        top = 1
        traced = 0
        while top > 0:
            top -= 1
            depth = depths[top]
            m = count[top]
            for k in range(m):
                for a in range(3):
                    P.O[k, a] = pend[top, k, P_O + a]
                    P.D[k, a] = pend[top, k, P_D + a]
                P.cone[k] = pend[top, k, P_CONE]
            # tmin 0: a ray leaves the eye, or a point moved off its surface by a share of
            # its size (EPS); at 1e-9, as the shadow rays' relative one, an object smaller
            # than 1e-9 was drawn as nothing (uscale(1e-10) sphere)
            trace(flat, m, 0.0, np.inf, nearest, lod, max_depth, S, P, together, ev, res)
            if traced == 0:         # the camera rays
                for k in range(m):
                    first_t[i0 + k] = res[k, R_T]
                    first_hit_out[i0 + k] = res[k, R_HIT] > 0.0
            traced += m
            hits = surfaces(pend, top, m, res, horizon, zenith, materials, default,
                            ambient, lod, P, sh, rgb, unit)
            if hits == 0:
                continue
            if ao_samples > 0:
                traced += occlusion(flat, hits, ao_samples, ao_distance, ids, lod,
                                    max_depth, S, P, together, blocker, ev, occ, sh)
            for li in range(lights.shape[0]):
                traced += light_up(flat, lights, li, shadows, shadow_samples, hits, lod,
                                   max_depth, S, P, together, blocker, ev, occ, sh, glass,
                                   materials, default, slot, ids, unit)
            top = bounce(pend, count, depths, top, depth, max_bounces, hits, sh, rgb)
        rays[c] = traced


@kernel
def surfaces(pend, top, m, res, horizon, zenith, materials, default, ambient, lod, P, sh,
             rgb, unit):
    """The packet's misses add the sky to their pixels; its hits go into sh with their
    ambient colour. Returns how many hit."""
    hits = 0
    for k in range(m):
        i = int(pend[top, k, P_PIX])
        w = (pend[top, k, P_W], pend[top, k, P_W + 1], pend[top, k, P_W + 2])
        d0, d1, d2 = P.D[k, 0], P.D[k, 1], P.D[k, 2]
        dn = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        if res[k, R_HIT] == 0.0:
            s = min(max(d2 / max(dn, 1e-300), 0.0), 1.0) ** 0.6
            for a in range(3):
                rgb[i, a] += w[a] * (horizon[a] * (1 - s) + zenith[a] * s)
            continue
        j = hits
        hits += 1
        t = res[k, R_T]
        sh[j, SH_CONE] = P.cone[k] + lod * t * dn   # the pixel's width here: rays from
        u = (d0 / dn, d1 / dn, d2 / dn)             # it start so
        p = (P.O[k, 0] + t * d0, P.O[k, 1] + t * d1, P.O[k, 2] + t * d2)
        n0, n1, n2 = res[k, R_N], res[k, R_N + 1], res[k, R_N + 2]
        inside = n0 * u[0] + n1 * u[1] + n2 * u[2] > 0.0
        if inside:
            n0, n1, n2 = -n0, -n1, -n2
        nrm = (n0, n1, n2)
        # finish: the material's (or the default), the paint's colour wins
        mat = int(res[k, R_MAT])
        fin = materials[mat] if mat >= 0 else default
        b = (fin[0], fin[1], fin[2])
        if not math.isnan(res[k, R_PAINT]):
            b = (max(res[k, R_PAINT], 0.0), max(res[k, R_PAINT + 1], 0.0),
                 max(res[k, R_PAINT + 2], 0.0))
        up = min(max(n2 * 0.5 + 0.5, 0.0), 1.0)
        lift = off_surface(unit, p[0], p[1], p[2])
        for a in range(3):
            sh[j, SH_Q + a] = p[a] + nrm[a] * lift
            sh[j, SH_N + a] = nrm[a]
            sh[j, SH_U + a] = u[a]
            sh[j, SH_P + a] = p[a]
            sh[j, SH_C + a] = ambient * b[a] * (horizon[a] * (1 - up) + zenith[a] * up)
            sh[j, SH_W + a] = w[a]
            sh[j, SH_B + a] = b[a]
        sh[j, SH_KD], sh[j, SH_KS], sh[j, SH_SHIN] = fin[3], fin[4], fin[5]
        sh[j, SH_REFL], sh[j, SH_IOR], sh[j, SH_TRANS] = fin[6], fin[7], fin[8]
        if res[k, R_HIT] == HIT_SHEET:
            sh[j, SH_IOR] = 1.0             # a sheet bends nothing that passes through it
        elif res[k, R_HIT] == HIT_SHELL:
            sh[j, SH_TRANS] = 0.0           # nothing passes through a shell (walk.HIT_SHELL)
        sh[j, SH_INSIDE] = 1.0 if inside else 0.0
        sh[j, SH_LIFT] = lift
        sh[j, SH_PIX] = i
    return hits


@inline
def aim(P, k, sh, j, d0, d1, d2):
    """Ray k of the packet: from surface j's offset point along d."""
    for a in range(3):
        P.O[k, a] = sh[j, SH_Q + a]
    P.D[k, 0] = d0
    P.D[k, 1] = d1
    P.D[k, 2] = d2
    P.cone[k] = sh[j, SH_CONE]


@inline
def occlusion(flat, hits, ao_samples, ao_distance, ids, lod, max_depth, S, P, together,
              any_hit, ev, occ, sh):
    """Ambient occlusion: one packet of rays per direction of the pattern; scales each
    surface's colour by the fraction of them that escape. Returns the rays traced."""
    for j in range(hits):
        sh[j, SH_SEEN] = 0.0
    for s in range(ao_samples):
        for j in range(hits):
            r1, r2 = pixel_shift(ids[int(sh[j, SH_PIX])], AO_STREAM)
            a0, a1, a2 = hemisphere(s, ao_samples, r1, r2, sh[j, SH_N], sh[j, SH_N + 1],
                                    sh[j, SH_N + 2])
            aim(P, j, sh, j, a0, a1, a2)
        trace(flat, hits, 0.0, ao_distance, any_hit, lod, max_depth, S, P, together, ev, occ)
        for j in range(hits):
            if occ[j, R_HIT] == 0.0:
                sh[j, SH_SEEN] += 1.0
    for j in range(hits):
        unoccluded = sh[j, SH_SEEN] / ao_samples
        for a in range(3):
            sh[j, SH_C + a] *= unoccluded
    return hits * ao_samples


@inline
def to_light(lights, li, sh, j):
    """The unit direction from surface j's offset point to light li's centre."""
    t0 = lights[li, L_POS] - sh[j, SH_Q]
    t1 = lights[li, L_POS + 1] - sh[j, SH_Q + 1]
    t2 = lights[li, L_POS + 2] - sh[j, SH_Q + 2]
    dist = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
    return t0 / dist, t1 / dist, t2 / dist


@inline
def light_up(flat, lights, li, shadows, shadow_samples, hits, lod, max_depth, S, P, together,
             any_hit, ev, occ, sh, glass, materials, default, slot, ids, unit):
    """Light li's diffuse and specular terms on every surface, times the fraction of
    its samples that no shadow ray finds blocked (one packet per sample; an area light's
    samples shifted by each pixel's id in `ids`: disk); with `glass`,
    a shadow ray that meets glass goes on through it (through_glass). Returns the rays
    traced."""
    rays = 0
    radius = lights[li, L_RADIUS]
    samples = shadow_samples if radius > 0 else 1
    # an int64 from the start: numba types the trace call below while it still takes
    # facing for the constant 0, and compiled the whole packet trace once more for that
    facing = np.int64(0)
    for j in range(hits):
        sh[j, SH_SEEN] = 0.0
        # a surface turned away from the light gets nothing from it, shadowed or not
        # (both terms below are 0), so it sends no shadow rays (half of them where a
        # light is behind the objects; few in the samples, lit from the camera's side)
        l0, l1, l2 = to_light(lights, li, sh, j)
        lit = sh[j, SH_N] * l0 + sh[j, SH_N + 1] * l1 + sh[j, SH_N + 2] * l2 > 0.0
        sh[j, SH_FACING] = 1.0 if lit else 0.0
        if lit:
            facing += 1
    if shadows and facing > 0:
        for s in range(samples):
            k = 0
            for j in range(hits):
                if sh[j, SH_FACING] == 0.0:
                    continue
                g0 = lights[li, L_POS]
                g1 = lights[li, L_POS + 1]
                g2 = lights[li, L_POS + 2]
                if samples > 1:
                    l0, l1, l2 = to_light(lights, li, sh, j)
                    r1, r2 = pixel_shift(ids[int(sh[j, SH_PIX])],
                                         LIGHT_STREAM + np.uint64(li))
                    e0, e1, e2 = disk(s, samples, radius, r1, r2, l0, l1, l2)
                    g0 += e0
                    g1 += e1
                    g2 += e2
                sh[j, SH_G], sh[j, SH_G + 1], sh[j, SH_G + 2] = g0, g1, g2
                aim(P, k, sh, j, g0 - sh[j, SH_Q], g1 - sh[j, SH_Q + 1],
                    g2 - sh[j, SH_Q + 2])
                k += 1
            trace(flat, facing, 1e-9, 1.0 - 1e-9, any_hit, lod, max_depth, S, P, together, ev,
                  occ)
            rays += facing
            k = 0
            blocked = np.int64(0)       # as facing above: no literal 0 into the trace
            for j in range(hits):
                if sh[j, SH_FACING] == 0.0:
                    continue
                if occ[k, R_HIT] == 0.0:
                    sh[j, SH_SEEN] += 1.0
                elif glass and passes(occ, k, materials, default) > 0.0:
                    # what it met lets light through: walked again, there may be more
                    # (what stops light, met first, stops it whatever else is there)
                    slot[blocked] = j
                    blocked += 1
                k += 1
            if blocked > 0:
                rays += through_glass(flat, blocked, slot, lod, max_depth, S, P, together,
                                      not any_hit, ev, occ, sh, materials, default, unit)
    for j in range(hits):
        vis = sh[j, SH_SEEN] / samples if shadows else 1.0
        l0, l1, l2 = to_light(lights, li, sh, j)
        n0, n1, n2 = sh[j, SH_N], sh[j, SH_N + 1], sh[j, SH_N + 2]
        ndl = max(n0 * l0 + n1 * l1 + n2 * l2, 0.0)
        ln = l0 * n0 + l1 * n1 + l2 * n2
        r0, r1, r2 = l0 - 2 * ln * n0, l1 - 2 * ln * n1, l2 - 2 * ln * n2
        spec = max(r0 * sh[j, SH_U] + r1 * sh[j, SH_U + 1] + r2 * sh[j, SH_U + 2],
                   0.0) ** sh[j, SH_SHIN]
        lit = 1.0 if ndl > 0 else 0.0
        kd, ks = sh[j, SH_KD], sh[j, SH_KS]
        for a in range(3):
            sh[j, SH_C + a] += vis * lights[li, L_COLOR + a] * (kd * sh[j, SH_B + a] * ndl
                                                                + ks * spec * lit)
    return rays


@inline
def passes(occ, i, materials, default):
    """The share of light the surface of hit i lets through: its material's transmit, 0
    for a shell (walk.HIT_SHELL)."""
    if occ[i, R_HIT] == HIT_SHELL:
        return 0.0
    mat = int(occ[i, R_MAT])
    return materials[mat, M_TRANSMIT] if mat >= 0 else default[M_TRANSMIT]


@inline
def through_glass(flat, n, slot, lod, max_depth, S, P, together, nearest, ev, occ, sh,
                  materials, default, unit):
    """The shadow rays of surfaces slot[:n], which met something on the way to their
    light, walked again surface by surface, nearest first: each surface of a material
    that transmits lets through its transmit (a ball of glass twice, going in and out,
    as POV-Ray's shadows through `transmit`), anything else, or a shell, stops the
    light. What comes through adds to the surface's SH_SEEN. Returns the rays traced."""
    rays = 0
    for i in range(n):
        j = slot[i]
        sh[j, SH_PASS] = 1.0
        aim(P, i, sh, j, sh[j, SH_G] - sh[j, SH_Q], sh[j, SH_G + 1] - sh[j, SH_Q + 1],
            sh[j, SH_G + 2] - sh[j, SH_Q + 2])
    for _ in range(MAX_CROSSINGS):
        if n == 0:
            break
        trace(flat, n, 1e-9, 1.0 - 1e-9, nearest, lod, max_depth, S, P, together, ev, occ)
        rays += n
        kept = np.int64(0)
        for i in range(n):
            j = slot[i]
            if occ[i, R_HIT] == 0.0:
                sh[j, SH_SEEN] += sh[j, SH_PASS]
                continue
            through = passes(occ, i, materials, default)
            if not through > 0.0:
                continue
            sh[j, SH_PASS] *= through
            # on from just past the surface, as a refracted ray starts (shade._bounces)
            t = occ[i, R_T]
            d0, d1, d2 = P.D[i, 0], P.D[i, 1], P.D[i, 2]
            p0, p1, p2 = P.O[i, 0] + t * d0, P.O[i, 1] + t * d1, P.O[i, 2] + t * d2
            dn = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
            lift = off_surface(unit, p0, p1, p2) / dn
            o0 = p0 + d0 * lift
            o1 = p1 + d1 * lift
            o2 = p2 + d2 * lift
            slot[kept] = j
            P.O[kept, 0], P.O[kept, 1], P.O[kept, 2] = o0, o1, o2
            P.D[kept, 0] = sh[j, SH_G] - o0
            P.D[kept, 1] = sh[j, SH_G + 1] - o1
            P.D[kept, 2] = sh[j, SH_G + 2] - o2
            P.cone[kept] = sh[j, SH_CONE]
            kept += 1
        n = kept
    return rays


@kernel
def bounce(pend, count, depths, top, depth, max_bounces, hits, sh, rgb):
    """Each surface adds the colour it keeps to its pixel and passes the rest on: its
    reflected ray into a packet at `top` of the stack, its refracted one into the
    packet above (traced first, in the order shade.py adds them). Returns the new
    top of the stack."""
    nr = 0
    nt = 0
    for j in range(hits):
        keep = 1.0
        w0, w1, w2 = sh[j, SH_W], sh[j, SH_W + 1], sh[j, SH_W + 2]
        if depth < max_bounces:
            u0, u1, u2 = sh[j, SH_U], sh[j, SH_U + 1], sh[j, SH_U + 2]
            n0, n1, n2 = sh[j, SH_N], sh[j, SH_N + 1], sh[j, SH_N + 2]
            ior, transmit = sh[j, SH_IOR], sh[j, SH_TRANS]
            cos_i = -(u0 * n0 + u1 * n1 + u2 * n2)
            eta = ior if sh[j, SH_INSIDE] > 0.0 else 1.0 / max(ior, 1e-9)
            kk = 1 - eta * eta * (1 - cos_i * cos_i)
            kr, kt = fresnel_split(cos_i, eta, sh[j, SH_REFL], transmit)
            w = max(w0, w1, w2)
            if kr * w > MIN_WEIGHT:
                keep -= kr
                _push(pend, top, nr, sh[j, SH_Q], sh[j, SH_Q + 1], sh[j, SH_Q + 2],
                      u0 + 2 * cos_i * n0, u1 + 2 * cos_i * n1, u2 + 2 * cos_i * n2,
                      w0 * kr, w1 * kr, w2 * kr, sh[j, SH_CONE], sh[j, SH_PIX])
                nr += 1
            if kt * w > MIN_WEIGHT:
                keep -= kt
                a = eta * cos_i - math.sqrt(max(kk, 0.0))
                e = sh[j, SH_LIFT]
                _push(pend, top + 1, nt, sh[j, SH_P] - n0 * e, sh[j, SH_P + 1] - n1 * e,
                      sh[j, SH_P + 2] - n2 * e, eta * u0 + a * n0, eta * u1 + a * n1,
                      eta * u2 + a * n2, w0 * kt, w1 * kt, w2 * kt, sh[j, SH_CONE],
                      sh[j, SH_PIX])
                nt += 1
        i = int(sh[j, SH_PIX])
        rgb[i, 0] += w0 * keep * sh[j, SH_C]
        rgb[i, 1] += w1 * keep * sh[j, SH_C + 1]
        rgb[i, 2] += w2 * keep * sh[j, SH_C + 2]
    count[top] = nr
    count[top + 1] = nt
    depths[top] = depth + 1
    depths[top + 1] = depth + 1
    if nt > 0:
        return top + 2
    if nr > 0:
        return top + 1
    return top


@kernel
def fresnel_split(cos_i, eta, reflect, transmit):
    """shade.fresnel_split for one surface."""
    c = min(max(cos_i, 0.0), 1.0)
    sin2 = eta * eta * (1 - c * c)
    if sin2 >= 1:
        return min(max(reflect + transmit, 0.0), 1.0), 0.0
    cos_t = math.sqrt(1 - sin2)
    rs = (eta * c - cos_t) / (eta * c + cos_t)
    rp = (c - eta * cos_t) / (c + eta * cos_t)
    f = 0.5 * (rs * rs + rp * rp)
    kr = min(max(reflect + transmit * f, 0.0), 1.0)
    return kr, min(transmit * (1 - f), 1 - kr)


@kernel
def _push(pend, p, k, o0, o1, o2, d0, d1, d2, w0, w1, w2, cone, pix):
    pend[p, k, P_O], pend[p, k, P_O + 1], pend[p, k, P_O + 2] = o0, o1, o2
    pend[p, k, P_D], pend[p, k, P_D + 1], pend[p, k, P_D + 2] = d0, d1, d2
    pend[p, k, P_W], pend[p, k, P_W + 1], pend[p, k, P_W + 2] = w0, w1, w2
    pend[p, k, P_CONE] = cone
    pend[p, k, P_PIX] = pix


@kernel
def pixel_shift(pixel_id, stream):
    """A pixel's shift (r1, r2) of a sample pattern, from its id in one stream."""
    h = splitmix64(np.uint64(pixel_id) ^ stream)
    return hash_to_unit(h), hash_to_unit(splitmix64(h))


@kernel
def shifted(k, n, r1, r2):
    """Point k of n of the pattern in the unit square, stratified in u, golden-ratio
    steps in v, shifted by (r1, r2) mod 1 (shade._shifted is its numpy)."""
    u = (k + 0.5) / n + r1
    u -= math.floor(u)
    v = k * GOLDEN + r2
    v -= math.floor(v)
    return u, v


@kernel
def disk(k, n, radius, r1, r2, x, y, z):
    """shade._disk: sample k of n on a disk of `radius` facing (x, y, z): stratified in
    area, golden-ratio angles, shifted by (r1, r2) mod 1 as the hemisphere's pattern is.
    One pattern for every pixel cast n hard shadows, one beside the other, in bands
    across a penumbra (the table tower's at 8 samples); shifted per pixel, they are noise
    that averages to the penumbra."""
    u, v = shifted(k, n, r1, r2)
    r = radius * math.sqrt(u)
    a = 2 * math.pi * v
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
    u, v = shifted(k, n, r1, r2)
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
