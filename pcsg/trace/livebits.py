"""numba's map of the variables live at each block's entry, computed on bit sets.

numba (0.68, `numba.core.analysis.compute_live_map`) first finds, for every block, each
variable defined or used on some path to it, as Python sets unioned block into block
until nothing grows. After the per-node steps are inlined, a walk has thousands of
blocks and tens of thousands of variables, and numba computes the map again after
most of its passes: those unions were an eighth of the kernels' compile (a profile:
57 s of 483 in 9,059 rounds). Here each variable is a bit of a Python int, a union is an
`|` over machine words, and the same rules are applied in the same order until nothing
grows; the least sets the rules allow are one answer whatever the representation, so
the map that comes out holds numba's sets (tests/test_compiling.py)."""
from __future__ import annotations

from numba.core import analysis

from . import compiling

NUMBA_LIVE_MAP = analysis.compute_live_map


def compute_live_map(cfg, blocks, var_use_map, var_def_map):
    """numba's `compute_live_map`: the variables live at the entry of each block."""
    order = cfg.topo_order()
    bit: dict[str, int] = {}
    for names in list(var_def_map.values()) + list(var_use_map.values()):
        for name in names:
            bit.setdefault(name, len(bit))

    def mask(names) -> int:
        return sum(1 << bit[name] for name in names)

    defs = {label: mask(names) for label, names in var_def_map.items()}
    uses = {label: mask(names) for label, names in var_use_map.items()}
    successors = {label: [out for out, _ in cfg.successors(label)] for label in order}
    predecessors = {label: [inc for inc, _ in cfg.predecessors(label)] for label in order}

    # what is defined or used on some path to each block, from the entry on
    reach: dict[int, int] = {}
    grown = True
    while grown:
        grown = False
        for label in order:
            here = reach.get(label, 0) | defs[label] | uses[label]
            if here != reach.get(label):
                reach[label] = here
                grown = True
            for out in successors[label]:
                there = reach.get(out, 0)
                if here | there != there:
                    reach[out] = here | there
                    grown = True

    # live: used on some path on, and defined on some path to it, pushed backwards
    live = {label: uses[label] for label in blocks.keys()}
    grown = True
    while grown:
        grown = False
        for label in reversed(order):
            for inc in predecessors[label]:
                was = live[inc]
                now = was | (live[label] & reach.get(inc, 0) & ~defs[inc])
                if now != was:
                    live[inc] = now
                    grown = True
    names = list(bit)
    return {label: _names(v, names) for label, v in live.items()}


def _names(v: int, names: list[str]) -> set[str]:
    bits = format(v, "b")[::-1]
    out = set()
    i = bits.find("1")
    while i >= 0:
        out.add(names[i])
        i = bits.find("1", i + 1)
    return out


def install() -> None:
    """For numba 0.68, whose rules this applies; another numba keeps its own way."""
    if compiling.numba_followed() and \
            analysis.compute_live_map is NUMBA_LIVE_MAP:
        analysis.compute_live_map = compute_live_map
