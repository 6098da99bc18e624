"""When the memoised bounding walk gives up on a system whose states do not repeat: at
bounds.PROBE_RANDOM states where they hold values drawn from rand() (the terrain's
heights), at PROBE_STATES otherwise; and a random system whose states do repeat keeps
memoising."""
import numpy as np

from pcsg.compiler import compile_text
from pcsg.graph import bounds
from pcsg.graph.dependence import StateKey, drawn_params
from pcsg.graph.regroup import regroup
from pcsg.trace.boxwalk import walk_boxes

from .conftest import GRAMMARS

# the scale drawn from rand() seeded by the level: the states of a level are one
DRAWN_SCALE = """
{c = 7; s = 0.5} S
S if(c > 0, 2, 1)
1: S -> sphere
2: S -> {c = c-1; s = 0.4 + 0.2*rand(c)} (move(1,0,0) uscale(s) S ∪ move(-1,0,0) uscale(s) S)
"""
# no rand(), and no state met twice: every branch moves by its own a
NEVER_TWICE = """
{c = 9; a = 1} S
S if(c > 0, 2, 1)
1: S -> uscale(0.1) move(a, 0, 0) sphere
2: S -> ({c = c-1; a = 2*a+1} S ∪ {c = c-1; a = 3*a+1} S)
"""


def graph_of(text: str, **overrides):
    """The graph as a render bounds it (tracer.Traced regroups it first)."""
    return regroup(compile_text(text, "probe", overrides))


def states_seen(graph):
    """The memo's sizes the memoised walk met on its way, and whether it gave up."""
    seen = []
    real = bounds._Walker.box

    def spy(self, *a):
        seen.append(len(self.memo))
        return real(self, *a)
    bounds._Walker.box = spy
    try:
        bounds._memoised(graph)
        gave_up = False
    except bounds.TooManyStates:
        gave_up = True
    finally:
        bounds._Walker.box = real
    return seen, gave_up


def test_the_terrains_heights_are_drawn_and_its_counts_are_not():
    g = graph_of((GRAMMARS / "carpenter_terrain.pcsg").read_text(), cnt=3)
    drawn = drawn_params(g)
    assert {"z1", "z2", "z3", "nz12", "nz13", "nz23", "rnd"} <= drawn
    assert not {"cnt", "kl", "delta", "x1", "y1", "sealevel"} & drawn
    assert StateKey(g, geometry=True).random


def test_the_terrain_gives_up_at_the_random_probe():
    g = graph_of((GRAMMARS / "carpenter_terrain.pcsg").read_text(), cnt=5)
    seen, gave_up = states_seen(g)
    assert gave_up and bounds.PROBE_RANDOM <= max(seen) < bounds.PROBE_STATES


def test_drawn_once_and_repeated_states_still_memoise():
    g = graph_of(DRAWN_SCALE)
    assert StateKey(g, geometry=True).random
    boxes, how, _, _ = bounds.hyper_boxes(g)
    assert how == "memoised"
    walked, complete, _, _ = walk_boxes(g)
    # the same exact boxes as the walk of every instance, to rounding
    assert complete and np.allclose(boxes[g.root], walked[g.root], rtol=0, atol=1e-12)


def test_a_system_without_rand_waits_for_the_full_probe():
    g = graph_of(NEVER_TWICE)
    assert not StateKey(g, geometry=True).random
    seen, gave_up = states_seen(g)
    assert gave_up and max(seen) >= bounds.PROBE_STATES > bounds.PROBE_RANDOM
