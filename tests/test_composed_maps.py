"""Runs of T-nodes computed from parameters, composed into one map where the run starts
(graph/flat.py _compose_chains, trace/nodes.py composed_affine): the tracer, packets
and single rays, must agree ray by ray with the brute-force trace of the graph as
written, and a bad argument is still reported at the transformation that has it."""
import numpy as np
import pytest

import pcsg
from pcsg.compiler import compile_file, compile_text
from pcsg.graph import flat as flat_module
from pcsg.graph.model import TRANSFORM
from pcsg.render.camera import finite_bounds

from .conftest import GRAMMARS
from .oracle import assert_agrees, camera_rays

# runs of every sort: fixed then computed (move rotz ...), computed then fixed
# (move(0, 0, -0.4 * n) uscale), five long, one under two parents (the named `twig`)
RUNS = """
twig = move(0, 0, 0.3 * n) zshear(0.2 * n, -0.1) scale(0.5, 0.4 + 0.05 * n, 0.6) cube
{ n = 3; a = 25 } S
S if(n > 0, 2, 1)
1: S → twig
2: S → {n = n - 1} (cylinder ∪
       move(0, 0, 1) rotz(a * n) zshear(0.1 * n, -0.05) rotx(8 * n) scale(0.7, 0.6, 0.7) S ∪
       move(1.2, 0, 0) rotx(a) uscale(0.5) S ∪
       move(0, 0, -0.4 * n) uscale(0.5) twig ∪
       move(-1, 0, 0) twig)
"""


def heads(flat):
    return [int(i) for i in np.flatnonzero(flat.then >= 0)]


def test_runs_are_composed_where_they_start():
    flat = pcsg.Traced(compile_text(RUNS, "t.pcsg")).flat
    assert len(heads(flat)) >= 5
    for i in heads(flat):
        assert flat.kind[i] == TRANSFORM and flat.kind[flat.then[i]] == TRANSFORM
        # the head points past its whole run
        assert flat.kind[flat.children[flat.child_start[i]]] != TRANSFORM
    # a fixed head with computed maps below it is not taken for a fixed map
    assert any(flat.fixed[i] for i in heads(flat))


def test_composed_runs_trace_as_written():
    written = compile_text(RUNS, "t.pcsg")
    traced = pcsg.Traced(written)
    for direction in ([1.0, -1.3, 0.8], [-0.4, 0.2, -1.0], [0.3, 1.0, 0.1]):
        o, d = camera_rays(finite_bounds(traced), 48, np.array(direction))
        together = assert_agrees(traced, o, d, min_hits=60, reference_graph=written)
        alone = traced.trace(o, d, packets=False)
        assert np.array_equal(alone.hit, together.hit)
        assert np.allclose(alone.t[alone.hit], together.t[alone.hit], rtol=1e-12, atol=0)


def test_a_block_above_a_run_is_not_left_to_the_hit():
    """A C-node over maps and a primitive that only colours is left to the hit
    (graph/defer.py); here the run's second map reads what it assigns, so it must run
    on the way down, though the run's head reads nothing."""
    text = "{ s = 0.4 + 0.2 * rand() } move(0, 0, 1) rotz(30) scale(1, s, 1) sphere"
    written = compile_text(text, "t.pcsg")
    traced = pcsg.Traced(written)
    assert heads(traced.flat) and not traced.flat.defer.any()
    o, d = camera_rays(finite_bounds(traced), 24, np.array([0.3, -1.0, 0.4]), spread=0.3)
    assert_agrees(traced, o, d, min_hits=100, reference_graph=written)


def not_composed(monkeypatch):
    monkeypatch.setattr(flat_module, "_compose_chains",
                        lambda kind, starts, children: np.full(len(kind), -1, dtype=np.int32))


def test_the_terrain_keeps_its_picture(monkeypatch):
    """move(0,0,z1) zshear(...) in one map: the same hits as map by map, and the same
    boxes, as the bounding walk enters runs map by map (composed, it was slower)."""
    graph = compile_file(GRAMMARS / "carpenter_terrain.pcsg", {"cnt": 3})
    traced = pcsg.Traced(graph)
    assert heads(traced.flat)
    o, d = camera_rays(finite_bounds(traced), 32, np.array([1.0, 1.2, 0.6]))
    hits = traced.trace(o, d)
    not_composed(monkeypatch)
    plain = pcsg.Traced(graph)
    assert not heads(plain.flat)
    assert np.array_equal(traced.flat.box, plain.flat.box)
    again = plain.trace(o, d)
    assert hits.hit.sum() > 500 and np.array_equal(hits.hit, again.hit)
    assert np.allclose(hits.t[hits.hit], again.t[hits.hit], rtol=1e-12, atol=0)


@pytest.mark.parametrize("bad, kind", [("0.5 + ln(x)", "non-finite argument"),
                                       ("x", "singular transformation")])
def test_a_bad_map_in_a_run_is_reported_where_it_is(bad, kind):
    """The run move rotz scale starts at column 8 of line 3 and composes at run time (x
    differs from instance to instance); the scale, bad where x = 0, is at column 31. The
    bounds would leave the bad instances' boxes empty and no ray would meet them: with
    too many states to memoise and a selection that reads `pixels`, which the walk of
    every instance cannot bound, nothing is bounded (a budget too small to walk them
    now bounds them to a shallower depth)."""
    text = ("{ n = 13; x = 0 } S\nS if(n > 0 && pixels > 0, 2, 1)\n"
            f"1: S → move(0, 0, 1) rotz(30) scale(1, {bad}, 1) sphere\n"
            "2: S → {n = n - 1} (S ∪ {x = x + rand()} S)\n")
    traced = pcsg.Traced(compile_text(text, "t.pcsg"))
    assert traced.bounds_method == "unbounded" and heads(traced.flat)
    o, d = camera_rays(np.array([-1.0, -1, 0, 1, 1, 2]), 8, np.array([0.2, -1.0, 0.5]))
    for packets in (True, False):
        h = traced.trace(o, d, packets=packets)
        assert h.hit.any()              # the instances where x > 0
        lines = [x for x in traced.describe_events(h.events) if kind in x]
        assert len(lines) == 1 and "at t.pcsg:3:31" in lines[0], lines


def test_the_constant_maps_found_as_one_stack_are_those_found_one_by_one():
    """flat.fixed_maps tests and inverts every constant map as one stack, and the fixed
    chains' inverses are taken once at the end: the same bits as a map at a time, and
    the singular, non-finite and computed maps left to the walk as before."""
    text = ("{a = 2} (move(1, 2, 3) uscale(0.5) rotz(30) scale(1, 2, 3) sphere ∪ "
            "scale(0, 1, 1) cube ∪ move(1/0, 0, 0) cube ∪ uscale(a) cube ∪ "
            "flipxy mirror(1, 1, 0) xshear(0.3, 0.2) cone ∪ "
            "matrix(1,2,3,4, 5,6,7,8, 9,10,11,12) cube ∪ rot(45, 1, 1, 0) cylinder)")
    g = compile_text(text, "maps.pcsg")
    ids, maps = flat_module.fixed_maps(g)
    one_by_one = {i: flat_module.fixed_matrix(g, i) for i in range(len(g.nodes))}
    assert ids.tolist() == [i for i, m in one_by_one.items() if m is not None]
    assert len(ids) == 9        # not scale(0, ...), move(1/0, ...), uscale(a) nor matrix(...)
    for i, m in zip(ids.tolist(), maps):
        assert m.tobytes() == one_by_one[i][:3].tobytes()
    fixed, fixed_map = flat_module._fixed_nodes(g)
    for i in ids.tolist():
        inverse = np.linalg.inv(one_by_one[i][:3, :3])
        assert fixed[i] == 1 and fixed_map[i, 12:21].tobytes() == inverse.ravel().tobytes()
    # composed where a fixed map's child is one: the inverse of the product, in bits
    flat = pcsg.loads(text).flat
    assert (flat.fixed[flat.kind == TRANSFORM] == 1).sum() >= 5
    for i in np.flatnonzero((flat.kind == TRANSFORM) & (flat.fixed == 1)):
        lin = flat.fixed_map[i, :9].reshape(3, 3)
        assert flat.fixed_map[i, 12:21].tobytes() == np.linalg.inv(lin).ravel().tobytes()
