"""Rays walked together: the first-hit walk of walk.py for a packet of up to PACKET
neighbouring rays, so that what depends on the instance alone (its hash, calculation,
selection, map and table box) is done once per packet and only the box and primitive
tests once per ray.

A packet frame is one instance with the list of its rays that are still in its box,
each with its own window. The rays' local origins and directions live in ray blocks
(rows of R, one per ray): a frame reads the block it was given and writes its own
(block f + 1 for the frame at stack position f) when it meets a T-node. Frames are
popped last in, first out, so no live frame reads a block that a later one overwrites.

Where the rays of a frame stop agreeing on what to do (some go below their pixel and
others not, an ∩ or \\ node whose interval lists are per ray, a selection that reads
`pixels`) or only one ray is left, each goes on alone: the frame is copied into the
single-ray walk's first frame and walk.walk finishes it. A ray's hit is the nearest,
so the order in which the packet visits children (nearest box of any of its rays
first) changes only which of two surfaces at exactly the same t shows.
"""
from __future__ import annotations

from collections import namedtuple

import math

import numpy as np

from .dispatch import cached_jit
from ..graph.model import DIFFERENCE, INTERSECTION, PRIMITIVE, SELECT, TRANSFORM, UNION
from . import vm
from .jit import copy_into, inline, kernel
from .deferred import defer_step
from .nodes import (BOXED, CUT, DCALC, DPAINT, DX, EV_DEPTH, EV_LOD, EV_NONFINITE, EV_SELECTION,
                    EV_SINGULAR, EV_VISITS, F_WIDTH, I_WIDTH, INSIDE, INV, LEVEL, M0, MAT,
                    N_EVENTS, NAVG, NODE, OX, PAINT, PHASE, RAY_WIDTH, SLOT, T0, T1, axis_aligned,
                    child_hash, copy_frame, culprit, map_matrix, map_ray,
                    map_ray_scaled, note, pick_rule, powers_of_two, set_inverse, sort_visits,
                    transform_map)
from .normals import world_size
from .windows import (instance_slot, operand_entry, operand_slot, packet_box, slabs, state_slot,
                      volume_window)
from .simd import LANES, quad_windows
from .walk import finish, hit_primitive, hit_volume, step_unary, walk

# rays per packet: one 16x16 tile of image.tile_order. Per-instance work (hash,
# calculation, selection, map, table box) is shared by more rays than in the 64 (16x4
# pixels) it was: renders 8 to 16 % faster, 32 slower, 512 and 1024 no faster
# (tools/performance_notes.md)
PACKET = 256
FRAMES = 128            # packet frames; a deeper stack sends its rays on alone
# a frame's PHASE at or above ALONE: its rays go on alone when it is popped, their
# windows inside its box already, and BOXED as well where PHASE - ALONE says so
ALONE = 4
WAIT = -1               # pixel_split: frame g waits, marked ALONE
OVER = -2               # select: a ray may have passed its budget, uncounted (trace)
# a union of at most QUAD children, each bounded by a box, is split by split_quad
QUAD = LANES

Packet = namedtuple("Packet", [
    "F", "I", "H",      # the frames' shared columns (nodes.py layout; the ray columns unused)
    "block",            # the ray block each frame reads
    "params",           # the frames' parameter slots
    "R",                # ray blocks: row block * PACKET + k is ray k in that block's frame
                        # (nodes.py's ray columns only: OX, DX, INV)
    "act", "win", "n",  # per frame: its rays, their windows [t0, t1], how many
    "tact", "twin", "tn", "tkey", "tfar", "th", "tphase", "order",  # a union's
                        # children being sorted, by operand number: rays, windows, count,
                        # key (the nearest window start), the farthest window start, hash,
                        # PHASE; and the numbers of those some ray meets (enlist)
    "stamp",            # per frame: `epoch` when split pushed it (trace)
    "best", "hit", "visits", "dnorm",   # per ray (visits: see trace)
    "count",            # [selections the packet made, the most visits of one ray alone]
    "saved",            # the events as they were before the packet (trace)
    "O", "D", "cone",   # the packet's rays: world origin, direction, footprint at 0
    "quad",             # split_quad: its children's boxes, (x0, y0, z0, x1, y1, z1) x QUAD
])


@cached_jit(error_model="numpy")
def make_packet(flat):
    # split takes a union of at most FRAMES operands (its rays go on alone past that): rows
    # for more were 6 kB an operand a thread, 820 MB for a union of 120,000
    c = min(max(flat.max_children, QUAD), FRAMES)
    return Packet(
        np.empty((FRAMES, F_WIDTH)), np.zeros((FRAMES, I_WIDTH), dtype=np.int64),
        np.zeros(FRAMES, dtype=np.uint64), np.zeros(FRAMES, dtype=np.int64),
        np.full((FRAMES + 1, flat.n_params), np.nan),      # + the spare (trace/deferred.py)
        np.empty(((FRAMES + 1) * PACKET, RAY_WIDTH)),
        np.zeros((FRAMES, PACKET), dtype=np.int64), np.empty((FRAMES, PACKET, 2)),
        np.zeros(FRAMES, dtype=np.int64),
        np.zeros((c, PACKET), dtype=np.int64), np.empty((c, PACKET, 2)),
        np.zeros(c, dtype=np.int64), np.empty(c), np.empty(c),
        np.zeros(c, dtype=np.uint64), np.zeros(c, dtype=np.int64), np.zeros(c, dtype=np.int64),
        np.full(FRAMES, -1, dtype=np.int64),
        np.empty(PACKET), np.zeros(PACKET, dtype=np.bool_), np.zeros(PACKET, dtype=np.int64),
        np.empty(PACKET), np.zeros(2, dtype=np.int64),
        np.zeros((2 * N_EVENTS, flat.kind.shape[0]), dtype=np.int64),
        np.empty((PACKET, 3)), np.empty((PACKET, 3)), np.zeros(PACKET),
        np.zeros((6, QUAD)))


@inline
def alone(flat, P, g, j, phase, tmin, tmax, any_hit, lod, max_depth, S, ev, res, exact):
    """Ray number j of frame g finishes the frame's subtree on its own walk. The frame's
    window is inside its node's box already; `phase` says whether also BOXED. Returns
    False where the walk of a packet that does not count exactly (trace) ran out of
    visits: it may have stopped where the ray's own count would not have.

    Inlined at one place in `trace`, where frames marked ALONE are popped: called, it
    took the Flat, Packet and Scratch tuples by value, 5 kB pushed on the stack per call,
    a tenth of the terrain's trace time (tools/profile_trace.py)."""
    k = P.act[g, j]
    row = P.block[g] * PACKET + k
    F, I, H = S.F, S.I, S.H
    copy_into(F[0], P.F[g])
    copy_into(F[0, :RAY_WIDTH], P.R[row])     # the frame's own ray columns come first
    F[0, T0] = P.win[g, j, 0]
    F[0, T1] = P.win[g, j, 1]
    copy_into(I[0], P.I[g])
    I[0, PHASE] = phase
    I[0, SLOT] = 0
    src = P.I[g, SLOT]
    copy_into(S.params[0], P.params[src])
    H[0] = P.H[g]
    # not counting exactly, the walk starts from a bound on the ray's count (trace)
    base = 0 if exact else P.count[0]
    S.visits[0] = base + P.visits[k]
    found, t = walk(flat, 1, P.best[k], tmin, tmax, any_hit, lod, P.cone[k], P.dnorm[k],
                    P.D[k, 0], P.D[k, 1], P.D[k, 2], max_depth, S, ev, res, k)
    P.visits[k] = S.visits[0] - base
    P.count[1] = max(P.count[1], P.visits[k])
    if found:
        P.hit[k] = True
        P.best[k] = -np.inf if any_hit else t
    return exact or S.visits[0] <= S.visits[1]


@inline
def note_all(ev, kind, node, level, count):
    for _ in range(count):
        note(ev, kind, node, level)


@kernel
def trace(flat, n, tmin, tmax, any_hit, lod, max_depth, S, P, together, ev, res):
    """The nearest hits of the packet's rays P.O[k], P.D[k] with footprints P.cone[k]
    (k < n) into res[k]. Without `together` every ray walks alone from the root.

    A ray may enter S.visits[1] S-node instances (--max-instances). Counting each ray's
    entries is a loop over the frame's rays at every selection; yet no ray can pass the
    budget while the packet's selections and the most entries of one ray on its own walks
    (P.count) do not. So the packet first counts only those (`exact` False), and where they
    pass the budget it walks again from the start, its events as they were, counting every
    ray's entries (P.visits): the same hits and events either way. One loop around one
    body, not a walk called twice: as a function of its own, called or inlined, the walk
    took the kernels' compile from 7 to 13 minutes and more."""
    for r in range(ev.shape[0]):
        copy_into(P.saved[r], ev[r])
    exact = False
    while True:
        F, I, H, R = P.F, P.I, P.H, P.R
        act, win, cnt, best = P.act, P.win, P.n, P.best
        has_table = flat.inst_used.shape[0] > 2 and flat.by_state == 0   # keyed by path
        for c in range(9):
            F[0, M0 + c] = 1.0 if c % 4 == 0 else 0.0
        for c in range(3):
            F[0, PAINT + c] = np.nan
            F[0, NAVG + c] = 0.0
        F[0, T0] = tmax
        I[0, NODE] = flat.root
        I[0, SLOT] = 0
        I[0, LEVEL] = 0
        I[0, MAT] = -1
        I[0, CUT] = 0
        I[0, DCALC] = -1
        I[0, DPAINT] = -1
        I[0, PHASE] = 0
        H[0] = vm.ROOT_HASH
        P.block[0] = 0
        for p in range(P.params.shape[1]):
            P.params[0, p] = np.nan
        for k in range(n):
            for c in range(3):
                R[k, OX + c] = P.O[k, c]
                R[k, DX + c] = P.D[k, c]
            set_inverse(R, k)
            act[0, k] = k
            win[0, k, 0] = tmin
            win[0, k, 1] = tmax
            best[k] = tmax
            P.hit[k] = False
            P.visits[k] = 0
            P.dnorm[k] = math.sqrt(P.D[k, 0] ** 2 + P.D[k, 1] ** 2 + P.D[k, 2] ** 2)
        cnt[0] = n
        P.count[0] = 0
        P.count[1] = 0
        dmax = 0.0
        cmax = 0.0
        for k in range(n):
            dmax = max(dmax, P.dnorm[k])
            cmax = max(cmax, P.cone[k])
        budget = S.visits[1]
        # --stack-depth bounds the packet's pending frames too, and then each ray's own walk
        cap = min(FRAMES, S.F.shape[0])
        # counts the places where some ray's nearest hit may have come nearer: a frame that
        # split pushed at the same epoch has its windows cut to its rays' hits already
        epoch = 0
        P.stamp[0] = -1
        sp = 1
        aborted = False
        while sp > 0:
            sp -= 1
            g = sp
            if I[g, PHASE] >= ALONE:
                for j in range(cnt[g]):
                    if not alone(flat, P, g, j, I[g, PHASE] - ALONE, tmin, tmax, any_hit, lod,
                                 max_depth, S, ev, res, exact):
                        aborted = True
                        break
                if aborted:
                    break
                epoch += 1
                continue
            boxed = I[g, PHASE] == BOXED
            within = I[g, PHASE] != 0
            # whether the rays' windows have been cut to their nearest hits since the frame was
            # popped: no ray that stays in a frame finds a hit while it follows single-child
            # nodes, so once is enough where there is no box to test. A frame popped at the
            # epoch it was pushed in needs no cut: the nearest child of a union, which is
            # popped at once, and the others where their elder siblings hit nothing
            pruned = P.stamp[g] == epoch
            while True:         # follow single-child nodes in place
                node = I[g, NODE]
                kind = flat.kind[node]
                blk = P.block[g] * PACKET
                slot = -1
                if kind == SELECT and has_table and not boxed:
                    slot = instance_slot(flat, node, H[g], I, g)
                if kind == SELECT:
                    test = I[g, PHASE] == 0 and not boxed
                else:
                    test = not within
                I[g, PHASE] = 0
                within = True
                use, x0, y0, z0, x1, y1, z1 = packet_box(flat, node, slot, test)
                done = use == 2 and pruned        # no box, and the windows cut already
                pruned = True
                m = cnt[g] if done else 0
                far = -np.inf
                for j in range(0 if done or use < 0 else cnt[g]):
                    k = act[g, j]
                    t0 = win[g, j, 0]
                    t1 = min(win[g, j, 1], best[k])
                    if use != 2:
                        if use == 1:
                            b0, b1 = slabs(x0, y0, z0, x1, y1, z1, R, blk + k)
                        else:
                            b0, b1 = volume_window(flat, node, slot, R, blk + k)
                        t0 = max(t0, b0)
                        t1 = min(t1, b1)
                        far = max(far, t0 if t0 <= t1 else -np.inf)
                    keep_ray(act, win, g, m, k, t0, t1)
                    m += t0 <= t1
                cnt[g] = m
                if use != 2 and m > 0:
                    F[g, T0] = far
                if m == 0:
                    break
                phase = BOXED if boxed else INSIDE
                if (not together or m == 1 or kind == INTERSECTION or kind == DIFFERENCE
                        or (kind == SELECT and flat.pixels_slot >= 0)
                        or (kind == UNION and sp + flat.child_count[node] > cap)):
                    I[g, PHASE] = ALONE + phase
                    sp += 1
                    break
                if kind == PRIMITIVE:
                    for j in range(m):
                        k = act[g, j]
                        t = hit_primitive(flat, node, R, blk + k, F, I, H, g, P.params, tmin,
                                          win[g, j, 1], best[k], lod, P.cone[k], P.dnorm[k],
                                          P.D[k, 0], P.D[k, 1], P.D[k, 2], S, ev, res, k)
                        if t < best[k]:
                            P.hit[k] = True
                            best[k] = -np.inf if any_hit else t
                    epoch += 1
                    break
                if kind == SELECT:
                    on, below_all = pixel_split(flat, node, P, g, phase, cap, lod, lod * dmax,
                                                cmax, max_depth)
                    if on == WAIT:
                        sp += 1
                        break
                    g = on
                    sp = on         # frames 0..g-1 wait: the rays split off at g - 1 too
                    e = select(flat, node, P, g, blk, below_all, tmin, any_hit, budget,
                               max_depth, S, ev, res, exact)
                    if e == OVER:
                        aborted = True
                        sp = 0
                        break
                    if e < 0:
                        epoch += 1      # it may have hit boxes
                        break
                    boxed = False
                    within = flat.holds[e] != 0
                    continue
                if kind == UNION:
                    used = split(flat, node, P, g, blk, has_table)
                    for d in range(g, g + used):
                        P.stamp[d] = epoch
                    sp += used
                    break
                if kind == TRANSFORM:
                    bad = transform_map(flat, node, P.params, I[g, SLOT], H[g], S.stack, S.args,
                                        S.m34, S.m21)
                    L = S.m21
                    if bad != 0:
                        note_all(ev, EV_NONFINITE if bad == 1 else EV_SINGULAR,
                                 culprit(flat, node, P.params, I[g, SLOT], H[g], S.stack, S.args,
                                         S.m34, bad), I[g, LEVEL], m)
                        break
                    own = (g + 1) * PACKET
                    within = axis_aligned(L)
                    if within and powers_of_two(L):
                        for j in range(m):
                            k = act[g, j]
                            map_ray_scaled(L, R, blk + k, R, own + k)
                    else:
                        for j in range(m):
                            k = act[g, j]
                            map_ray(L, R, blk + k, R, own + k)
                    P.block[g] = g + 1
                    map_matrix(L, F, g)
                    boxed = boxed and within
                    I[g, NODE] = flat.children[flat.child_start[node]]
                    continue
                if defer_step(flat, node, kind, I, g):
                    continue
                if not step_unary(flat, node, kind, F, I, H, g, P.params, 0, S, ev):
                    break
        if not aborted or exact:
            break
        for r in range(ev.shape[0]):
            copy_into(ev[r], P.saved[r])
        exact = True
    for k in range(n):
        finish(res, k, P.hit[k])


@inline
def pixel_split(flat, node, P, g, phase, cap, lod, reach, widest, max_depth):
    """At an S-node the rays for which the instance is below their pixel stop refining.
    If only some are, frame g keeps those, marked ALONE, and a copy of it at g + 1 takes
    the others: returns (the frame that goes on: g, g + 1, or WAIT where there is no
    room above g and frame g, all its rays marked ALONE, is to be pushed again; whether
    all its rays are below their pixel). `reach` is lod times the packet's largest
    direction length, `widest` its largest cone (walk.choose_rule's footprint)."""
    F, I, H, act, win = P.F, P.I, P.H, P.act, P.win
    m = P.n[g]
    if I[g, CUT] != 0 or I[g, LEVEL] + 1 > max_depth or lod <= 0.0:
        return g, False
    size = world_size(flat.box, node, F, g)
    # F[g, T0] bounds the window starts of the frame's rays, so no ray's footprint where
    # it enters can pass this one (products of non-negative factors round monotonically):
    # most instances are far above every pixel (a terrain patch's box spans all its
    # heights), and the loop below would go over every ray of the frame
    if size >= widest + reach * max(F[g, T0], 0.0):
        return g, False
    below = 0
    for j in range(m):
        below += below_pixel(size, lod, P, g, j)
    if below == 0 or below == m:
        return g, below == m
    d = g + 1
    if d < cap:
        copy_frame(F, I, H, g, d)
        P.block[d] = P.block[g]
    I[g, PHASE] = ALONE + phase
    if d >= cap:
        return WAIT, False
    b = 0
    q = 0
    for j in range(m):
        k = act[g, j]
        if below_pixel(size, lod, P, g, j):
            f, i = g, b
            b += 1
        else:
            f, i = d, q
            q += 1
        act[f, i] = k
        win[f, i, 0] = win[g, j, 0]
        win[f, i, 1] = win[g, j, 1]
    P.n[g] = b
    P.n[d] = q
    return d, False


@inline
def below_pixel(size, lod, P, g, j):
    """Whether an instance of world size `size` is below the pixel of frame g's ray j
    where it enters the instance (its cone and lod over its length, as walk.choose_rule)."""
    k = P.act[g, j]
    return size < P.cone[k] + lod * P.dnorm[k] * max(P.win[g, j, 0], 0.0)


@inline
def select(flat, node, P, g, blk, below_all, tmin, any_hit, budget, max_depth, S, ev, res,
           exact):
    """choose_rule for the packet at an S-node, its rays' windows narrowed to its boxes
    already (and pixel_split past): the chosen rule's entry in flat.children, -1 if the
    frame ends here, OVER if some ray may have passed its budget of entries and the packet
    does not count them exactly (trace)."""
    F, I, H, R, act, win = P.F, P.I, P.H, P.R, P.act, P.win
    m = P.n[g]
    level = I[g, LEVEL] + 1
    over = False
    if exact:
        for j in range(m):
            k = act[g, j]
            P.visits[k] += 1
            over |= P.visits[k] > budget
    else:
        P.count[0] += 1
        if P.count[0] + P.count[1] > budget:
            return OVER
    if over:        # rarely: the frame keeps every ray, and its list is not rewritten
        q = 0
        for j in range(m):
            k = act[g, j]
            if P.visits[k] > budget:
                if P.visits[k] == budget + 1:
                    note(ev, EV_VISITS, node, level)
                continue
            act[g, q] = k
            win[g, q, 0] = win[g, j, 0]
            win[g, q, 1] = win[g, j, 1]
            q += 1
        m = q
        P.n[g] = m
    I[g, LEVEL] = level
    if m == 0:
        return -1
    if I[g, CUT] == 0 and level > max_depth:
        I[g, CUT] = 1
        note_all(ev, EV_DEPTH, node, level, m)
    elif below_all:
        I[g, CUT] = 1
        note_all(ev, EV_LOD, node, level, m)
    if I[g, CUT] == 1:
        r = flat.term_rule[node]
        if r < 0:
            for j in range(m):
                k = act[g, j]
                t0 = win[g, j, 0]
                if t0 > tmin and t0 < P.best[k]:
                    hit_volume(flat, node, R, blk + k, F, I, g, t0, 0.0, 0.0, 0.0, res, k)
                    P.hit[k] = True
                    P.best[k] = -np.inf if any_hit else t0
            return -1
        if level > 4 * max_depth + 64:
            return -1
    else:
        r = pick_rule(flat, node, P.params, I[g, SLOT], H[g], S.stack)
        if r < 0:
            note_all(ev, EV_SELECTION, node, level, m)
            return -1
        if flat.by_state != 0:
            slot = state_slot(flat, node, P.params, I[g, SLOT])
            if slot >= 0 and narrow(flat, P, g, slot, blk) == 0:
                return -1
    if flat.hashed:
        H[g] = vm.edge_hash(H[g], node, r)
    e = flat.child_start[node] + r
    I[g, NODE] = flat.children[e]
    return e


@inline
def keep_ray(act, win, f, q, k, t0, t1):
    """Ray k with window [t0, t1] as frame f's ray number q, written whether or not the
    window is empty: the caller counts it only if not (q += t0 <= t1). A third to two
    thirds of the rays leave at each box test, which no branch predicts."""
    act[f, q] = k
    win[f, q, 0] = t0
    win[f, q, 1] = t1


@inline
def narrow(flat, P, g, slot, blk):
    """Keeps frame g's rays that meet the table's box `slot`, their windows narrowed to
    it: returns how many."""
    act, win, R = P.act, P.win, P.R
    use, x0, y0, z0, x1, y1, z1 = packet_box(flat, 0, slot, False)
    q = 0
    far = -np.inf
    for j in range(P.n[g] if use == 1 else 0):
        k = act[g, j]
        b0, b1 = slabs(x0, y0, z0, x1, y1, z1, R, blk + k)
        t0 = max(win[g, j, 0], b0)
        t1 = min(win[g, j, 1], b1)
        keep_ray(act, win, g, q, k, t0, t1)
        far = max(far, t0 if t0 <= t1 else -np.inf)
        q += t0 <= t1
    P.n[g] = q
    P.F[g, T0] = far
    return q


@inline
def split(flat, node, P, g, blk, has_table):
    """A union's children that some of frame g's rays enter, pushed at g, g+1, ...
    (nearest entry on top): returns how many."""
    F, I, H, act, win = P.F, P.I, P.H, P.act, P.win
    tact, twin, tn, th, order = P.tact, P.twin, P.tn, P.th, P.order
    used = -1
    if flat.child_count[node] <= QUAD:
        used = split_quad(flat, node, P, g, blk, has_table)
    if used < 0:
        used = split_each(flat, node, P, g, blk, has_table)
    sort_visits(flat, node, order, used, P.tkey)
    for j in range(used - 1, -1, -1):      # the source frame g is overwritten last
        d = g + j
        u = order[j]
        copy_frame(F, I, H, g, d)
        I[d, NODE] = flat.children[flat.child_start[node] + u]
        I[d, PHASE] = P.tphase[u]
        F[d, T0] = P.tfar[u]
        H[d] = th[u]
        P.block[d] = P.block[g]
        P.n[d] = tn[u]
        for q in range(tn[u]):
            act[d, q] = tact[u, q]
            win[d, q, 0] = twin[u, q, 0]
            win[d, q, 1] = twin[u, q, 1]
    return used


@inline
def operand_box(flat, node, P, g, k, has_table):
    """Operand k of frame g's union: (its node, its table slot or -1, the PHASE of its
    frame once pushed, packet_box of it)."""
    c = flat.children[flat.child_start[node] + k]
    if has_table:
        slot = operand_entry(flat, node, P.H[g], k, P.I[g, LEVEL])
    else:
        slot = operand_slot(flat, c, P.params, P.I, g)
    use, x0, y0, z0, x1, y1, z1 = packet_box(flat, c, slot, True)
    phase = BOXED if has_table and slot >= 0 else INSIDE
    return c, slot, phase, use, x0, y0, z0, x1, y1, z1


@inline
def split_each(flat, node, P, g, blk, has_table):
    """The children of split's union into P.order (see enlist), one child after another
    (each ray read once per child): returns how many some ray enters."""
    R, act, win, tact, twin = P.R, P.act, P.win, P.tact, P.twin
    m = P.n[g]
    used = 0
    for k in range(flat.child_count[node]):
        c, slot, phase, use, x0, y0, z0, x1, y1, z1 = operand_box(flat, node, P, g, k,
                                                                    has_table)
        q = 0
        near = np.inf
        far = -np.inf
        for j in range(m if use >= 0 else 0):
            ray = act[g, j]
            if use == 1:
                e0, e1 = slabs(x0, y0, z0, x1, y1, z1, R, blk + ray)
            else:
                e0, e1 = volume_window(flat, c, slot, R, blk + ray)
            e0 = max(e0, win[g, j, 0])
            e1 = min(e1, win[g, j, 1])
            keep_ray(tact, twin, k, q, ray, e0, e1)
            near = min(near, e0 if e0 <= e1 else np.inf)
            far = max(far, e0 if e0 <= e1 else -np.inf)
            q += e0 <= e1
        if q > 0:
            P.tphase[k] = phase
            enlist(flat, node, P, g, k, q, near, far, used)
            used += 1
    return used


@inline
def enlist(flat, node, P, g, k, q, near, far, used):
    """Child k of the union, met by the q rays of row k of P.tact / P.twin (the nearest
    entry at `near`, the farthest at `far`; its PHASE in P.tphase[k] already), into
    P.order after the `used` children listed before it (split sorts them)."""
    P.tn[k] = q
    P.tfar[k] = far
    P.th[k] = child_hash(flat, P.H[g], node, k)
    P.tkey[k] = near
    P.order[used] = k


@inline
def split_quad(flat, node, P, g, blk, has_table):
    """split_each for a union of at most QUAD children that boxes bound (the terrain's
    four sub-triangles, the Sierpinski tetrahedron's four corners): each ray is read once
    and tested against the QUAD boxes at once, in vector instructions (simd.py); a union
    of fewer children tests empty lanes too, and lists none of them. Returns how many
    children some ray enters; -1 where a sphere bounds a child (split_each does it)."""
    n = flat.child_count[node]
    B = P.quad
    live = 0                        # bit k: child k has a box that is not empty
    for k in range(QUAD):
        use = -1
        if k < n:
            _, _, phase, use, x0, y0, z0, x1, y1, z1 = operand_box(flat, node, P, g, k,
                                                                   has_table)
            if use == 0:
                return -1
            if use == 1:
                live |= 1 << k
                B[0, k], B[1, k], B[2, k], B[3, k], B[4, k], B[5, k] = x0, y0, z0, x1, y1, z1
                P.tphase[k] = phase
        if use != 1:
            for a in range(6):
                B[a, k] = 0.0           # a lane tested, and not listed
    act, win, R, tact, twin = P.act, P.win, P.R, P.tact, P.twin
    q0, q1, q2, q3 = 0, 0, 0, 0
    for j in range(P.n[g]):
        ray = act[g, j]
        r = blk + ray
        ox, oy, oz = R[r, OX], R[r, OX + 1], R[r, OX + 2]
        ix, iy, iz = R[r, INV], R[r, INV + 1], R[r, INV + 2]
        w0, w1 = win[g, j, 0], win[g, j, 1]
        a0, b0, c0, d0, a1, b1, c1, d1 = quad_windows(B, ox, oy, oz, ix, iy, iz, w0, w1)
        keep_ray(tact, twin, 0, q0, ray, a0, a1)
        keep_ray(tact, twin, 1, q1, ray, b0, b1)
        keep_ray(tact, twin, 2, q2, ray, c0, c1)
        keep_ray(tact, twin, 3, q3, ray, d0, d1)
        q0 += a0 <= a1
        q1 += b0 <= b1
        q2 += c0 <= c1
        q3 += d0 <= d1
    used = 0
    for k in range(n):
        q = (q0, q1, q2, q3)[k] if live >> k & 1 else 0
        if q == 0:
            continue
        near = np.inf
        far = -np.inf
        for j in range(q):
            near = min(near, twin[k, j, 0])
            far = max(far, twin[k, j, 0])
        enlist(flat, node, P, g, k, q, near, far, used)
        used += 1
    return used
