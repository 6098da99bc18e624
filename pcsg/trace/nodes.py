"""What a ray does at each kind of node, shared by the tracing walks: its calculations,
selections, maps and paint. Where a ray is inside a box is in windows.py, normals and
world sizes are in normals.py.

A frame is one instance on a walk: the ray in that instance's frame (the
direction is never renormalised, so t is the same in every frame), the
accumulated world-from-local linear map M (for normals and sizes), the t-window,
the paint and material in force, its parameter slot, instance hash and level.
Frames are rows of three per-walk arrays: F (floats), I (ints), H (hashes).
"""
from __future__ import annotations

import math

import numpy as np

from ..graph.model import TRANSFORM
from . import vm
from .jit import copy_into, inline, kernel
from .native import call_block
from .transforms import affine

# F columns; INV is 1/DX, kept so that box tests multiply instead of divide
# NAVG: the running average of the world normals of the boxes the walk entered
OX, DX, INV, M0, T0, T1, PAINT, NAVG = 0, 3, 6, 9, 18, 19, 20, 23
F_WIDTH = 26
# the ray's own columns come first: a packet's ray blocks (packet.py) hold only these,
# 72 bytes a ray instead of the frame's 208
RAY_WIDTH = 9
# I columns; DCALC and DPAINT: the C-node and paint node the walk passed without running
# them, for a hit to run (trace/deferred.py), -1 if none
NODE, SLOT, LEVEL, MAT, CUT, PHASE, DCALC, DPAINT = 0, 1, 2, 3, 4, 5, 6, 7
I_WIDTH = 8
# PHASE of a frame a union pushed: its window is inside its node's box (INSIDE), and
# also inside the instance box of the S-node it leads to (BOXED) where the union's
# table entry for it was met and only maps that keep boxes exact (axis_aligned) lie
# between: that S-node's own box would cull nothing more
INSIDE, BOXED = 1, 2
# Below a frame's first node, the walks test a node's box only where it could cull: not
# after a C-, paint or material node, whose child's box holds its own, nor after a T-node
# that only moves and scales (its child's box is its own, mapped); an S-node's own box or
# table entry is tested as before, unless BOXED. Each walk keeps this as `within`: the
# frame's window lies inside the current node's box.

MANTISSA = np.uint64((1 << 52) - 1)     # a float64's fraction bits (exact_scaling)
SORT_FEW = 16       # sort_visits sorts this many of a union's operands by insertion

# event kinds, counted per node and reported once per render. An events array has
# 2 * N_EVENTS rows per node: the counts, then the deepest level each kind was met at.
(EV_LOD, EV_DEPTH, EV_STACK, EV_INTERVALS, EV_SINGULAR, EV_SELECTION, EV_NONFINITE,
 EV_VISITS) = range(8)
N_EVENTS = 8


@inline
def note(ev, kind, node, level):
    ev[kind, node] += 1
    ev[N_EVENTS + kind, node] = max(ev[N_EVENTS + kind, node], level)


def no_events(nodes: int, chunks: int | None = None) -> np.ndarray:
    shape = (2 * N_EVENTS, nodes) if chunks is None else (chunks, 2 * N_EVENTS, nodes)
    return np.zeros(shape, dtype=np.int64)


def add_events(total: np.ndarray, ev: np.ndarray) -> np.ndarray:
    """Fold events (one array, or per-chunk arrays) into total: counts add, levels max."""
    if ev.ndim == 3:
        ev = np.concatenate([ev[:, :N_EVENTS].sum(axis=0), ev[:, N_EVENTS:].max(axis=0)])
    total[:N_EVENTS] += ev[:N_EVENTS]
    np.maximum(total[N_EVENTS:], ev[N_EVENTS:], out=total[N_EVENTS:])
    return total


@inline
def copy_frame(F, I, H, src, dst):
    if src != dst:
        copy_into(F[dst], F[src])
        copy_into(I[dst], I[src])
        H[dst] = H[src]


@inline
def set_inverse(F, f):
    for a in range(3):
        # + 0.0 turns -0.0 into 0.0: a direction parallel to an axis gets 1/d = +inf
        # whatever the sign of its zero, as _slab needs
        F[f, INV + a] = 1.0 / (F[f, DX + a] + 0.0)


@inline
def child_hash(flat, h, node, k):
    """The instance hash of child k of an instance of `node` whose hash is h."""
    if flat.hashed and flat.child_count[node] > 1:
        return vm.edge_hash(h, node, k)
    return h


@inline
def cheap_operand(flat, node, k):
    """Whether operand k of the union `node` is a primitive, or a run of single-child
    steps to one (Flat.chain), but not a fractal. Both walks visit these first (nearest
    box first among them), then the others: one test of such an operand may bring the
    rays' nearest hits nearer than the other operands' boxes, as the sea does for the
    terrain, whose box the camera rays enter first and whose patches under the water a
    quarter of them walked down to the hit behind the sea's surface."""
    return flat.cheap[flat.child_start[node] + k] != 0


@inline
def visited_later(flat, node, a, entry_a, b, entry_b):
    """Whether operand a of the union `node`, its window entered at entry_a, is visited
    after operand b: the cheap ones first (cheap_operand), among the same kind the
    nearest box (entry) first, and on a tie the earlier operand, which then keeps the
    surface (as a union merges)."""
    cheap_a, cheap_b = cheap_operand(flat, node, a), cheap_operand(flat, node, b)
    if cheap_a != cheap_b:
        return cheap_b
    if entry_a != entry_b:
        return entry_a > entry_b
    return a > b


@inline
def sort_visits(flat, node, met, m, entry):
    """The operands met[0:m] of the union `node` (entry[k]: where operand k's window
    starts) into the reverse order of their visits (visited_later), so that the last
    pushed pops first. Few are met in most unions, sorted by insertion; past SORT_FEW a
    heap sort, since insertion made a flat union of thousands of operands quadratic per
    ray (2,000 coincident spheres: 0.9 s at 32x24, now 0.06 s; tools/performance_notes.md)."""
    if m <= SORT_FEW:
        for i in range(1, m):
            k = met[i]
            j = i
            while j > 0 and visited_later(flat, node, k, entry[k], met[j - 1],
                                          entry[met[j - 1]]):
                met[j] = met[j - 1]
                j -= 1
            met[j] = k
        return
    for root in range(m // 2 - 1, -1, -1):
        sift_down(flat, node, met, root, m, entry)
    for end in range(m - 1, 0, -1):
        met[0], met[end] = met[end], met[0]
        sift_down(flat, node, met, 0, end, entry)


@inline
def sift_down(flat, node, met, root, end, entry):
    """sort_visits' heap met[0:end] with its root's operand moved down into place: the
    operand visited first on top (a heap sort puts it last)."""
    while True:
        c = 2 * root + 1
        if c >= end:
            return
        if c + 1 < end and visited_later(flat, node, met[c], entry[met[c]], met[c + 1],
                                         entry[met[c + 1]]):
            c += 1
        if not visited_later(flat, node, met[root], entry[met[root]], met[c],
                             entry[met[c]]):
            return
        met[root], met[c] = met[c], met[root]
        root = c


@inline
def axis_aligned(L):
    """Whether the map L (transform_map's layout) only scales and moves along the axes:
    then it maps a box onto exactly a box."""
    return L[1] == 0.0 and L[2] == 0.0 and L[3] == 0.0 and L[5] == 0.0 and L[6] == 0.0 \
        and L[7] == 0.0


@inline
def expr(flat, params, slot, k, h, salt_slot, stack):
    """Evaluate expression number k of the flat table with the parameters of `slot`;
    rand() draws from the instance hash h salted with salt_slot."""
    return vm.eval_row(flat.vm_code, flat.vm_consts, flat.vm_start[k], flat.vm_end[k],
                       params, slot, h, salt_slot, stack)


@inline
def run_calc(flat, node, params, src, dst, h, stack):
    """A C-node: copy the parameter state into slot dst, then run its block, compiled
    where it could be (native.py), else on the expression machine."""
    if src != dst:
        copy_into(params[dst], params[src])
    if flat.calc_fn[node] != 0:
        call_block(flat.calc_fn[node], params, dst, flat.vm_consts, h, flat.block_no[node])
    else:
        vm.eval_row(flat.vm_code, flat.vm_consts, flat.calc_start[node], flat.calc_end[node],
                    params, dst, h, -1, stack)


@inline
def cached_calc(flat, node, params, src, dst, h, stack, ckeys, cvals):
    """run_calc through the walker's cache of calculated states: neighbouring rays
    enter the same instances, and a long block (the terrain's 25 assignments) costs
    more than copying its result. The key is the instance hash with the node, which
    fixes the state; a slot holds the last key that mapped to it."""
    if not flat.calc_cache[node]:
        run_calc(flat, node, params, src, dst, h, stack)
        return
    key = vm.mix(h, node) | np.uint64(1)
    slot = np.int64(key & np.uint64(ckeys.shape[0] - 1))
    if ckeys[slot] == key:
        copy_into(params[dst], cvals[slot])
        return
    run_calc(flat, node, params, src, dst, h, stack)
    ckeys[slot] = key
    copy_into(cvals[slot], params[dst])


@inline
def pick_rule(flat, node, params, slot, h, stack):
    """The 0-based rule an S-node selects, or -1 if its selection is invalid."""
    if flat.arg_fn[node] != 0:      # compiled (Flat.arg_fn), into a scratch column
        call_block(flat.arg_fn[node], params, slot, flat.vm_consts, h, flat.block_no[node])
        x = params[slot, flat.arg_base]
    else:
        x = expr(flat, params, slot, flat.expr_ids[flat.expr_start[node]], h, 0, stack)
    return vm.select_rule(x, flat.child_count[node]) - 1


@inline
def eval_args(flat, node, params, slot, h, stack, args):
    """A T- or paint node's arguments into args; False if one is not finite. Compiled
    where they could be (Flat.arg_fn): one call that leaves them in params[slot]'s
    scratch columns, where the machine took a run per argument (a T-node of the terrain's
    final triangles, with its matrix, took 56 to 66 ns that way and 13 to 14 ns compiled)."""
    if flat.arg_fn[node] != 0:
        return _compiled_args(flat, node, params, slot, h, args)
    e0 = flat.expr_start[node]
    return _machine_args(flat.vm_code, flat.vm_consts, flat.vm_start, flat.vm_end,
                         flat.expr_ids[e0:e0 + flat.expr_count[node]], params, slot, h,
                         stack, args)


@inline
def _compiled_args(flat, node, params, slot, h, args):
    call_block(flat.arg_fn[node], params, slot, flat.vm_consts, h, flat.block_no[node])
    ok = True
    for k in range(flat.expr_count[node]):
        args[k] = params[slot, flat.arg_base + k]
        if not math.isfinite(args[k]):
            ok = False
    return ok


@inline
def _machine_args(vm_code, vm_consts, vm_start, vm_end, ids, params, slot, h, stack, args):
    """The arguments whose expressions are ids, on the expression machine; rand() salted
    with the argument's place, 1 on."""
    ok = True
    for k in range(ids.shape[0]):
        args[k] = vm.eval_row(vm_code, vm_consts, vm_start[ids[k]], vm_end[ids[k]], params,
                              slot, h, k + 1, stack)
        if not math.isfinite(args[k]):
            ok = False
    return ok


@inline
def node_affine(flat, node, params, slot, h, stack, args, m34):
    """The T-node's own 3x4 map into m34 (precomputed where fixed), without what it
    composes (Flat.then: transform_map composes). False for bad arguments. Inlined, but
    for arguments the expression machine runs (_machine_affine): called with the Flat,
    it pushed the Flat's arrays on the stack at every call, 304 words, a third of the
    bounding walk's time (tools/performance_notes.md, session 72)."""
    if flat.fixed[node]:
        fm = flat.fixed_map[node]
        for i in range(3):
            for j in range(3):
                m34[i, j] = fm[3 * i + j]
            m34[i, 3] = fm[9 + i]
        return True
    if flat.arg_fn[node] == 0:
        e0 = flat.expr_start[node]
        return _machine_affine(flat.vm_code, flat.vm_consts, flat.vm_start, flat.vm_end,
                               flat.expr_ids[e0:e0 + flat.expr_count[node]], flat.code[node],
                               params, slot, h, stack, args, m34)
    ok = _compiled_args(flat, node, params, slot, h, args)
    affine(flat.code[node], args, m34)
    return ok


@kernel
def _machine_affine(vm_code, vm_consts, vm_start, vm_end, ids, code, params, slot, h, stack,
                    args, m34):
    """node_affine where the machine runs the arguments: a call, given only the arrays
    it reads."""
    ok = _machine_args(vm_code, vm_consts, vm_start, vm_end, ids, params, slot, h, stack,
                       args)
    affine(code, args, m34)
    return ok


@kernel
def called_affine(flat, node, params, slot, h, stack, args, m34):
    """node_affine as a call, where inlining it would only grow a walk's code: the maps a
    T-node composes (Flat.then) and the search for a failed map's culprit. Inlined there
    too, the render of Sierpinski at 8 took 4 to 9 % longer."""
    return node_affine(flat, node, params, slot, h, stack, args, m34)


@inline
def composed_affine(flat, node, params, slot, h, stack, args, m34):
    """The T-node's 3x4 map into m34, composed with the maps of the T-nodes below it that
    it stands for (Flat.then). False for bad arguments. A system bounded instance by
    instance has its runs written out as one `matrix` node where they can be
    (graph/fuse.py); this composes the others. The bounding walk keeps to node_affine:
    with this loop in node_affine, its walk of the terrain at order 10 on one thread took
    1.0 to 1.1 s inlined and 1.7 s called, against 0.83 s."""
    ok = node_affine(flat, node, params, slot, h, stack, args, m34)
    below = flat.then[node]
    while below >= 0:
        # the map so far in locals while m34 takes the next one: no scratch array
        a0, a1, a2, a3 = m34[0, 0], m34[0, 1], m34[0, 2], m34[0, 3]
        b0, b1, b2, b3 = m34[1, 0], m34[1, 1], m34[1, 2], m34[1, 3]
        c0, c1, c2, c3 = m34[2, 0], m34[2, 1], m34[2, 2], m34[2, 3]
        ok = called_affine(flat, below, params, slot, h, stack, args, m34) and ok
        for j in range(4):
            x, y, z = m34[0, j], m34[1, j], m34[2, j]
            m34[0, j] = a0 * x + a1 * y + a2 * z
            m34[1, j] = b0 * x + b1 * y + b2 * z
            m34[2, j] = c0 * x + c1 * y + c2 * z
        m34[0, 3] += a3
        m34[1, 3] += b3
        m34[2, 3] += c3
        below = flat.then[below]
    return ok


@kernel
def culprit(flat, node, params, slot, h, stack, args, m34, bad):
    """Which of the T-nodes that `node` composes made transform_map fail with `bad`
    (1: a non-finite argument, 2: a singular map), for the warning's location: the
    first whose own map fails so; `node` if only their product is singular. A `matrix`
    node written for a run (Flat.origin) stands for the run as written, which a flat
    that composes no runs (the bounding walk's: `then` all -1) follows child by child
    down to the node below the run."""
    below = -1
    if flat.origin[node] >= 0:
        below = flat.children[flat.child_start[node]]
        node = flat.origin[node]
    at = node
    while at >= 0:
        finite = called_affine(flat, at, params, slot, h, stack, args, m34)
        if bad == 1 and not finite:
            return at
        if bad == 2 and singular_map(m34):
            return at
        nxt = flat.then[at]
        if nxt < 0 and below >= 0:
            c = flat.children[flat.child_start[at]]
            nxt = c if c != below and flat.kind[c] == TRANSFORM else -1
        at = nxt
    return node


@inline
def determinant(m34):
    """Of the 3x4 map's linear part, by cofactors as transform_map computes it (and
    graph/linear.py)."""
    a, b, c = m34[0, 0], m34[0, 1], m34[0, 2]
    d, e, g = m34[1, 0], m34[1, 1], m34[1, 2]
    p, q, r = m34[2, 0], m34[2, 1], m34[2, 2]
    return a * (e * r - g * q) + b * (g * p - d * r) + c * (d * q - e * p)


@inline
def singular_map(m34):
    """Whether the 3x4 map's linear part is singular or its determinant not finite: the
    tracer empties such an instance (transform_map's test, on its determinant as it
    computes it)."""
    det = determinant(m34)
    return not (det != 0.0 and math.isfinite(det))


@inline
def transform_map(flat, node, params, slot, h, stack, args, m34, m21):
    """The T-node's map into m21: [L (9) | t (3) | L^-1 (9)] like a row of fixed_map
    (copied from there where the map is fixed). Returns 0 if fine, 1 for non-finite
    arguments, 2 for a singular map."""
    if flat.fixed[node] and flat.then[node] < 0:
        for k in range(21):
            m21[k] = flat.fixed_map[node, k]
        return 0
    if not composed_affine(flat, node, params, slot, h, stack, args, m34):
        return 1
    a, b, c = m34[0, 0], m34[0, 1], m34[0, 2]
    d, e, g = m34[1, 0], m34[1, 1], m34[1, 2]
    p, q, r = m34[2, 0], m34[2, 1], m34[2, 2]
    c00 = e * r - g * q
    c01 = g * p - d * r
    c02 = d * q - e * p
    det = a * c00 + b * c01 + c * c02
    if not (det != 0.0 and math.isfinite(det)):
        return 2
    inv = 1.0 / det
    for i in range(3):
        for j in range(3):
            m21[3 * i + j] = m34[i, j]
        m21[9 + i] = m34[i, 3]
    # rows of L^-1 = cofactor(L)^T / det
    m21[12], m21[13], m21[14] = c00 * inv, (c * q - b * r) * inv, (b * g - c * e) * inv
    m21[15], m21[16], m21[17] = c01 * inv, (a * r - c * p) * inv, (c * d - a * g) * inv
    m21[18], m21[19], m21[20] = c02 * inv, (b * p - a * q) * inv, (a * e - b * d) * inv
    return 0


@inline
def map_ray(L, F, f, G, g):
    """G[g]'s ray := frame f's ray of F in the child frame of the map L (g may be f)."""
    ox = F[f, OX] - L[9]
    oy = F[f, OX + 1] - L[10]
    oz = F[f, OX + 2] - L[11]
    dx, dy, dz = F[f, DX], F[f, DX + 1], F[f, DX + 2]
    G[g, OX] = L[12] * ox + L[13] * oy + L[14] * oz
    G[g, OX + 1] = L[15] * ox + L[16] * oy + L[17] * oz
    G[g, OX + 2] = L[18] * ox + L[19] * oy + L[20] * oz
    G[g, DX] = L[12] * dx + L[13] * dy + L[14] * dz
    G[g, DX + 1] = L[15] * dx + L[16] * dy + L[17] * dz
    G[g, DX + 2] = L[18] * dx + L[19] * dy + L[20] * dz
    set_inverse(G, g)


@inline
def exact_scaling(L):
    """Whether the map L (transform_map's layout) only moves and scales along the axes by
    powers of two, as the Sierpinski tetrahedron's and the terrain's do. Its inverse then
    scales by the exact reciprocals, and 1/(s d) is (1/d)/s bit for bit: map_ray_scaled
    maps a ray's 1/d by a product instead of three divisions."""
    return axis_aligned(L) and powers_of_two(L)


@inline
def powers_of_two(L):
    """exact_scaling of an L that is axis_aligned already (the packet walk knows)."""
    for a in range(3):
        s = L[4 * a]
        # a power of two: no mantissa bits (a subnormal one has one); not infinite, as
        # s * (1/s) == 1 says
        if vm.float_bits(s) & MANTISSA != 0 or s * L[12 + 4 * a] != 1.0:
            return False
        for b in range(3):
            if b != a and L[12 + 3 * a + b] != 0.0:
                return False
    return True


@inline
def map_ray_scaled(L, F, f, G, g):
    """map_ray for an L of exact_scaling: the same values (where a product is zero, its
    sign may differ, which only 1/d would show: an infinite one is kept +inf, as
    set_inverse makes it)."""
    for a in range(3):
        s = L[12 + 4 * a]
        G[g, OX + a] = s * (F[f, OX + a] - L[9 + a])
        G[g, DX + a] = s * F[f, DX + a]
        inv = F[f, INV + a] * L[4 * a]
        G[g, INV + a] = abs(inv) if math.isinf(inv) else inv


@inline
def map_matrix(L, F, f):
    """Frame f's world-from-local M <- M L."""
    for row in range(3):
        m0 = F[f, M0 + 3 * row]
        m1 = F[f, M0 + 3 * row + 1]
        m2 = F[f, M0 + 3 * row + 2]
        F[f, M0 + 3 * row] = m0 * L[0] + m1 * L[3] + m2 * L[6]
        F[f, M0 + 3 * row + 1] = m0 * L[1] + m1 * L[4] + m2 * L[7]
        F[f, M0 + 3 * row + 2] = m0 * L[2] + m1 * L[5] + m2 * L[8]


@inline
def enter_transform(flat, node, F, f, params, slot, h, stack, args, m34, m21):
    """Map frame f's ray into the T-node's child frame, in place. Returns 0 if fine,
    1 for non-finite arguments, 2 for a singular map (the instance is then empty)."""
    bad = transform_map(flat, node, params, slot, h, stack, args, m34, m21)
    if bad != 0:
        return bad
    if exact_scaling(m21):
        map_ray_scaled(m21, F, f, F, f)
    else:
        map_ray(m21, F, f, F, f)
    map_matrix(m21, F, f)
    return 0


@inline
def enter_paint(flat, node, F, f, params, slot, h, stack, args):
    if flat.fixed[node]:                # constant colour, stored like a fixed map
        for k in range(3):
            F[f, PAINT + k] = flat.fixed_map[node, k]
        return True
    if not eval_args(flat, node, params, slot, h, stack, args):
        return False
    for k in range(3):
        F[f, PAINT + k] = args[k]
    return True
