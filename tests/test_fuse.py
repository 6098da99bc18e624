"""Runs of T-nodes written out as one `matrix` node for systems bounded instance by
instance (graph/fuse.py): the node's map is the product of the run's maps, a bad
argument still empties the instance, and the tracer, with the boxes of the walk over
every instance, agrees ray by ray with the brute-force reference of the graph as
written. Systems bounded by their states keep their runs."""

import math

import numpy as np
import pytest

import pcsg
from pcsg.compiler import compile_file, compile_text
from pcsg.graph import bounds
from pcsg.graph.fuse import MOST_TERMS, _size, fuse_runs
from pcsg.graph.model import TRANSFORM
from pcsg.render.camera import finite_bounds
from pcsg.trace import boxwalk
from pcsg.trace.boxwalk import walk_boxes
from pcsg.trace.transforms import matrix

from .conftest import GRAMMARS
from .oracle import assert_agrees, camera_rays

# every map fuse.py writes out, with arguments computed from p, q and r
MAPS = ["move(p, 0.5 * q, -r)", "scale(p, q, 1.5)", "uscale(q)", "rotx(40 * p)",
        "roty(-25 * q)", "rotz(r * 90)", "zshear(p, -q)", "xshear(0.3, r)", "yshear(q, p)",
        "flipxy", "flipxz", "flipyz", "matrix(p, 0.1, 0, r, 0, q, 0.2, 0, 0.3, 0, 1, p)",
        "move(1, 2, 3)", "rotz(30)"]


def fused_heads(fused):
    """The heads of the runs that `matrix` nodes stand for."""
    return sorted(fused.origins.values())


def run_maps(graph, head, params):
    """The head's run in the graph as written: each map's 4x4 matrix, evaluated."""
    out, node = [], head
    while graph.nodes[node].kind == TRANSFORM:
        x = graph.nodes[node]
        args = [graph.exprs.evaluate(e, params) for e in x.exprs]
        out.append(matrix(x.name, args))
        node = x.children[0]
    return out, node


@pytest.mark.parametrize("seed", range(6))
def test_the_fused_map_is_the_product_of_the_run(seed):
    rng = np.random.default_rng(seed)
    for _ in range(6):
        run = " ".join(rng.choice(MAPS, size=int(rng.integers(2, 6))))   # some constant
        graph = compile_text(f"{{ p = 0.7; q = 1.3; r = -0.4 }} {run} cube", "t.pcsg")
        fused = fuse_runs(graph)
        # each matrix node in its run's place under every parent that is not a T-node
        # (a T-node above heads a longer run)
        instead = {head: m for m, head in fused.origins.items()}
        for i, x in enumerate(graph.nodes):
            want = x.children if x.kind == TRANSFORM else [instead.get(c, c) for c in x.children]
            assert fused.nodes[i].children == want
        assert fused.root == instead.get(graph.root, graph.root)
        for m, head in fused.origins.items():
            params = np.zeros(len(graph.params))
            for name, value in zip("pqr", rng.uniform(-2, 2, 3)):
                params[graph.params[name]] = value
            maps, below = run_maps(graph, head, params)
            want = np.linalg.multi_dot(maps) if len(maps) > 1 else maps[0]
            node = fused.nodes[m]
            assert node.name == "matrix" and node.children == [below]
            got = np.array([fused.exprs.evaluate(e, params) for e in node.exprs]).reshape(3, 4)
            assert np.allclose(got, want[:3], rtol=1e-12, atol=1e-12), run
        computed = [i for i in range(len(graph.nodes)) if graph.nodes[i].kind == TRANSFORM
                    and graph.nodes[graph.nodes[i].children[0]].kind == TRANSFORM
                    and not all(graph.exprs.constant(e) is not None
                                for e in _run_exprs(graph, i))]
        assert fused_heads(fused) == computed, run


def _run_exprs(graph, head):
    node, out = head, []
    while graph.nodes[node].kind == TRANSFORM:
        out += graph.nodes[node].exprs
        node = graph.nodes[node].children[0]
    return out


def test_a_nonfinite_argument_still_empties_the_instance():
    graph = compile_text("{ n = 2; x = 1 } S\nS if(n > 0, 2, 1)\n"
                         "1: S → move(0, 0, x) zshear(ln(x), 2) scale(1, 1, x) cube\n"
                         "2: S → {n = n - 1; x = x - 0.5} S\n", "t.pcsg")
    fused = fuse_runs(graph)
    head = fused.nodes[next(iter(fused.origins))]
    params = np.zeros(len(graph.params))
    for x, finite in ((1.0, True), (0.0, False), (-1.0, False), (math.inf, False)):
        params[graph.params["x"]] = x
        got = [fused.exprs.evaluate(e, params) for e in head.exprs]
        # x = 0: the map is singular but finite, ln(0) alone is not; x = -1: ln is nan
        assert all(math.isfinite(v) for v in got) == finite, x


@pytest.mark.parametrize("run", ["rot(30, 1, 1, 0) move(0, 0, x)", "mirror(1, x, 0) uscale(x)",
                                 "move(0, 0, x) rotz(rand() * 90)",
                                 "move(1, 0, 0) uscale(0.5)", "move(0, 0, x) cube ∪ uscale(x)"])
def test_runs_it_leaves_as_written(run):
    # x varies: a parameter that holds one value everywhere is folded into a constant
    graph = compile_text(f"{{ n = 1; x = 0.5 }} S\nS if(n > 0, 2, 1)\n1: S → ({run} sphere)\n"
                         "2: S → {n = n - 1; x = x * 2} S\n", "t.pcsg")
    assert fuse_runs(graph) is graph


def walked(monkeypatch, text_or_graph):
    """The graph traced with the bounding walk's boxes (memoising turned off)."""
    monkeypatch.setattr(bounds, "MAX_STATES", 0)
    graph = (compile_text(text_or_graph, "t.pcsg") if isinstance(text_or_graph, str)
             else text_or_graph)
    traced = pcsg.Traced(graph)
    assert traced.bounds_method == "every instance"
    return graph, traced


RUNS = """
{ n = 3; a = 25 } S
S if(n > 0, 2, 1)
1: S → move(0, 0, 0.3 * n) zshear(0.2 * a, -0.1 * n) scale(0.5, 0.4 + 0.05 * a, 0.6) cube
2: S → {n = n - 1; a = a * 0.9} (cylinder ∪
       move(0, 0, 1) rotz(a * n) zshear(0.1 * n, -0.05) rotx(8 * n) scale(0.7, 0.6, 0.7) S ∪
       move(1.2, 0, 0) rotx(a) uscale(0.5) S ∪
       move(0, 0, -0.4 * n) yshear(0.1 * a, 0) flipxz uscale(0.5) S)
"""


def test_a_system_bounded_by_its_states_keeps_its_runs():
    """Its arguments run on the expression machine: the twelve entries would cost more."""
    traced = pcsg.Traced(compile_text(RUNS, "t.pcsg"))
    assert traced.bounds_method == "memoised"
    assert not traced.graph.origins and fuse_runs(traced.graph).origins


def test_a_run_too_long_to_write_out_is_composed_at_run_time():
    """The entries of a product of general maps grow about threefold with each map."""
    maps = " ".join(["rotx(a) roty(a + 1) zshear(a, -a) rotz(2 * a)"] * 6)
    graph = compile_text(f"{{ n = 1; a = 10 }} S\nS if(n > 0, 2, 1)\n1: S → {maps} cube\n"
                         "2: S → {n = n - 1; a = a * 2} S\n", "t.pcsg")
    fused = fuse_runs(graph)
    longest = max(len(_run_exprs(graph, h)) for h in fused_heads(fused))
    whole = max(len(_run_exprs(graph, i)) for i, x in enumerate(graph.nodes)
                if x.kind == TRANSFORM)
    assert 2 <= longest < whole // 2        # only the short ends of the run
    for m in fused.origins:
        assert sum(_size(fused.exprs.form(e)) for e in fused.nodes[m].exprs) <= MOST_TERMS


def test_walked_boxes_of_fused_runs_trace_as_written(monkeypatch):
    graph, traced = walked(monkeypatch, RUNS)
    assert len(traced.graph.origins) >= 4
    for direction in ([1.0, -1.3, 0.8], [-0.4, 0.2, -1.0], [0.3, 1.0, 0.1]):
        o, d = camera_rays(finite_bounds(traced), 48, np.array(direction))
        assert_agrees(traced, o, d, min_hits=60, reference_graph=graph)


def test_the_terrain_walks_to_the_same_boxes_and_table():
    """Against the walk of the graph as written: the same boxes for every node, a run's
    `matrix` node the box of the run's head (the walk no longer reaches the run, which
    the tracer never enters), and the same table entries to rounding (a box mapped by
    the product instead of map by map)."""
    graph = compile_file(GRAMMARS / "carpenter_terrain.pcsg", {"cnt": 4})
    fused = fuse_runs(graph)
    heads = fused_heads(fused)
    assert [graph.nodes[i].name for i in heads] == ["move", "move"]
    boxes, complete, table, depth = walk_boxes(fused, instances=True)
    plain, complete0, table0, depth0 = walk_boxes(graph, instances=True)
    assert complete and complete0 and depth == depth0
    n = len(graph.nodes)
    run = heads + [graph.nodes[i].children[0] for i in heads]
    assert np.all(boxes[run, 0] > boxes[run, 3])                    # not reached
    others = np.setdiff1d(np.arange(n), run)
    assert np.array_equal(boxes[others], plain[others])
    assert np.array_equal(boxes[list(fused.origins)], plain[list(fused.origins.values())])
    keys, used, vals = table
    keys0, used0, vals0 = table0
    assert np.array_equal(np.sort(keys[used > 0]), np.sort(keys0[used0 > 0]))
    a = vals[used > 0][np.argsort(keys[used > 0])]
    b = vals0[used0 > 0][np.argsort(keys0[used0 > 0])]
    assert np.array_equal(np.isfinite(a), np.isfinite(b))
    both = np.isfinite(a)
    assert np.abs(a[both] - b[both]).max() <= 1e-15


def test_the_walked_terrain_traces_as_written(monkeypatch):
    graph, traced = walked(monkeypatch, compile_file(GRAMMARS / "carpenter_terrain.pcsg",
                                                     {"cnt": 3}))
    o, d = camera_rays(finite_bounds(traced), 40, np.array([1.0, 1.2, 0.6]))
    assert traced.graph.origins
    assert_agrees(traced, o, d, min_hits=600, reference_graph=graph)
