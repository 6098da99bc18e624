"""The bounding walk steps over the nodes that cannot change a box (graph/passthrough.py):
the same boxes and table entries as the walk through them, only where that holds."""
import numpy as np
import pytest

import pcsg
from pcsg.compiler import compile_file, compile_text
from pcsg.graph import bounds
from pcsg.graph.fuse import fuse_runs
from pcsg.graph.model import CALC, PAINT
from pcsg.graph.passthrough import fill_boxes, without_passable
from pcsg.render.camera import finite_bounds
from pcsg.trace.boxwalk import walk_boxes

from .conftest import GRAMMARS
from .oracle import assert_agrees, camera_rays

SYSTEM = """
{ n = 3; r = 1; c = 0 } S
S if(n > 0, 2, 1)
1: S → { r = 0.5 + 0.1 * n; c = n / 3 } paint(c, 0.5, 1 - c) move(0, 0, r) uscale(r) sphere
2: S → { n = n - 1 } (paint(1, 0, 0) T ∪ move(2, 0, 0) T ∪
       { c = 0.2 * n } paint(c, c, c) move(0, 2, 0) scale(0.5, 0.5, 0.5) cube)
T 1
1: T → scale(0.6, 0.6, 0.6) S
"""


def reached(graph):
    seen, todo = {graph.root}, [graph.root]
    while todo:
        for c in graph.nodes[todo.pop()].children:
            if c not in seen:
                seen.add(c)
                todo.append(c)
    return seen


def entries(table):
    keys, used, vals = table
    order = np.argsort(keys[used > 0], kind="stable")
    return keys[used > 0][order], used[used > 0][order], vals[used > 0][order]


def assert_same_walk(graph):
    """The walk of the graph without its passable nodes, their boxes filled in, is the
    walk through them: the same bits."""
    walked, skipped = without_passable(graph)
    boxes, complete, table, depth = walk_boxes(walked, instances=True)
    fill_boxes(boxes, skipped)
    plain, complete0, table0, depth0 = walk_boxes(graph, instances=True)
    assert complete and complete0 and depth == depth0
    assert np.array_equal(boxes, plain)
    for a, b in zip(entries(table), entries(table0)):
        assert np.array_equal(a, b)
    return walked, skipped


def test_the_terrain_steps_over_its_colours():
    """Its final triangles' colour block and paint, and the sea's material (kept under
    the union, whose operands own their table entries)."""
    graph = fuse_runs(compile_file(GRAMMARS / "carpenter_terrain.pcsg", {"cnt": 4}))
    walked, skipped = assert_same_walk(graph)
    kinds = sorted(graph.nodes[i].kind_name for i in skipped)
    assert kinds == ["calc", "calc", "material", "paint", "paint"]
    gone = reached(graph) - reached(walked)
    assert sorted(graph.nodes[i].kind_name for i in gone) == ["calc", "calc", "paint", "paint"]


def test_what_it_keeps():
    """A C-node whose values a T-node below reads, and a paint whose child has another
    parent, stay; an operand stays its union's child, its own chain stepped over."""
    graph = compile_text(SYSTEM, "t.pcsg")
    walked, skipped = assert_same_walk(graph)
    nodes = graph.nodes
    r, c = graph.params["r"], graph.params["c"]
    calcs = {tuple(x.targets): i for i, x in enumerate(nodes) if x.kind == CALC}
    paints = [i for i, x in enumerate(nodes) if x.kind == PAINT]
    leaf_calc, operand_calc = calcs[r, c], calcs[c,]
    red = next(i for i in paints if graph.exprs.constant(nodes[i].exprs[0]) == 1.0)
    assert leaf_calc not in skipped and red not in skipped
    assert set(skipped) == {operand_calc} | (set(paints) - {red})
    union = next(i for i, x in enumerate(nodes) if operand_calc in x.children)
    assert operand_calc in walked.nodes[union].children          # the operand as written
    assert walked.nodes[operand_calc].children == [skipped[operand_calc]]


@pytest.mark.parametrize("direction", [[1.0, -1.3, 0.8], [-0.4, 0.2, -1.0]])
def test_walked_without_them_it_traces_as_written(monkeypatch, direction):
    monkeypatch.setattr(bounds, "MAX_STATES", 0)
    graph = compile_text(SYSTEM, "t.pcsg")
    traced = pcsg.Traced(graph)
    assert traced.bounds_method == "every instance"
    o, d = camera_rays(finite_bounds(traced), 40, np.array(direction))
    assert_agrees(traced, o, d, min_hits=40, reference_graph=graph)


# a paint between two fixed maps: stepped over, the walk composed rotx with move and
# uscale as one map and never visited move or uscale, which the tracer enters below the
# paint: their boxes stayed empty and the rays of that operand missed it (found by
# hypothesis in tests/test_balls.py)
BETWEEN_MAPS = ("{n = 1} S\nS if(n > 0, 2, 1)\n1: S → sphere\n2: S → {n = n - 1} "
                "(rotx(1) paint(0, 0, n / 4) move(0, 0, 0) uscale(0.5) S ∪ "
                "move(0.2, 0.1, 0) uscale(0.5) S)\n")


def test_a_paint_between_two_maps_is_walked(monkeypatch):
    graph = compile_text(BETWEEN_MAPS, "t.pcsg")
    walked, skipped = assert_same_walk(graph)
    assert not skipped
    monkeypatch.setattr(bounds, "MAX_STATES", 0)
    traced = pcsg.Traced(graph)
    assert traced.bounds_method == "every instance"
    o, d = camera_rays(traced.bounds, 16, np.array([1.0, -1.3, 0.8]), seed=7)
    assert_agrees(traced, o, d, min_hits=20, reference_graph=graph)
