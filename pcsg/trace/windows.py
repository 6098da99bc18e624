"""Where a ray is inside what bounds an instance: a node's box or sphere, and the
instance table's box of one instance (its S-node instance or a union's operand, keyed
by hash, or its parameter state, keyed by state). Every culling test of both tracing
walks is a window [t_enter, t_exit] from here, narrowed as the walk goes down."""
from __future__ import annotations

import math

import numpy as np

from ..graph.model import SELECT
from . import vm
from .jit import inline, kernel
from .nodes import CUT, DX, INV, LEVEL, OX, SLOT
from .primitives import _roots


@inline
def box_window(boxes, b, F, f):
    """Where the frame's ray is inside boxes[b]: (t_enter, t_exit), empty if enter > exit."""
    if boxes[b, 0] > boxes[b, 3]:
        # empty (the box walks make every side of an empty box inverted): the slabs
        # below would make it all of space
        return np.inf, -np.inf
    return slabs(boxes[b, 0], boxes[b, 1], boxes[b, 2], boxes[b, 3], boxes[b, 4], boxes[b, 5],
                 F, f)


FAR = 1.7976931348623157e308       # the largest double


@inline
def slabs(x0, y0, z0, x1, y1, z1, F, f):
    """box_window of the box (x0, y0, z0)-(x1, y1, z1), which is not empty: the packets
    read a frame's box once for all its rays. It starts from [-FAR, FAR], not [-inf,
    inf], so that a slab a parallel ray lies outside of, whose ends are both inf or both
    -inf (_slab), leaves the window crossed over even where no other slab narrowed it (an
    unbounded box): a window that would end at ±inf ends at ±FAR, which no finite t
    tells apart."""
    t0, t1 = _slab(F[f, OX], F[f, INV], x0, x1, -FAR, FAR)
    t0, t1 = _slab(F[f, OX + 1], F[f, INV + 1], y0, y1, t0, t1)
    return _slab(F[f, OX + 2], F[f, INV + 2], z0, z1, t0, t1)


@inline
def _slab(o, inv, lo, hi, t0, t1):
    """[t0, t1] narrowed to one axis' slab; an empty window stays so: no later slab widens
    it. A ray parallel to the slab needs no branch of its own where inv is +inf (never
    -inf: set_inverse, map_ray_scaled): outside, both ends are the same infinity, which
    crosses the window over (slabs starts it at ±FAR for that); inside, they are -inf
    and inf, which leave it; in a side plane, that side's end is 0 * inf = nan, which
    every comparison below leaves out, and the other is +inf (at lo) or -inf (at hi),
    which narrows nothing."""
    ta = (lo - o) * inv
    tb = (hi - o) * inv
    if ta > tb:
        ta, tb = tb, ta
    if ta > t0:
        t0 = ta
    if tb < t1:
        t1 = tb
    return t0, t1


@inline
def packet_box(flat, node, slot, test):
    """What every ray of a packet frame at `node` is tested against, read once for all:
    with `test`, its volume_window; else only the instance table's entry `slot`
    (entry_window). (1, x0, y0, z0, x1, y1, z1) where that is one box; -1 where the box
    is empty, 0 where a sphere bounds the node (volume_window per ray), 2 for no test."""
    if not test and slot < 0:
        return 2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    if test and flat.sphere.shape[0] > 0 and flat.sphere[node, 3] >= 0.0:
        return 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    if slot >= 0:       # the table's rows are float32 (instance_table.tracer_rows)
        r = flat.inst_boxes
        if r[slot, 0] > r[slot, 3]:
            return -1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
        return (1, np.float64(r[slot, 0]), np.float64(r[slot, 1]), np.float64(r[slot, 2]),
                np.float64(r[slot, 3]), np.float64(r[slot, 4]), np.float64(r[slot, 5]))
    b = flat.box
    if b[node, 0] > b[node, 3]:
        return -1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    return 1, b[node, 0], b[node, 1], b[node, 2], b[node, 3], b[node, 4], b[node, 5]


@inline
def sphere_window(spheres, b, F, f):
    """Where the frame's ray is inside the ball spheres[b] = (centre, radius): the sphere
    primitive's quadratic in the ball's unit frame, where t is the same."""
    r = spheres[b, 3]
    ox = (F[f, OX] - spheres[b, 0]) / r
    oy = (F[f, OX + 1] - spheres[b, 1]) / r
    oz = (F[f, OX + 2] - spheres[b, 2]) / r
    dx = F[f, DX] / r
    dy = F[f, DX + 1] / r
    dz = F[f, DX + 2] / r
    a = dx * dx + dy * dy + dz * dz
    c = ox * ox + oy * oy + oz * oz - 1.0
    if a == 0.0:
        return (-np.inf, np.inf) if c <= 0.0 else (np.inf, -np.inf)
    cx = oy * dz - oz * dy
    cy = oz * dx - ox * dz
    cz = ox * dy - oy * dx
    disc = a - (cx * cx + cy * cy + cz * cz)     # b^2 - a c, free of cancellation
    if not (disc >= 0.0):
        return np.inf, -np.inf
    ok, t0, t1 = _roots(a, ox * dx + oy * dy + oz * dz, c, disc)
    if not ok:
        return np.inf, -np.inf
    return t0, t1


@inline
def node_window(flat, node, F, f):
    """Where the frame's ray is inside the node's bounding volume: the sphere of a
    graftal that a sphere bounds better than a box (graph/volumes.py), else its box.
    `sphere` is empty when no node has one, which spares the other systems the look."""
    if flat.sphere.shape[0] > 0 and flat.sphere[node, 3] >= 0.0:
        return sphere_window(flat.sphere, node, F, f)
    return box_window(flat.box, node, F, f)


@inline
def volume_normal(flat, node, F, f, t):
    """Outward local normal of the node's bounding volume (sphere or box) where the ray
    is at t; not normalised."""
    if flat.sphere.shape[0] > 0 and flat.sphere[node, 3] >= 0.0:
        return (F[f, OX] + t * F[f, DX] - flat.sphere[node, 0],
                F[f, OX + 1] + t * F[f, DX + 1] - flat.sphere[node, 1],
                F[f, OX + 2] + t * F[f, DX + 2] - flat.sphere[node, 2])
    return box_normal(flat.box, node, F, f, t)


@kernel
def box_normal(boxes, b, F, f, t):
    """Outward local normal of the box face the ray crosses at t."""
    best = np.inf
    axis = 0
    sign = 1.0
    for a in range(3):
        p = F[f, OX + a] + t * F[f, DX + a]
        for side in range(2):
            plane = boxes[b, a + 3 * side]
            if math.isfinite(plane) and abs(p - plane) < best:
                best = abs(p - plane)
                axis = a
                sign = 1.0 if side == 1 else -1.0
    if axis == 0:
        return sign, 0.0, 0.0
    if axis == 1:
        return 0.0, sign, 0.0
    return 0.0, 0.0, sign


@inline
def table_slot(keys, used, h):
    """Open addressing: the slot of hash h, or of the empty place where it would go
    (the table is at most half full, so the probe ends)."""
    mask = keys.shape[0] - 1
    i = np.int64(h & np.uint64(mask))
    while used[i] and keys[i] != h:
        i = (i + 1) & mask
    return i


@inline
def row_slot(flat, key):
    """The tracer's table slot of `key`, -1 where it has none. The rows hold the keys, an
    empty slot key 0 (instance_table.tracer_rows), so a probe reads one row per step."""
    keys = flat.inst_keys
    slot = table_slot(keys, keys, key)
    return slot if keys[slot] != 0 else -1


@inline
def entry_slot(flat, key, level):
    """The instance table's slot for `key`, -1 where it has none. `level` is the one the
    entry would have: an S-node instance's own, an operand's the operator's."""
    if level > flat.inst_deepest:
        return -1
    return row_slot(flat, key)


@inline
def instance_slot(flat, node, h, I, f):
    """entry_slot of an S-node instance whose frame f is on it, before its selection
    (choose_rule, packet.select) raises the frame's level to the instance's own."""
    return entry_slot(flat, vm.mix(h, node), I[f, LEVEL] + 1)


@inline
def operand_entry(flat, node, h, k, level):
    """entry_slot of operand k of the instance h of the operator `node`, at `level`."""
    return entry_slot(flat, vm.operand_key(h, node, k), level)


@inline
def volume_window(flat, node, slot, F, f):
    """node_window narrowed by the instance table's box `slot` (-1: none). An entry's
    box lies inside its node's box (instance_table.clip_to_owners), so where that is the
    node's volume, the entry's window alone is the window of both."""
    if slot < 0:
        return node_window(flat, node, F, f)
    t0, t1 = box_window(flat.inst_boxes, slot, F, f)
    if flat.sphere.shape[0] > 0 and flat.sphere[node, 3] >= 0.0:
        s0, s1 = sphere_window(flat.sphere, node, F, f)
        t0 = max(t0, s0)
        t1 = min(t1, s1)
    return t0, t1


@inline
def instance_window(flat, node, h, I, F, f, t0, t1):
    """The window [t0, t1] narrowed by one instance's own box where the instance table
    has it: an S-node instance (node, its hash) in its own frame, or an operand of an
    operator (the operator, the operand's hash) in the operator's frame. The table holds
    the top derivation levels of systems whose hyper boxes are loose (the terrain)."""
    if flat.inst_used.shape[0] > 2 and flat.by_state == 0:
        return entry_window(flat, instance_slot(flat, node, h, I, f), F, f, t0, t1)
    return t0, t1


@inline
def entry_window(flat, slot, F, f, t0, t1):
    """The window [t0, t1] narrowed by the instance table's box `slot`, as it is where
    slot is -1 (no entry)."""
    if slot >= 0:
        b0, b1 = box_window(flat.inst_boxes, slot, F, f)
        t0 = max(t0, b0)
        t1 = min(t1, b1)
    return t0, t1


@inline
def state_slot(flat, node, params, row):
    """The table slot of the box of an S-node instance's state (graph/states.py) for a
    table keyed by state: the node and the values of its key's parameters on entry,
    params[row]; -1 if the table has none. Taken only where the instance refines: its
    terminating rule is not what the state's box holds."""
    c = flat.state_count[node]
    if c < 0:
        return -1
    h = vm.splitmix64(np.uint64(node))
    s = flat.state_start[node]
    for j in range(c):
        h = vm.mix(h, vm.float_bits(params[row, flat.state_slots[s + j]]))
    return row_slot(flat, h)


@inline
def operand_slot(flat, child, params, I, f):
    """The table slot of the box of a union's operand in frame f's state, for a table
    keyed by state, where the operand is not an S-node and the frame refines; -1 if
    none. An S-node operand's entry is its instance's, which only a refining instance
    may take (state_slot)."""
    if flat.by_state == 0 or I[f, CUT] != 0 or flat.state_count[child] < 0 \
            or flat.kind[child] == SELECT:
        return -1
    return state_slot(flat, child, params, I[f, SLOT])


@inline
def state_window(flat, node, I, f, params, F, t0, t1):
    """The window [t0, t1] of frame f narrowed by the box of its instance's state where
    the table is keyed by state and the instance refines (state_slot)."""
    if flat.by_state != 0 and I[f, CUT] == 0:
        return entry_window(flat, state_slot(flat, node, params, I[f, SLOT]), F, f, t0, t1)
    return t0, t1
