"""The per-ray walks over the cyclic graph (njit, explicit stacks, no recursion).

`walk` finds the nearest surface: union children are visited nearest box
first, the cheap ones before the others (nodes.sort_visits), and anything beyond the best
hit so far is skipped (Bekaert & Willems §3.1). At an ∩ or \\ node it asks `intervals` for that subtree's sorted interval
list along the ray (Roth 1982), so both work on recursive operands too.
"""
from __future__ import annotations

import numpy as np

from ..graph.model import (CALC, DIFFERENCE, INTERSECTION, MATERIAL, PAINT as PAINT_NODE,
                           PRIMITIVE, SELECT, TRANSFORM, UNION)
from . import vm
from .jit import copy_into, inline, kernel
from .nodes import (BOXED, CUT, DX, EV_DEPTH, EV_INTERVALS, EV_LOD, EV_NONFINITE, EV_SELECTION,
                    EV_SINGULAR, EV_STACK, EV_VISITS, INSIDE, DPAINT, LEVEL, MAT, NODE, OX, PAINT,
                    PHASE, SLOT, T0, T1, axis_aligned, child_hash,
                    copy_frame, culprit, enter_paint, enter_transform, note, pick_rule,
                    sort_visits, cached_calc)
from .normals import (average_box_normal, footprint_scale, world_diameter, world_normal,
                      world_size)
from .windows import (box_window, entry_window, instance_slot, operand_entry, node_window,
                      instance_window, operand_slot, state_window, volume_window,
                      volume_normal)
from .deferred import defer_step, deferred_paint
from .fractals import march
from .primitives import FRACTAL_MIN, JULIA, intersect
from .scratch import IV_WIDTH


SLIVER = 1e-9           # relative thickness below which ∩ and \ pieces are slivers
BY_TREE = 1 << 40       # added to the PHASE of an operator that walks by its operand tree
FLAT_MIN = 6            # primitive codes >= this have a surface only: triangles, fractals
# interval record columns: an interval is [t_in, t_out] with what is at each end
IT_IN, IT_OUT, IN_N, OUT_N, IN_PAINT, OUT_PAINT, IN_MAT, OUT_MAT = 0, 1, 2, 5, 8, 11, 14, 15
# what a ray's result row holds
R_T, R_N, R_PAINT, R_MAT, R_HIT = 0, 1, 4, 7, 8
R_WIDTH = 9
# R_HIT: 0 a miss, else what was hit: a solid; a flat triangle, a sheet without thickness
# (what passes through it goes on unbent); a surface without an inside, which a ray cannot
# pass through (a fractal traced to its first surface, a graftal's instance at pixel size)
HIT_SOLID, HIT_SHEET, HIT_SHELL = 1.0, 2.0, 3.0


@inline
def choose_rule(flat, node, F, I, H, f, S, lod, cone, dnorm, max_depth, t_enter, ev):
    """The S-node's rule for frame f: >= 0 a rule, -1 the instance is empty, -2 hit its box.
    Past the depth bound or below the pixel footprint the walk stops refining and
    follows the rule that ends soonest (graph/terminating.py). A selection that reads
    `pixels` finds there the diameter of the instance's box over the pixel footprint
    where the ray enters it. The footprint is the beam's from the eye (Bekaert & Willems
    §3.1): `cone`, its width where a shadow or reflected ray leaves a surface, grown by
    lod over the ray's length; without the cone, a shadow ray leaving the ground beside an
    object saw it tens of pixels large, and its shadow was the other rule's (QA: a ball
    cast the shadow of a cross, the pixel forest's crowns the shadows of branches). Past
    the ray's budget of instances every instance is empty, so that the walk ends."""
    params, stack, visits = S.params, S.stack, S.visits
    level = I[f, LEVEL] + 1
    I[f, LEVEL] = level
    visits[0] += 1
    if visits[0] > visits[1]:
        if visits[0] == visits[1] + 1:
            note(ev, EV_VISITS, node, level)
        return -1
    if I[f, CUT] == 0:
        if level > max_depth:
            I[f, CUT] = 1
            note(ev, EV_DEPTH, node, level)
        elif lod > 0.0 and world_size(flat.box, node, F, f) < \
                cone + lod * dnorm * max(t_enter, 0.0):
            I[f, CUT] = 1
            note(ev, EV_LOD, node, level)
    if I[f, CUT] == 1:
        r = flat.term_rule[node]
        if r < 0:
            return -2
        if level > 4 * max_depth + 64:      # a terminating rule that keeps recursing
            return -1
        return r
    if flat.pixels_slot >= 0:
        foot = cone + lod * dnorm * max(t_enter, 0.0) if lod > 0.0 else 0.0
        params[I[f, SLOT], flat.pixels_slot] = (world_diameter(flat.box, node, F, f) / foot
                                                if foot > 0.0 else np.inf)
    r = pick_rule(flat, node, params, I[f, SLOT], H[f], stack)
    if r < 0:
        note(ev, EV_SELECTION, node, level)
        return -1
    return r


@inline
def enter_child(flat, node, k, F, I, H, src, dst):
    copy_frame(F, I, H, src, dst)
    I[dst, NODE] = flat.children[flat.child_start[node] + k]
    I[dst, PHASE] = 0
    H[dst] = child_hash(flat, H[src], node, k)


@inline
def step_unary(flat, node, kind, F, I, H, f, params, slot_base, S, ev):
    """S-free single-child nodes, in place on frame f: True if the walk goes on.
    `params` holds the frames' parameter slots (the walk's own: S.params, or a packet's)."""
    stack, args, m34 = S.stack, S.args, S.m34
    if kind == TRANSFORM:
        bad = enter_transform(flat, node, F, f, params, I[f, SLOT], H[f], stack, args, m34,
                              S.m21)
        if bad != 0:
            note(ev, EV_NONFINITE if bad == 1 else EV_SINGULAR,
                 culprit(flat, node, params, I[f, SLOT], H[f], stack, args, m34, bad),
                 I[f, LEVEL])
            return False
    elif kind == CALC:
        cached_calc(flat, node, params, I[f, SLOT], slot_base + f, H[f], stack, S.ckeys,
                    S.cvals)
        I[f, SLOT] = slot_base + f
    elif kind == PAINT_NODE:
        if not enter_paint(flat, node, F, f, params, I[f, SLOT], H[f], stack, args):
            note(ev, EV_NONFINITE, node, I[f, LEVEL])
            return False
        I[f, DPAINT] = -1           # it paints over a passed one
    elif kind == MATERIAL:
        I[f, MAT] = flat.code[node]
        if flat.fixed[node]:        # its own colour, which paints over a paint above
            for c in range(3):
                F[f, PAINT + c] = flat.fixed_map[node, c]
            I[f, DPAINT] = -1
    I[f, NODE] = flat.children[flat.child_start[node]]
    return True


@inline
def set_end(iv, row, side, t, F, I, f, nx, ny, nz):
    """Fill one end (0 = in, 1 = out) of interval `row` with t, world normal, paint, material."""
    iv[row, IT_IN + side] = t
    world_normal(F, f, nx, ny, nz, iv, row, IN_N + 3 * side)
    for c in range(3):
        iv[row, IN_PAINT + 3 * side + c] = F[f, PAINT + c]
    iv[row, IN_MAT + side] = I[f, MAT]


@kernel
def _state(op, ina, inb):
    if op == 0:
        return ina or inb
    if op == 1:
        return ina and inb
    return ina and not inb


@kernel
def combine(iv, a0, na, b0, nb, out0, op):
    """Roth's interval CSG of the lists at a0 (na) and b0 (nb) into out0; returns the count.
    op: 0 union, 1 intersection, 2 difference (the ends taken from b show its inside).
    All ends at one t are applied together before the state is compared, so that
    coincident surfaces (A \\ A) leave no zero-length sliver."""
    ia = 0
    ib = 0
    ina = False
    inb = False
    inside = False
    n = 0
    while ia < 2 * na or ib < 2 * nb:
        ta = iv[a0 + ia // 2, IT_IN + ia % 2] if ia < 2 * na else np.inf
        tb = iv[b0 + ib // 2, IT_IN + ib % 2] if ib < 2 * nb else np.inf
        t = min(ta, tb)
        src_a = -1
        while ia < 2 * na and iv[a0 + ia // 2, IT_IN + ia % 2] == t:
            src_a = ia
            ina = ia % 2 == 0
            ia += 1
        src_b = -1
        while ib < 2 * nb and iv[b0 + ib // 2, IT_IN + ib % 2] == t:
            src_b = ib
            inb = ib % 2 == 0
            ib += 1
        now = _state(op, ina, inb)
        if now == inside:
            continue
        inside = now
        # coincident surfaces: the first operand's wins, as in the reference
        from_a = src_a >= 0
        if from_a:
            src, side = a0 + src_a // 2, src_a % 2
        else:
            src, side = b0 + src_b // 2, src_b % 2
        end = 0 if now else 1
        row = out0 + n
        iv[row, IT_IN + end] = t
        flip = -1.0 if (op == 2 and not from_a) else 1.0
        for c in range(3):
            iv[row, IN_N + 3 * end + c] = flip * iv[src, IN_N + 3 * side + c]
            iv[row, IN_PAINT + 3 * end + c] = iv[src, IN_PAINT + 3 * side + c]
        iv[row, IN_MAT + end] = iv[src, IN_MAT + side]
        if end == 1:
            # ∩ and \ drop slivers: coincident surfaces that rounding pulled apart
            if op == 0 or thick(iv[row, IT_IN], t):
                n += 1
    return n


@kernel
def thick(s, e):
    """Whether a piece of an ∩ or \\ from s to e is more than a sliver: coincident surfaces
    that rounding pulled apart are a few roundings of their t apart, at any scale. With a
    floor of SLIVER below t = 1, a solid of a scene 1e-9 across was a sliver, and drawn
    as nothing. The reference drops the same pieces (trace/reference.py)."""
    if e == np.inf:
        return s < e
    return e - s > SLIVER * max(abs(s), abs(e))


@inline
def next_leaf(flat, row, end, F, f, t0, t1):
    """The first leaf of an operand tree (graph/operand_trees.py) from `row` on, before
    `end`, whose box and the boxes above it frame f's window [t0, t1] meets; end if none."""
    while row < end:
        b0, b1 = box_window(flat.tree_box, row, F, f)
        if max(b0, t0) > min(b1, t1):
            row = flat.tree_skip[row]
        elif flat.tree_count[row] > 0:
            return row
        else:
            row += 1
    return end


@inline
def leaf_span(flat, row, end):
    """The operands of an operand tree's leaf `row`: tree_items[first:stop]; none past
    the tree's `end`."""
    if row >= end:
        return 0, 0
    first = flat.tree_first[row]
    return first, first + flat.tree_count[row]


@kernel
def candidates(flat, node, F, f, cands, start):
    """The operands of the union `node` with a tree whose tree boxes frame f's window
    meets (of a difference: its first operand, and such subtrahends), into cands from
    `start` on, sorted by number: the ones among which the loop over every operand finds
    a list that is not empty. Returns how many, -1 where cands runs out (then the loop
    over every operand does: the interval rows are the loop's, and so is what it does
    where they run out)."""
    t0, t1 = F[f, T0], F[f, T1]
    row = flat.tree_root[node]
    end = flat.tree_skip[row]
    m = 0
    if flat.kind[node] == DIFFERENCE:   # its tree holds the subtrahends
        if start >= cands.shape[0]:
            return -1
        cands[start] = 0
        m = 1
    row = next_leaf(flat, row, end, F, f, t0, t1)
    while row < end:
        first, stop = leaf_span(flat, row, end)
        for j in range(first, stop):
            if start + m >= cands.shape[0]:
                return -1
            cands[start + m] = flat.tree_items[j]
            m += 1
        row = next_leaf(flat, row + 1, end, F, f, t0, t1)
    # a heap sort: a ray may pass through the boxes of thousands of operands
    for root in range(m // 2 - 1, -1, -1):
        sift_candidate(cands, start, root, m)
    for last in range(m - 1, 0, -1):
        cands[start], cands[start + last] = cands[start + last], cands[start]
        sift_candidate(cands, start, 0, last)
    return m


@inline
def sift_candidate(cands, start, root, end):
    while True:
        c = 2 * root + 1
        if c >= end:
            return
        if c + 1 < end and cands[start + c + 1] > cands[start + c]:
            c += 1
        if cands[start + root] >= cands[start + c]:
            return
        cands[start + root], cands[start + c] = cands[start + c], cands[start + root]
        root = c


@kernel
def push_list(lists, ls, start, count):
    """Put a finished subtree's interval list (rows start..start+count) on the list stack."""
    lists[ls, 0] = start
    lists[ls, 1] = count
    return ls + 1


@kernel
def intervals(flat, F0, I0, H0, f0, tmin, tmax, S, lod, cone, dnorm, max_depth, ev):
    """The interval list of frame f0's subtree along [tmin, tmax], computed bottom-up
    with an explicit stack; operators keep a phase (the next child) while their children
    run. Returns (start row in S.iv, count).

    It starts from [tmin, tmax], not from the caller's window, which holds the nearest
    hit so far: the pieces must not depend on which instance was walked first. The boxes
    on the way only cull: a primitive's interval is clipped to [tmin, tmax], as the
    reference clips it. A piece clipped at a box or a hit would be shorter, and ∩ and \\
    drop pieces shorter than SLIVER."""
    params, out8, cands = S.params, S.out8, S.cands
    F, I, H, iv, lists = S.Fi, S.Ii, S.Hi, S.iv, S.lists
    slot_base = S.F.shape[0]
    cap_f = F.shape[0]
    cap_iv = iv.shape[0]
    copy_into(F[0], F0[f0])
    copy_into(I[0], I0[f0])
    H[0] = H0[f0]
    F[0, T0] = tmin
    F[0, T1] = tmax
    I[0, PHASE] = 0
    sp = 1              # frames
    ls = 0              # lists: rows [start, count]
    top = 0             # first free interval row
    ct = 0              # first free entry of cands
    while sp > 0:
        f = sp - 1
        node = I[f, NODE]
        kind = flat.kind[node]
        phase = I[f, PHASE]
        if phase == 0:
            b0, b1 = node_window(flat, node, F, f)
            t0 = max(F[f, T0], b0)
            t1 = min(F[f, T1], b1)
            if t0 > t1:
                ls = push_list(lists, ls, top, 0)
                sp -= 1
                continue
            F[f, T0] = t0
            F[f, T1] = t1
            if kind == PRIMITIVE:
                n = 0
                r = out8
                met = intersect(flat.code[node], F[f, OX], F[f, OX + 1], F[f, OX + 2],
                                F[f, DX], F[f, DX + 1], F[f, DX + 2], r)
                if met and max(r[0], t0) <= min(r[1], t1):
                    if top < cap_iv:
                        set_end(iv, top, 0, max(r[0], tmin), F, I, f, r[2], r[3], r[4])
                        set_end(iv, top, 1, min(r[1], tmax), F, I, f, r[5], r[6], r[7])
                        n = 1
                    else:
                        note(ev, EV_INTERVALS, node, I[f, LEVEL])
                ls = push_list(lists, ls, top, n)
                top += n
                sp -= 1
                continue
            if kind == SELECT:
                t0, t1 = instance_window(flat, node, H[f], I, F, f, t0, t1)
                if t0 > t1:
                    ls = push_list(lists, ls, top, 0)
                    sp -= 1
                    continue
                r = choose_rule(flat, node, F, I, H, f, S, lod, cone, dnorm, max_depth,
                                t0, ev)
                if r >= 0:
                    t0, t1 = state_window(flat, node, I, f, params, F, t0, t1)
                    if t0 > t1:
                        r = -1      # the ray misses its state's box: nothing here
                if r == -2:         # a graftal below the footprint: its box or sphere is the solid
                    n = 0
                    if top < cap_iv:
                        nx, ny, nz = volume_normal(flat, node, F, f, t0)
                        set_end(iv, top, 0, t0, F, I, f, nx, ny, nz)
                        nx, ny, nz = volume_normal(flat, node, F, f, t1)
                        set_end(iv, top, 1, t1, F, I, f, nx, ny, nz)
                        n = 1
                    else:
                        note(ev, EV_INTERVALS, node, I[f, LEVEL])
                    ls = push_list(lists, ls, top, n)
                    top += n
                    sp -= 1
                elif r == -1:
                    ls = push_list(lists, ls, top, 0)
                    sp -= 1
                else:
                    F[f, T0] = t0
                    F[f, T1] = t1
                    if flat.hashed:
                        H[f] = vm.edge_hash(H[f], node, r)
                    I[f, NODE] = flat.children[flat.child_start[node] + r]
                continue
            if kind == UNION or kind == INTERSECTION or kind == DIFFERENCE:
                if sp >= cap_f:
                    note(ev, EV_STACK, node, I[f, LEVEL])
                    ls = push_list(lists, ls, top, 0)
                    sp -= 1
                    continue
                first = 0
                I[f, PHASE] = 1
                m = -1 if flat.tree_root[node] < 0 else candidates(flat, node, F, f, cands, ct)
                if m == 0:
                    ls = push_list(lists, ls, top, 0)
                    sp -= 1
                    continue
                if m > 0:
                    # only its candidates (cands[ct:ct + m], an entry [ct, m] of the list
                    # stack), merged as the loop over every operand merges them: skipped,
                    # an operand that leaves an empty list leaves the list it is merged
                    # with as it is (tests/test_operand_trees.py)
                    ls = push_list(lists, ls, ct, m)
                    first = cands[ct]
                    ct += m
                    I[f, PHASE] = BY_TREE + 1
                    if first != 0:      # as operand 0's empty list: a list to merge with
                        ls = push_list(lists, ls, top, 0)
                enter_child(flat, node, first, F, I, H, f, sp)
                sp += 1
                continue
            if not step_unary(flat, node, kind, F, I, H, f, params, slot_base, S, ev):
                ls = push_list(lists, ls, top, 0)
                sp -= 1
            continue
        # an operator whose child number phase-1 has just left its list on top (a union or
        # difference that walks by its tree: its candidate number phase-1-BY_TREE)
        tree = phase > BY_TREE
        if tree:
            phase -= BY_TREE
        merge = phase > 1
        if tree and phase == 1:
            if lists[ls - 2, 1] == 0:       # operand 0 was not a candidate (above)
                merge = True
            elif lists[ls - 2, 1] == 1 or cands[lists[ls - 2, 0] + 1] != 1:
                # the loop over every operand merges operand 0's list with operand 1's,
                # empty here, before any other: as it comes out of a merge
                ls = push_list(lists, ls, top, 0)
                merge = True
        if merge:
            a0, na = lists[ls - 2, 0], lists[ls - 2, 1]
            b0, nb = lists[ls - 1, 0], lists[ls - 1, 1]
            op = 0 if kind == UNION else (1 if kind == INTERSECTION else 2)
            if top + na + nb > cap_iv:
                note(ev, EV_INTERVALS, node, I[f, LEVEL])
                n = na                      # keep the accumulator as it was
            else:
                n = combine(iv, a0, na, b0, nb, top, op)
                for row in range(n):
                    for k in range(IV_WIDTH):
                        iv[a0 + row, k] = iv[top + row, k]
            ls -= 1
            lists[ls - 1, 1] = n
            top = a0 + n
        acc = lists[ls - 1, 1]
        if tree:
            if phase >= lists[ls - 2, 1] or (acc == 0 and kind != UNION):
                # its candidates' entry goes: its list in its place
                ct = lists[ls - 2, 0]
                lists[ls - 2, 0] = lists[ls - 1, 0]
                lists[ls - 2, 1] = acc
                ls -= 1
                sp -= 1
            else:
                I[f, PHASE] = BY_TREE + phase + 1
                enter_child(flat, node, cands[lists[ls - 2, 0] + phase], F, I, H, f, sp)
                sp += 1
            continue
        done = phase >= flat.child_count[node] or (acc == 0 and kind != UNION)
        if done:
            sp -= 1
        else:
            I[f, PHASE] = phase + 1
            enter_child(flat, node, phase, F, I, H, f, sp)
            sp += 1
    return lists[0, 0], lists[0, 1]


@inline
def record_hit(res, ri, t, F, I, f, nx, ny, nz, what):
    """The best hit so far: its distance, world normal, the paint and material in force,
    and what it is (HIT_SOLID ...)."""
    res[ri, R_T] = t
    world_normal(F, f, nx, ny, nz, res, ri, R_N)
    for c in range(3):
        res[ri, R_PAINT + c] = F[f, PAINT + c]
    res[ri, R_MAT] = I[f, MAT]
    res[ri, R_HIT] = what


@inline
def hit_primitive(flat, node, R, r, F, I, H, f, params, tmin, t1, best, lod, cone, dnorm,
                  wdx, wdy, wdz, S, ev, res, ri):
    """The primitive `node` against the ray of row r of R, in the frame f of F, I and H (its
    map, paint, material and instance; `params` holds its parameter slot). A nearer hit
    than `best` goes into res[ri]; returns the nearest t so far. wd is the ray's world
    direction, dnorm its length."""
    out8 = S.out8
    code = flat.code[node]
    if code >= FRACTAL_MIN:
        # marched from tmin, not t0, so that the reference finds the same steps
        found = march(code == JULIA, flat.fractal, node, R[r, OX], R[r, OX + 1],
                      R[r, OX + 2], R[r, DX], R[r, DX + 1], R[r, DX + 2], tmin, t1,
                      lod, cone / dnorm,
                      footprint_scale(F, f, R[r, DX], R[r, DX + 1], R[r, DX + 2], dnorm),
                      out8)
    else:
        found = intersect(code, R[r, OX], R[r, OX + 1], R[r, OX + 2],
                          R[r, DX], R[r, DX + 1], R[r, DX + 2], out8)
    if found:
        # the first boundary crossing: the entry, or the exit from inside.
        # Not `t >= t0`: the box entry may round past the primitive's own entry.
        side = 0 if out8[0] > tmin else 1
        t = out8[side]
        if t > tmin and t < best:
            if not deferred_paint(flat, I, H, f, params, S.stack, S.args):
                note(ev, EV_NONFINITE, I[f, DPAINT], I[f, LEVEL])
                return best
            record_hit(res, ri, t, F, I, f, out8[2 + 3 * side], out8[3 + 3 * side],
                       out8[4 + 3 * side], HIT_SHELL if code >= FRACTAL_MIN else
                       HIT_SHEET if code >= FLAT_MIN else HIT_SOLID)
            if I[f, DPAINT] >= 0:
                for c in range(3):
                    res[ri, R_PAINT + c] = S.args[c]
            if code >= FLAT_MIN and res[ri, R_N] * wdx + res[ri, R_N + 1] * wdy + \
                    res[ri, R_N + 2] * wdz > 0.0:
                for c in range(3):
                    res[ri, R_N + c] = -res[ri, R_N + c]
            return t
    return best


@inline
def hit_volume(flat, node, R, r, F, I, f, t0, ax, ay, az, res, ri):
    """A graftal instance below the footprint: its box or sphere is the surface at t0;
    with averaged box normals (ax, ay, az) those are its normal."""
    nx, ny, nz = volume_normal(flat, node, R, r, t0)
    record_hit(res, ri, t0, F, I, f, nx, ny, nz, HIT_SHELL)
    if flat.normal_decay > 0.0:
        res[ri, R_N] = ax
        res[ri, R_N + 1] = ay
        res[ri, R_N + 2] = az


@inline
def finish(res, ri, hit):
    """R_HIT holds what the hit was (record_hit), else 0 for a miss."""
    if not hit:
        res[ri, R_HIT] = 0.0         # a miss is a full row too: the caller hands out views
        res[ri, R_T] = np.inf
        for c in range(3):
            res[ri, R_N + c] = 0.0
            res[ri, R_PAINT + c] = np.nan
        res[ri, R_MAT] = -1.0


@inline
def meet_operand(flat, node, k, m, has_table, F, I, H, f, t0, t1, params, order, keys, hashes,
                 phases):
    """Operand k of the union `node` in frame f's window [t0, t1]: where its box meets it,
    its window, hash and phase under its number, and k appended to order[:m]; returns m."""
    c = flat.children[flat.child_start[node] + k]
    if has_table:
        es = operand_entry(flat, node, H[f], k, I[f, LEVEL])
    else:
        es = operand_slot(flat, c, params, I, f)
    e0, e1 = volume_window(flat, c, es, F, f)
    e0 = max(e0, t0)
    e1 = min(e1, t1)
    if e0 <= e1:
        keys[k, 0] = e0
        keys[k, 1] = e1
        hashes[k] = child_hash(flat, H[f], node, k)
        phases[k] = BOXED if has_table and es >= 0 else INSIDE
        order[m] = k
        m += 1
    return m


@inline
def walk(flat, sp, best, tmin, tmax, any_hit, lod, cone, dnorm, wdx, wdy, wdz, max_depth, S, ev,
         res, ri):
    """The first-hit walk over the frames 0..sp-1 of S (the ray in each frame's own
    columns), with the nearest hit so far at `best`: returns (hit found, best). A frame
    pushed by a union has PHASE INSIDE: its window is already inside its box; or BOXED:
    also inside the box of the S-node below (nodes.BOXED). Inlined: called, the
    single-ray walk took half as long again."""
    params, order, keys, hashes, phases = S.params, S.order, S.keys, S.hashes, S.phases
    F, I, H, iv = S.F, S.I, S.H, S.iv
    cap = F.shape[0]
    has_table = flat.inst_used.shape[0] > 2 and flat.by_state == 0
    hit = False
    while sp > 0:
        sp -= 1
        f = sp
        boxed = I[f, PHASE] == BOXED
        within = I[f, PHASE] != 0
        while True:         # follow single-child nodes in place
            node = I[f, NODE]
            kind = flat.kind[node]
            t0, t1 = F[f, T0], min(F[f, T1], best)
            slot = -1
            if kind == SELECT and has_table and not boxed:
                slot = instance_slot(flat, node, H[f], I, f)
            if I[f, PHASE] != 0 or (boxed if kind == SELECT else within):
                I[f, PHASE] = 0
                t0, t1 = entry_window(flat, slot, F, f, t0, t1)
            else:
                b0, b1 = volume_window(flat, node, slot, F, f)
                t0 = max(t0, b0)
                t1 = min(t1, b1)
            within = True
            if t0 > t1:
                break
            F[f, T0] = t0
            F[f, T1] = t1
            if kind == PRIMITIVE:
                t = hit_primitive(flat, node, F, f, F, I, H, f, params, tmin, t1, best, lod,
                                  cone, dnorm, wdx, wdy, wdz, S, ev, res, ri)
                if t < best:
                    best = t
                    hit = True
                    if any_hit:
                        return True, best
                break
            if kind == SELECT:
                boxed = False
                within = False
                ax, ay, az = 0.0, 0.0, 0.0
                if flat.normal_decay > 0.0:
                    ax, ay, az = average_box_normal(flat, node, F, f, t0)
                r = choose_rule(flat, node, F, I, H, f, S, lod, cone, dnorm, max_depth,
                                t0, ev)
                if r == -2:
                    if t0 > tmin and t0 < best:
                        best = t0
                        hit = True
                        hit_volume(flat, node, F, f, F, I, f, t0, ax, ay, az, res, ri)
                        if any_hit:
                            return True, best
                    break
                if r < 0:
                    break
                t0, t1 = state_window(flat, node, I, f, params, F, t0, t1)
                if t0 > t1:
                    break
                F[f, T0] = t0
                F[f, T1] = t1
                if flat.hashed:
                    H[f] = vm.edge_hash(H[f], node, r)
                e = flat.child_start[node] + r
                I[f, NODE] = flat.children[e]
                within = flat.holds[e] != 0
                continue
            if kind == UNION:
                n = flat.child_count[node]
                if sp + n > cap:
                    note(ev, EV_STACK, node, I[f, LEVEL])
                    break
                # nearest box first, cheap operands before the others: sort the children
                # that the window meets; keys, hashes and phases by operand number
                # with a tree, only the operands under the tree boxes the window meets (a
                # box that holds theirs): the same ones the loop over all of them finds.
                # Both in one loop: meet_operand is inlined at each call, and the walk into
                # every kernel
                m = 0
                root, row, end = flat.tree_root[node], 0, 0
                j, stop = 0, n                  # without a tree, one leaf of every operand
                if root >= 0:
                    end = flat.tree_skip[root]
                    row = next_leaf(flat, root, end, F, f, t0, t1)
                    j, stop = leaf_span(flat, row, end)
                while True:
                    while j < stop:
                        k = j if end == 0 else flat.tree_items[j]
                        m = meet_operand(flat, node, k, m, has_table, F, I, H, f, t0, t1,
                                         params, order, keys, hashes, phases)
                        j += 1
                    if row >= end:
                        break
                    row = next_leaf(flat, row + 1, end, F, f, t0, t1)
                    j, stop = leaf_span(flat, row, end)
                sort_visits(flat, node, order, m, keys[:, 0])
                for j in range(m - 1, -1, -1):     # the source frame f is overwritten last
                    g = sp + j
                    k = order[j]
                    copy_frame(F, I, H, f, g)
                    I[g, NODE] = flat.children[flat.child_start[node] + k]
                    I[g, PHASE] = phases[k]
                    H[g] = hashes[k]
                    F[g, T0] = keys[k, 0]
                    F[g, T1] = keys[k, 1]
                sp += m
                break
            if kind == INTERSECTION or kind == DIFFERENCE:
                start, count = intervals(flat, F, I, H, f, tmin, tmax, S, lod, cone, dnorm,
                                         max_depth, ev)
                for j in range(2 * count):          # every end, in order along the ray
                    row = start + j // 2
                    side = j % 2
                    t = iv[row, IT_IN + side]
                    if t > tmin and t < best:
                        best = t
                        hit = True
                        res[ri, R_T] = t
                        for c in range(3):
                            res[ri, R_N + c] = iv[row, IN_N + 3 * side + c]
                            res[ri, R_PAINT + c] = iv[row, IN_PAINT + 3 * side + c]
                        res[ri, R_MAT] = iv[row, IN_MAT + side]
                        res[ri, R_HIT] = HIT_SOLID
                        if any_hit:
                            return True, best
                        break
                break
            if defer_step(flat, node, kind, I, f):
                continue
            if not step_unary(flat, node, kind, F, I, H, f, params, 0, S, ev):
                break
            if kind == TRANSFORM:
                within = axis_aligned(S.m21)
                boxed = boxed and within
    return hit, best
