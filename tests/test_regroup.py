"""Unions regrouped for the tracer (graph/regroup.py): the same object, ray by ray, as
the brute-force trace of the graph as written; the same rand() draws; fewer frames."""
import numpy as np
import pytest

import pcsg
from pcsg.compiler import compile_file, compile_text
from pcsg.graph.expand import expand_file
from pcsg.graph.model import CALC, PRIMITIVE, SELECT, TRANSFORM, UNION
from pcsg.graph.regroup import OPERANDS, regroup
from pcsg.render.camera import finite_bounds

from .conftest import GRAMMARS
from .oracle import assert_agrees, camera_rays

BRANCHES = """
{ n = 4; k = 0 } (S ∪ move(0, 0, -0.5) cube)
S if(n > 0, 2, 1)
1: S → uscale(0.3) sphere
2: S → scale(0.2, 0.2, 1) cylinder ∪
       move(0, 0, 1) rotz(40) ({n = n - 1} rotx(-50) uscale(0.7) S ∪
                               {n = n - 1} rotx(30) uscale(0.6) S)
"""

# rand() decides the angles: the draws hash the instance's path through the unions
RANDOM = BRANCHES.replace("rotx(-50)", "rotx(-20 - 50 * rand())").replace(
    "{n = n - 1} rotx(30)", "{n = n - 1; a = 40 * rand()} rotx(a)")

NESTED = """
move(1, 0, 0) rotz(30) uscale(0.8) (sphere ∪ move(2, 0, 0) cube ∪
                                    (cone ∪ move(0, 2, 0) sphere))
"""

BALANCED = """
((sphere ∪ move(2, 0, 0) sphere) ∪ (move(0, 2, 0) cube ∪ move(2, 2, 0) cube)) ∪
((move(0, 0, 2) cone ∪ move(2, 0, 2) cone) ∪ (move(0, 2, 2) sphere ∪ move(2, 2, 2) cube))
"""

SHARED = """
pair = move(1, 0, 0) (sphere ∪ move(0, 2, 0) cube)
pair ∪ move(0, 0, 3) rotx(20) pair
"""


def reachable_unions(g):
    seen, stack, out = set(), [g.root], []
    while stack:
        i = stack.pop()
        if i in seen:
            continue
        seen.add(i)
        if g.nodes[i].kind == UNION:
            out.append(i)
        stack.extend(g.nodes[i].children)
    return out


@pytest.mark.parametrize("text", [BRANCHES, RANDOM, NESTED, BALANCED, SHARED])
def test_the_same_object_as_written(text):
    written = compile_text(text, "t.pcsg")
    traced = pcsg.Traced(written)
    assert traced.graph is not written
    for direction in ([1.0, -1.3, 0.8], [-0.4, 0.2, -1.0]):
        o, d = camera_rays(finite_bounds(traced), 24, np.array(direction))
        assert_agrees(traced, o, d, min_hits=20, reference_graph=written)


def test_the_tree_maps_a_sub_crown_once():
    t = pcsg.load(GRAMMARS / "sympodial_tree.pcsg", cnt=5)
    g, flat = t.graph, t.flat
    tr = g.modules["TR"]
    crown = g.nodes[g.nodes[tr].children[2]]        # SG ∪ move rotz (... ∪ ...)
    assert crown.kind == UNION
    assert [g.nodes[c].kind for c in crown.children] == [SELECT, CALC, CALC]
    for c in crown.children[1:]:
        # {cnt=cnt-1} then one map, move rotz rotx uscale composed, then TR
        t_node = g.nodes[c].children[0]
        assert g.nodes[t_node].kind == TRANSFORM and flat.fixed[t_node]
        assert flat.children[flat.child_start[t_node]] == tr
    written = compile_file(GRAMMARS / "sympodial_tree.pcsg", {"cnt": 5})
    # the sub-crowns' pair and a segment's pair of leaves (under move(0,0,dSG)) are
    # spliced into the unions above them
    assert len(reachable_unions(g)) == len(reachable_unions(written)) - 2


def test_rand_draws_are_kept():
    """With rand() the hashes must not change: the unions stay, with their operands in
    order, and the hits are the graph's as written, bit for bit."""
    written = compile_text(RANDOM, "t.pcsg")
    g = regroup(written)
    assert sorted(reachable_unions(g)) == sorted(reachable_unions(written))
    for u in reachable_unions(g):
        assert len(g.nodes[u].children) == len(written.nodes[u].children)
    a = pcsg.Traced(written)
    b = pcsg.Traced(written, regrouped=False)
    o, d = camera_rays(finite_bounds(b), 32, np.array([1.0, -1.3, 0.8]))
    ha, hb = a.trace(o, d), b.trace(o, d)
    assert hb.hit.sum() > 100
    assert np.array_equal(ha.hit, hb.hit)
    assert np.allclose(ha.t[ha.hit], hb.t[hb.hit], rtol=1e-12, atol=0)


def test_a_nest_of_unions_keeps_its_hierarchy():
    written = compile_text(BALANCED, "t.pcsg")
    g = regroup(written)
    sizes = [len(g.nodes[u].children) for u in reachable_unions(g)]
    assert max(sizes) == OPERANDS
    assert sum(sizes) - len(sizes) + 1 == 8        # eight primitives under them all


def test_a_root_run_of_maps_goes_into_the_union_and_stays_there():
    """The run goes into each operand of the union below it, the inner union too, but
    no further: pushed on through every union, every map would go down to every
    primitive of an expanded system."""
    g = regroup(compile_text(NESTED, "t.pcsg"))
    root = g.nodes[g.root]
    assert root.kind == UNION and len(root.children) == 3
    assert all(g.nodes[c].kind == TRANSFORM for c in root.children)
    inner = g.nodes[root.children[2]]
    while inner.kind == TRANSFORM:
        inner = g.nodes[inner.children[0]]
    assert inner.kind == UNION and len(inner.children) == 2
    assert all(g.nodes[c].kind == PRIMITIVE or g.nodes[c].kind == TRANSFORM
               for c in inner.children)


def test_an_expanded_system_grows_by_its_unions_operands_only():
    """Each run of maps is copied once per further operand of its own union: 2 052
    nodes become 2 945; pushed on through every union below, 3 806, a share that grows
    with the depth."""
    text = ("S\nS if(n > 0, 2, 1)\n1: S → sphere\n2: S → uscale(0.5) sphere ∪ "
            "{n = n - 1} move(0, 0, 1) rotz(30) (uscale(0.6) S ∪ rotx(40) uscale(0.7) S)\n")
    expanded = compile_text(expand_file(compile_text("{ n = 8 } " + text, "t.pcsg"), 20),
                            "e.pcsg")
    g = regroup(expanded)
    assert len(g.nodes) < 1.6 * len(expanded.nodes)
    traced = pcsg.Traced(expanded)
    o, d = camera_rays(finite_bounds(traced), 64, np.array([1.0, -1.3, 0.8]))
    assert_agrees(traced, o, d, min_hits=20, reference_graph=expanded)


def test_shared_nodes_are_left_as_they_are():
    written = compile_text(SHARED, "t.pcsg")
    g = regroup(written)
    for i, (a, b) in enumerate(zip(written.nodes, g.nodes)):
        if a.kind == UNION and i in reachable_unions(written):
            assert b.children == a.children


def test_a_run_goes_below_thousands_of_calculations():
    """The run goes down past the operand's C-nodes in a loop: a recursion would stop
    at Python's limit on this system (it did)."""
    text = ("{ x = 0 } move(1, 0, 0) (" + "{x = x + 1} " * 5000
            + "sphere ∪ move(0, 2, 0) cube)\n")
    written = compile_text(text, "t.pcsg")
    g = regroup(written)
    below = g.nodes[g.nodes[g.root].children[0]]      # past { x = 0 }: the union
    assert below.kind == UNION
    for c in below.children:
        node = g.nodes[c]
        while node.kind == CALC:
            node = g.nodes[node.children[0]]
        assert node.kind == TRANSFORM       # the move, below the 5 000 C-nodes
    # the sphere and the cube moved by (1, 0, 0); the third ray meets them unmoved only
    hits = pcsg.Traced(written).trace(np.array([[1.0, 0, -5], [1.0, 2, -5], [-0.9, 0, -5]]),
                                      np.array([[0, 0, 1.0]] * 3))
    assert list(hits.hit) == [True, True, False] and np.allclose(hits.t[:2], 4.0)


def test_a_run_with_a_map_of_parameters_is_pushed_below_that_map_only():
    """The constant maps below `move(c, 0, 0)` go into the operands, the move and the map
    above it stay over the union; the maps above a run that stays are not walked again
    from each of them (a chain of 10 000 maps took 7.5 s)."""
    text = """{c = 2} S
S if(c > 0, 2, 1)
1: S → sphere
2: S → {c = c - 1} rotx(10) move(c, 0, 0) rotz(30) uscale(0.8) (S ∪ move(0, 2, 0) cube)
"""
    written = compile_text(text, "t.pcsg")
    g = regroup(written)

    def run(x):
        names = []
        while g.nodes[x].kind == TRANSFORM:
            names.append(g.nodes[x].name)
            x = g.nodes[x].children[0]
        return names, x

    rule = g.nodes[g.nodes[g.nodes[g.root].children[0]].children[1]]   # {c = c - 1}
    above, union = run(rule.children[0])
    assert above == ["rotx", "move"] and g.nodes[union].kind == UNION
    assert [run(c)[0][:2] for c in g.nodes[union].children] == [["rotz", "uscale"]] * 2
    traced = pcsg.Traced(written)
    for direction in ([1.0, -1.3, 0.8], [-0.4, 0.2, -1.0]):
        o, d = camera_rays(finite_bounds(traced), 24, np.array(direction))
        assert_agrees(traced, o, d, min_hits=20, reference_graph=written)
