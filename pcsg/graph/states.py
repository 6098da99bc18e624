"""Boxes by state: the instance table of a memoised system (graph/bounds.py).

A node's hyper box is the union of the boxes of all its instances. Where the
memoised walk could bound a system, every instance of an S-node with the same
values of the parameters its derivation depends on (a state) has the same box, and
the states are few: the sympodial tree's TR has 17, one per remaining order and trunk
segment. A deep branch's own box is then a hundredth of the hyper box's volume, which
holds the whole tree. The tracer keys the instance table by the state (trace/windows.py
state_slot) instead of by the instance's path, and narrows the window of a ray that
refines the instance to that box.

The operands of unions that are not S-nodes are keyed the same way (the values of
their key's parameters at the union): the T-node that carries the tree's two
sub-crowns, the C-nodes that start each of them. A ray that misses a deep branch's
operand box is then dropped at the union, before its calculation and its map, where
the operand's hyper box (that of the whole tree's largest branch) let it through.
S-node operands keep their own entry, which the tracer takes only once the instance
refines, as before.

Only nodes whose states' boxes are smaller than their hyper box are kept: for the
others (the Sierpinski tetrahedron, whose every instance is the same shape) the
lookup would cost and cull nothing. Each entry's row ends with its node (its owner,
instance_table.OWNER), so that Traced can cut it down to the node's padded box.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..trace.instance_table import hashed
from .hashes import float_bits, mix, splitmix64
from .model import SELECT, UNION, Graph

SMALLER = 0.9       # a state's box counts as smaller below this share of a side


@dataclass
class StateTable:
    keys: np.ndarray        # uint64[s]   state_hash of (node, values); open addressing
    used: np.ndarray        # int16[s]    1 where an entry is
    boxes: np.ndarray       # float64[s, 7]   box, owner node (instance_table.OWNER)
    slots: list             # per node: the parameter slots of its key, or None (not kept)


def state_hash(node: int, values) -> int:
    """The key of S-node `node` entered with these values of its key's slots; the
    tracer computes the same bits (trace/windows.py state_slot)."""
    h = splitmix64(node)
    for v in values:
        h = mix(h, float_bits(float(v)))
    return h


def state_table(graph: Graph, memo: dict, key, terminating: dict) -> StateTable | None:
    """The table of the memo's S-node and operand states (key: the memo's StateKey).
    None when no node gains: every state's box is its hyper box, or no node is keyed
    by its parameters alone (a rand() decides, or it is a graftal, bounded by its box)."""
    from .bounds import as_box, union_box
    operands = {c for n in graph.nodes if n.kind == UNION for c in n.children
                if graph.nodes[c].kind != SELECT}
    found: dict[int, dict[int, np.ndarray]] = {}
    for k, bound in memo.items():
        node = k[0]
        if key.rand[node]:
            continue
        if node not in operands and (graph.nodes[node].kind != SELECT
                                     or terminating.get(node, -1) < 0):
            continue
        h = state_hash(node, np.frombuffer(k[1], dtype=np.float64))
        states = found.setdefault(node, {})
        box = as_box(bound)
        # the same values with other parameters unassigned: the same geometry, kept whole
        states[h] = box if h not in states else union_box(states[h], box)
    kept = {node: states for node, states in found.items() if _gains(list(states.values()))}
    if not kept:
        return None
    hashes = np.array([h for states in kept.values() for h in states], dtype=np.uint64)
    boxes = np.array([[*b, node] for node, states in kept.items() for b in states.values()])
    size = 1 << max(2, (4 * len(hashes) - 1).bit_length())     # at most a quarter full
    keys, used, boxes = hashed((hashes, np.ones(len(hashes), dtype=np.int16), boxes, size))
    slots = [key.slots[i] if i in kept else None for i in range(len(graph.nodes))]
    return StateTable(keys, used, boxes, slots)


def _gains(boxes: list[np.ndarray]) -> bool:
    """Whether some state's box is markedly smaller than the union of them all."""
    b = np.array(boxes)
    lo, hi = b[:, :3].min(axis=0), b[:, 3:].max(axis=0)
    whole = hi - lo
    finite = np.isfinite(whole) & (whole > 0)
    if not finite.any():
        return False
    sides = (b[:, 3:] - b[:, :3])[:, finite]
    return bool((sides < SMALLER * whole[finite]).any())
