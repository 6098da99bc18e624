"""Work that only a hit needs, done at the hit: a C-node whose results only paint
reads, and the paint node itself, on a chain of single-child nodes that ends at a
primitive (graph/defer.py marks them). The terrain's terminating rule computes its
colour from the corner heights in 25 assignments; a camera ray passes several final
triangles for the one it hits, and a shadow ray needs no colour at all, so running
them on the way took a fifth of the terrain's camera rays. The ∩ and \\ interval walk
still runs them on the way: its pieces carry their paint."""
from __future__ import annotations

from ..graph.model import CALC
from .jit import inline
from .nodes import DCALC, DPAINT, NODE, SLOT, eval_args, run_calc


@inline
def defer_step(flat, node, kind, I, f):
    """Pass a marked C-node or paint node without running it: True if it was one."""
    if flat.defer[node] == 0:
        return False
    if kind == CALC:
        I[f, DCALC] = node
    else:
        I[f, DPAINT] = node
    I[f, NODE] = flat.children[flat.child_start[node]]
    return True


@inline
def deferred_paint(flat, I, H, f, params, stack, args):
    """Run frame f's passed C-node (into the spare last row of `params`) and paint node
    for a hit; the colour is in args[0:3]. False if it is not finite: the instance is
    empty then, as when the walk finds that on the way. True at once if none was passed."""
    paint = I[f, DPAINT]
    if paint < 0:
        return True         # no colour waits; a passed block's results are read by no one
    slot = I[f, SLOT]
    calc = I[f, DCALC]
    if calc >= 0:
        spare = params.shape[0] - 1
        run_calc(flat, calc, params, slot, spare, H[f], stack)
        slot = spare
    return eval_args(flat, paint, params, slot, H[f], stack, args)
