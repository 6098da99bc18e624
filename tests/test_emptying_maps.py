"""A map whose arguments are not finite (uscale(1e999), move(sqrt(-1), 0, 0)) or that
is singular (uscale(0)) empties its instance, in the tracer as in the bounding walks; and
its box is then empty too, so no ray ever reaches it to count it as a runtime error. The
walk that met it says so once, where the T-node is written (notation §4: "reported
once"), and --strict fails on it (graph/bounds.py)."""
import numpy as np
import pytest

from pcsg.cli import main
from pcsg.compiler import compile_text
from pcsg.graph import boxcache
from pcsg.graph.bounds import fault_warnings
from pcsg.graph.flatten import flatten, leaf_inverse
from pcsg.graph.leaves import leaf_chunks
from pcsg.graph.linear import determinants, flat, invertible, singular
from pcsg.graph.model import TRANSFORM
from pcsg.trace.boxwalk import walk_boxes

# rand() draws a path's own numbers: no state repeats, so the instance walk bounds it
DRAWN = """{c = 5} S
S if(c > 0, 2, 1)
1: S → move(sqrt(rand() - 0.1), 0, 0) sphere
2: S → {c = c-1} (move(-1,0,0) uscale(0.5) S ∪ move(1,0,0) uscale(0.5) S ∪
                  move(0,1,0) uscale(0.5) S)
"""


def faults_of(traced, code="non-finite-map"):
    return [w for w in traced.warnings if w.code == code]


@pytest.mark.parametrize("text, column", [
    ("uscale(1e999) sphere ∪ move(3,0,0) cube", 1),
    ("{k = -1} move(sqrt(k), 0, 0) sphere ∪ move(3,0,0) cube", 10)])
def test_a_constant_map_that_is_not_finite_is_named(text, column):
    from pcsg.tracer import loads
    traced = loads(text, "t.pcsg")
    assert traced.bounds_method == "memoised"
    (w,) = faults_of(traced)
    assert (w.location.line, w.location.column) == (1, column)
    # constant arguments: every instance, as check says it (it said "in some instances");
    # k is read under the block, not at the axiom's head, so it is not a constant there
    assert w.message.endswith(": it empties its operand" if column == 1 else
                              " in some instances, which are empty (a runtime error in "
                              "the grammar)")


def test_the_instance_walk_counts_the_instances_the_reference_expansion_has():
    graph = compile_text(DRAWN, "t.pcsg")
    bad = sum(not np.isfinite(x.matrix).all() for x in flatten(graph))
    assert 0 < bad < 3 ** 5
    from pcsg.tracer import loads
    traced = loads(DRAWN, "t.pcsg")
    assert traced.bounds_method == "every instance"
    (w,) = faults_of(traced)
    assert f"not finite in {bad:,} instances" in w.message
    assert (w.location.line, w.location.column) == (3, 8)


@pytest.mark.parametrize("bad_map, code", [("move(sqrt(k - 0.1), 0, 0)", "non-finite-map"),
                                           ("scale(1, floor(k * 5), 1)", "singular-map")])
def test_the_instance_walk_names_the_map_of_a_fused_run_that_fails(bad_map, code):
    """The walk bounds a run of maps as one `matrix` node (graph/fuse.py), written at the
    run's head: it said `rotz(30)` where `move(sqrt(k - 0.1), 0, 0)` had the fault."""
    text = DRAWN.replace("move(sqrt(rand() - 0.1), 0, 0)",
                         "{k = rand()} rotz(30) " + bad_map + " roty(20)")
    text = text.replace("{c = 5}", "{c = 7}")   # states enough to be walked one by one
    graph = compile_text(text, "t.pcsg")
    bad = sum(leaf_inverse(x.matrix) is None for x in flatten(graph))
    assert 0 < bad < 3 ** 7
    from pcsg.tracer import loads
    traced = loads(text, "t.pcsg")
    assert traced.bounds_method == "every instance" and traced.graph.origins
    (w,) = faults_of(traced, code)
    assert f" in {bad:,} instances" in w.message
    line = text.splitlines()[2]
    assert (w.location.line, w.location.column) == (3, line.index(bad_map) + 1)


def test_a_system_without_such_maps_has_no_warning():
    from pcsg.tracer import loads
    fine = loads(DRAWN.replace("- 0.1", "+ 0.1"), "t.pcsg")
    assert faults_of(fine) == [] and faults_of(fine, "singular-map") == []


@pytest.mark.parametrize("text", ["uscale(0) sphere ∪ move(3,0,0) cube",
                                  "{k = 0} uscale(k) sphere ∪ move(3,0,0) cube",
                                  "scale(1, 0, 1) sphere ∪ move(3,0,0) cube"])
def test_a_singular_map_is_reported_once_and_its_box_is_empty(text):
    # a zero scale's box is a point or a flat disk, which rays met by chance: uscale(0)
    # was never reported, scale(1, 0, 1) once for every ray that crossed its disk
    from pcsg.tracer import loads
    traced = loads(text, "t.pcsg")
    (w,) = faults_of(traced, "singular-map")
    assert (w.location.line, w.location.column) == (1, 1 if text[0] != "{" else 9)
    said = ": it empties its operand" if text[0] != "{" else \
        " in some instances, which are empty (a runtime error in the grammar)"
    assert w.message == "this transformation is singular (a zero scale) or too large to " \
        "invert" + said
    maps = [i for i, n in enumerate(traced.graph.nodes)
            if n.kind == TRANSFORM and n.span == w.span]
    assert maps and all(traced.boxes[i, 0] > traced.boxes[i, 3] for i in maps)


# numpy's LU determinant of the first is -7.1e-15 where the cofactors the tracer computes
# give 0; the second's world matrix has a determinant of 4e-18 by cofactors, the rounding
# of a product whose third map is flat
NEARLY = ["matrix(1,2,3,4, 5,6,7,8, 9,10,11,12) sphere ∪ move(3,0,0) cube",
          "rotz(30) roty(20) scale(0,1,1) rotx(40) rotz(10) sphere ∪ move(3,0,0) cube"]


@pytest.mark.parametrize("text", NEARLY)
def test_what_the_tracer_takes_as_singular_every_derivation_leaves_out(text):
    """check, render, the reference (the oracle), the Python and the compiled derivation
    (the export's) take the same instances as empty: export wrote the first sphere."""
    from pcsg.trace.reference import Reference
    from pcsg.tracer import loads
    traced = loads(text, "t.pcsg")
    assert faults_of(traced, "singular-map")
    assert [x.primitive for x in flatten(traced.graph) if leaf_inverse(x.matrix) is not None] \
        == ["cube"]
    for compiled in (True, False):
        (chunk,) = leaf_chunks(traced.graph, compiled)
        assert np.isnan(chunk.world[0]).all() and np.isfinite(chunk.world[1]).all()
    # a ray through where the sphere would be, and one onto the cube
    origins = np.array([[0.0, 0.0, -5.0], [3.0, 0.0, -5.0]])
    directions = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
    hits = traced.trace(origins, directions)
    reference = Reference(traced.graph).trace(origins, directions)
    assert np.isinf(hits.t[0]) and np.isfinite(hits.t[1])
    assert np.isinf(reference["t"][0]) and reference["t"][1] == pytest.approx(hits.t[1])


def test_the_cofactors_agree_with_numpy_away_from_singular():
    rng = np.random.default_rng(5)
    m = rng.normal(size=(200, 3, 4))
    assert np.allclose(determinants(m), np.linalg.det(m[:, :, :3]), rtol=1e-12, atol=1e-14)
    assert invertible(m).all() and not any(singular(x) or flat(x) for x in m)
    lu_nonzero = np.array([[1.0, 2, 3, 4], [5, 6, 7, 8], [9, 10, 11, 12]])
    assert np.linalg.det(lu_nonzero[:, :3]) != 0 and flat(lu_nonzero)
    assert not invertible(lu_nonzero)
    # extreme but invertible: LU inverts them (1/det of the cofactors is not finite)
    tiny = np.diag([1e-160, 1e-160, 1.0])
    assert invertible(tiny) and not flat(tiny) and np.isfinite(np.linalg.inv(tiny)).all()
    assert singular(np.diag([1.0, 0.0, 1.0])) and flat(np.diag([1.0, 0.0, 1.0]))
    assert not invertible(np.array([[1.0, 2, 3], [4, 5, 6], [7, 8, np.inf]]))


def test_the_instance_walk_counts_singular_maps_as_the_reference_has_them():
    text = DRAWN.replace("move(sqrt(rand() - 0.1), 0, 0)", "scale(1, floor(rand() * 5), 1)")
    graph = compile_text(text, "t.pcsg")
    bad = sum(leaf_inverse(x.matrix) is None for x in flatten(graph))
    assert 0 < bad < 3 ** 5
    from pcsg.tracer import loads
    traced = loads(text, "t.pcsg")
    assert traced.bounds_method == "every instance"
    (w,) = faults_of(traced, "singular-map")
    assert f"too large to invert in {bad:,} instances" in w.message


def test_the_count_comes_back_from_the_bounds_cache(monkeypatch, tmp_path):
    monkeypatch.setenv("PCSG_BOUNDS_CACHE", "1")
    monkeypatch.setenv("PCSG_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(boxcache, "MIN_VISITS", 0)
    graph = compile_text(DRAWN, "t.pcsg")
    walked, read = [], []
    walk_boxes(graph, instances=True, cache=True, faults=walked)
    hits = boxcache.hits
    walk_boxes(graph, instances=True, cache=True, faults=read)
    assert boxcache.hits == hits + 1 and read == walked
    (count, node), (singular, _) = walked[0]
    assert count > 0 and singular == 0
    assert fault_warnings(graph, graph, [(0, count, node)], counted=True)[0].span == \
        graph.nodes[node].span


def test_strict_fails_on_it_and_a_plain_render_says_it(capsys, tmp_path):
    src = tmp_path / "t.pcsg"
    src.write_text("uscale(1e999) sphere ∪ move(3,0,0) cube\n", encoding="utf-8")
    out = tmp_path / "t.png"
    fast = ["--size", "32x24", "-q", "--no-shadows"]
    assert main(["render", str(src), "-o", str(out), "--strict", *fast]) == 1
    assert "not finite: it empties its operand" in capsys.readouterr().err
    assert not out.exists()
    assert main(["render", str(src), "-o", str(out), *fast]) == 0
    assert "t.pcsg:1:1: warning: the arguments of this transformation are not finite" in \
        capsys.readouterr().err
