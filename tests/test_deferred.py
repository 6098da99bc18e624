"""C-nodes and paint nodes that only a hit needs run at the hit (graph/defer.py,
trace/deferred.py): which nodes are passed, and that rays see the same colours, the
same empty instances and the same shadows as the brute-force reference, which runs
every block where the derivation meets it."""
from pathlib import Path

import numpy as np
import pytest

import pcsg
from pcsg.graph.model import CALC, PAINT

from .oracle import assert_agrees, camera_rays

ROOT = Path(__file__).resolve().parent.parent

# colours from rand() (the instance hash) in a block only paint reads; a paint of
# sqrt(c - 0.4), not finite where c < 0.4, so those spheres are empty and the rays
# go on to the spheres and the floor behind; and a block whose result a T-node reads
SYSTEM = """
{n = 3; s = 0.6} (A ∪ paint(0.5, 0.5, 0.5) move(0, 0, -1.5) plane)
A if(n > 0, 2, 1)
1: A → {c = rand(); g = 0.2 + 0.6*rand()} paint(sqrt(c - 0.4), g, 0.3) move(0, 0, 0.1) uscale(0.9) sphere
2: A → {n = n-1} move(-0.6, 0, 0) uscale(0.55) A ∪
       {n = n-1} move(0.6, 0, 0.2) uscale(0.55) B ∪
       {n = n-1; h = 0.3*n} move(0, 0.6, h) paint(h, 1 - h, 0.5) uscale(0.5) cube
B if(n > 0, 2, 1)
1: B → {k = 0.25 + 0.5*rand()} move(0, 0, k) paint(k, k, 1 - k) cube
2: B → {n = n-1} move(0, -0.5, 0) uscale(0.6) A ∪ {n = n-1} move(0, 0.5, 0) uscale(0.6) B
"""


def marked(traced, kind):
    g = traced.graph
    return [i for i, n in enumerate(g.nodes) if n.kind == kind and traced.flat.defer[i]]


def test_only_blocks_and_paints_on_a_chain_to_a_primitive_are_passed():
    t = pcsg.loads(SYSTEM)
    calcs = {tuple(t.graph.nodes[i].targets) for i in marked(t, CALC)}
    names = {v: k for k, v in t.graph.params.items()}
    calcs = {tuple(sorted(names[p] for p in c)) for c in calcs}
    # A's terminating block; not B's (its move reads k), nor any that a selection or a
    # T-node below reads
    assert calcs == {("c", "g")}
    # every paint whose colour is not constant and that leads to a primitive alone
    paints = marked(t, PAINT)
    assert len(paints) == 3
    assert all(not t.flat.fixed[i] for i in paints)


def test_the_terrains_colour_blocks_are_passed():
    t = pcsg.load(ROOT / "grammars" / "carpenter_terrain.pcsg", cnt=2)
    names = {v: k for k, v in t.graph.params.items()}
    blocks = [{names[p] for p in t.graph.nodes[i].targets} for i in marked(t, CALC)]
    assert len(blocks) == 2 and all({"cr", "cg", "cb", "slope"} <= b for b in blocks)
    assert len(marked(t, PAINT)) == 2


@pytest.mark.parametrize("direction", [(1, -2, 1.5), (-1, 1, 2), (0.2, 0.1, 1)])
def test_rays_agree_with_the_reference(direction):
    t = pcsg.loads(SYSTEM)
    o, d = camera_rays(t.bounds, 40, direction)
    got = assert_agrees(t, o, d, min_hits=400)
    # some rays met an empty sphere (a paint not finite) and went on behind it
    assert any("non-finite" in line for line in t.describe_events(got.events))
    single = t.trace(o, d, packets=False)
    np.testing.assert_array_equal(single.t, got.t)
    np.testing.assert_array_equal(np.nan_to_num(single.paint, nan=-1.0),
                                  np.nan_to_num(got.paint, nan=-1.0))


# a block and two paints on one chain, all three passed to the hit: the inner paint colours
NESTED = """
{n = 2} A
A if(n > 0, 2, 1)
1: A → {c = rand()} paint(c, 0.2, 0.9) paint(0.3, c, 1 - c) uscale(0.9) sphere
2: A → {n = n-1} move(-0.5, 0, 0) uscale(0.5) A ∪ {n = n-1} move(0.5, 0, 0) uscale(0.5) A ∪
       {n = n-1} move(0, 0.5, 0) uscale(0.5) A ∪ {n = n-1} move(0, -0.5, 0) uscale(0.5) A
"""


def test_a_block_and_two_passed_paints_the_inner_one_colours():
    t = pcsg.loads(NESTED)
    assert len(marked(t, CALC)) == 1 and len(marked(t, PAINT)) == 2
    o, d = camera_rays(t.bounds, 40, (0.2, 0.1, 1))
    got = assert_agrees(t, o, d, min_hits=150)
    single = t.trace(o, d, packets=False)
    np.testing.assert_array_equal(single.t, got.t)
    np.testing.assert_array_equal(single.paint, got.paint)
    # every sphere has the inner paint's colour: red 0.3, green and blue adding up to 1
    np.testing.assert_array_equal(got.paint[got.hit, 0], 0.3)
    np.testing.assert_allclose(got.paint[got.hit, 1] + got.paint[got.hit, 2], 1.0)
    assert np.ptp(got.paint[got.hit, 1]) > 0.1         # rand() differs from sphere to sphere


EMPTY = """
{c = 0.1} paint(sqrt(c - 0.4), 0.5, 0.5) sphere ∪
{c = 0.9} paint(sqrt(c - 0.4), 0.5, 0.5) move(3, 0, 0) sphere
"""


@pytest.mark.parametrize("packets", [True, False])
def test_an_empty_instance_stops_no_ray(packets):
    """Shadow rays need no colour, but the colour decides whether the instance is there:
    the sphere at x = 0 has a paint that is not finite, so it is empty for every ray."""
    t = pcsg.loads(EMPTY)
    assert len(marked(t, CALC)) == 2 and len(marked(t, PAINT)) == 2
    x = np.repeat([0.0, 3.0], 64) + np.tile(np.linspace(-0.5, 0.5, 8), 16)
    y = np.tile(np.repeat(np.linspace(-0.5, 0.5, 8), 8), 2)
    o = np.stack([x, y, np.full_like(x, 5.0)], axis=1)
    d = np.tile([0.0, 0.0, -1.0], (len(o), 1))
    for any_hit in (False, True):
        hits = t.trace(o, d, any_hit=any_hit, packets=packets)
        assert not hits.hit[:64].any() and hits.hit[64:].all()
        assert any("non-finite" in line for line in t.describe_events(hits.events))


@pytest.mark.parametrize("source", [SYSTEM, "terrain"])
def test_the_bounding_walk_passes_the_blocks_without_changing_a_box(source, monkeypatch):
    """The box walk passes the marked C-nodes too (colour bounds nothing): the hyper boxes
    and the per-instance table are what the walk that runs every block computes."""
    from pcsg.graph import flat as flat_module
    from pcsg.trace.boxwalk import walk_boxes
    t = (pcsg.load(ROOT / "grammars" / "carpenter_terrain.pcsg", cnt=4)
         if source == "terrain" else pcsg.loads(source))
    assert marked(t, CALC)
    passing = walk_boxes(t.graph, instances=True)
    monkeypatch.setattr(flat_module, "deferrable",
                        lambda graph, *rest: np.zeros(len(graph.nodes), dtype=np.int8))
    running = walk_boxes(t.graph, instances=True)
    np.testing.assert_array_equal(passing[0], running[0])
    assert passing[1] == running[1] and passing[3] == running[3]     # complete, depth
    for got, want in zip(passing[2], running[2]):
        np.testing.assert_array_equal(got, want)
