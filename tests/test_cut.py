"""The derivation cut where the tracer's walk stops (graph/cut.py): at the depth bound an
S-node instance takes its terminating rule, and a graftal's, which has none, is its
bounding volume clipped by the boxes above it. The tracer is checked against the
reference expansion of that cut ray by ray, and `pcsg export --pov --max-depth N` writes
it, so that a graftal can be taken into POV-Ray."""
import re

import numpy as np
import pytest

from pcsg.cli import main
from pcsg.compiler import compile_file, compile_text
from pcsg.graph.cut import cut_of
from pcsg.graph.flatten import instances
from pcsg.graph.stats import count_by_primitive, count_primitives
from pcsg.graph.leaves import leaf_chunks
from pcsg.trace.nodes import EV_DEPTH
from pcsg.trace.reference import CLIP, Reference
from pcsg.tracer import Traced

from .conftest import GRAMMARS
from .oracle import camera_rays

FERN = GRAMMARS / "barnsley_fern.pcsg"
FERN_AXIOM = "paint(0.22, 0.55, 0.18) FERN ∪ paint(0.50, 0.44, 0.34) move(0, 0, -0.2) plane"


def _fern_in_a_ball() -> str:
    """The fern as the operand of an intersection, whose interval walk cuts it too."""
    text = FERN.read_text()
    assert FERN_AXIOM in text
    return text.replace(FERN_AXIOM, "paint(0.22, 0.55, 0.18) (FERN ∩ move(0.3, 0, 3) "
                                    "uscale(3.6) sphere)")


def _fern_with_a_flat_pinna() -> str:
    """One of the fern's maps made singular: the instances below it are empty."""
    text = FERN.read_text()
    flat = text.replace("1: PINNA → stem PINNA", "1: PINNA → scale(0, 1, 1) stem PINNA")
    assert flat != text
    return flat


def _cut_pair(graph, depth):
    traced = Traced(graph, max_depth=depth, average_normals=False)
    assert traced.max_depth == depth
    return traced, Reference(traced.graph, cut=cut_of(traced))


# 40 halvings: the full derivation is a line, but cut at depth 1 two unit cubes, which
# its boxes left out (the memoised bounds ignored the depth bound; rays missed them)
HALVINGS = ("{c = 40} S\nS if(c > 0, 2, 1)\n1: S → cube\n"
            "2: S → {c = c-1} (move(0.5,0,0) uscale(0.5) S ∪ move(-0.5,0,0) uscale(0.5) S)\n")
# and beside a graftal, whose re-entered states the bounds reach a fixed point over
HALVINGS_AND_A_GRAFTAL = ("{c = 40} (S ∪ move(0, 0, 3) F)\n" + HALVINGS.split("\n", 1)[1]
                          + "F 1\n1: F → (uscale(0.5) F ∪ move(1,0,0) uscale(0.5) F ∪ "
                            "move(0,1,0) uscale(0.5) sphere)\n")
# graftals whose instances differ in what their selections read: a rand() or a counter
# picks the rule (bounded with every rule taken, bounds._any_rule)
_MAPS = ("move(0.5,0.5,0.5) uscale(0.5) S ∪ move(-0.5,-0.5,0.5) uscale(0.5) S",
         "move(0.5,-0.5,-0.5) uscale(0.5) S ∪ move(-0.5,0.5,-0.5) uscale(0.5) S")
RANDOM_GRAFTAL = (f"paint(0.7,0.4,0.2) S\nS if(rand() < 0.5, 1, 2)\n1: S → {_MAPS[0]} ∪ "
                  f"uscale(0.3) sphere\n2: S → {_MAPS[1]} ∪ {_MAPS[0].split(' ∪ ')[0]}\n")
PARITY_GRAFTAL = (f"{{k = 0}} S\nS if(k % 2 == 0, 1, 2)\n1: S → {{k = k + 1}} ({_MAPS[0]})\n"
                  f"2: S → {{k = k + 1}} ({_MAPS[1]} ∪ move(0,0,0.5) uscale(0.5) S)\n")
CASES = [("fern", 1), ("fern", 2), ("fern", 3), ("fern in a ball", 3),
         ("fern with a flat pinna", 3), ("cifs_temple", 2), ("sympodial_tree", 4),
         ("sierpinski", 3), ("halvings", 1), ("halvings and a graftal", 1),
         ("random graftal", 4), ("parity graftal", 3)]
TEXTS = {"fern in a ball": _fern_in_a_ball, "fern with a flat pinna": _fern_with_a_flat_pinna,
         "halvings": lambda: HALVINGS, "halvings and a graftal": lambda: HALVINGS_AND_A_GRAFTAL,
         "random graftal": lambda: RANDOM_GRAFTAL, "parity graftal": lambda: PARITY_GRAFTAL}


@pytest.mark.parametrize("name,depth", CASES)
def test_the_tracer_cut_at_its_depth_bound_is_the_reference_cut(name, depth):
    """Ray by ray, with no level of detail: hits, distances and paints, and normals but
    where the reference's hit is on a clipping box (the tracer takes its own volume's
    face there). Both walks of the tracer: packets and single rays."""
    if name in TEXTS:
        graph = compile_text(TEXTS[name]())
    else:
        graph = compile_file(FERN if name == "fern" else GRAMMARS / f"{name}.pcsg", {})
    traced, ref = _cut_pair(graph, depth)
    for direction in [(1, -1.5, 0.5), (-1, 0.3, 0.2)]:
        o, d = camera_rays(traced.bounds, 24, direction, spread=0.3)
        want = ref.trace(o, d, exits=True)
        for packets in (True, False):
            got = traced.trace(o, d, lod=0.0, packets=packets)
            assert np.array_equal(got.hit, want["hit"]) and got.hit.sum() > 50
            both = got.hit
            np.testing.assert_allclose(got.t[both], want["t"][both], rtol=1e-9)
            np.testing.assert_allclose(got.paint[both], want["paint"][both], atol=1e-12)
            own = both & ~np.array([p.endswith(CLIP) for p in want["primitive"]])
            np.testing.assert_allclose(got.normal[own], want["normal"][own], atol=1e-9)
            assert got.events[EV_DEPTH].sum() > 0          # the cut was reached


def test_the_clips_are_what_makes_the_fern_agree():
    """Without its clips (each cut instance its whole box) the reference sees boxes that
    the tracer's windows leave out: the clipping is needed, and the test above sees it."""
    traced, ref = _cut_pair(compile_file(FERN, {}), 3)
    assert sum(leaf.name.endswith(CLIP) for leaf in ref.leaves) > 10
    unclipped = Reference(traced.graph, cut=_without_clips(cut_of(traced)))
    differ = 0
    for direction in [(1, -1.5, 0.5), (-1, 0.3, 0.2)]:
        o, d = camera_rays(traced.bounds, 40, direction)
        got = traced.trace(o, d, lod=0.0)
        t = unclipped.trace(o, d, exits=True)["t"]
        differ += int((~np.isclose(got.t, t, rtol=1e-6, atol=0)).sum())
    assert differ > 0


def _without_clips(cut):
    """The cut with its clipping left out: Cut.clips_of keeps none."""
    class Whole(type(cut)):
        def clips_of(self, leaves, aboves):
            return [() for _ in leaves]
    return Whole(**vars(cut))


@pytest.mark.parametrize("name,depth", CASES + [("graftal_tree", 5), ("table_tower", 3),
                                                ("carpenter_terrain", 3)])
def test_the_cut_is_counted_as_it_derives(name, depth):
    """What the export's progress line counts out of (stats.count_primitives with the
    cut), without deriving, against the derivation, cut volumes and empty leaves too."""
    if name in TEXTS:
        graph = compile_text(TEXTS[name]())
    else:
        path = FERN if name == "fern" else GRAMMARS / f"{name}.pcsg"
        graph = compile_file(path, {"cnt": 4.0} if name == "carpenter_terrain" else {})
    cut = cut_of(Traced(graph, max_depth=depth))
    derived = [inst.primitive for inst in instances(graph, cut)]
    counted = count_by_primitive(graph, cut=cut)
    assert counted == {k: derived.count(k) for k in set(derived)}
    if not cut.graftal:         # and it is not the whole derivation's count
        assert count_primitives(graph, cut=cut) < count_primitives(graph)


@pytest.mark.parametrize("name,depth", [("sympodial_tree", 5), ("sierpinski", 3),
                                        ("graftal_tree", 5), ("table_tower", 3)])
def test_the_compiled_walk_cuts_as_the_python_derivation(name, depth):
    traced = Traced(compile_file(GRAMMARS / f"{name}.pcsg", {}), max_depth=depth)
    cut = cut_of(traced)
    assert not cut.graftal
    fast = list(leaf_chunks(traced.graph, True, cut))
    slow = list(leaf_chunks(traced.graph, False, cut))
    assert fast[0].chain is not None and slow[0].paths is not None   # two derivations
    nodes = np.concatenate([c.node for c in fast])
    np.testing.assert_array_equal(nodes, np.concatenate([c.node for c in slow]))
    np.testing.assert_allclose(np.concatenate([c.world for c in fast]),
                               np.concatenate([c.world for c in slow]), atol=1e-12)
    deeper = cut_of(Traced(compile_file(GRAMMARS / f"{name}.pcsg", {}), max_depth=depth + 1))
    assert len(nodes) < sum(len(c) for c in leaf_chunks(traced.graph, True, deeper))


def test_export_writes_a_graftal_cut_at_max_depth(tmp_path, capsys):
    out = tmp_path / "fern.pov"
    assert main(["export", str(FERN), "--pov", str(out), "--max-depth", "3", "-q"]) == 0
    text = out.read_text()
    traced = Traced(compile_file(FERN, {}), max_depth=3)
    insts = list(leaf_chunks(traced.graph, False, cut_of(traced)))
    clips = [c for chunk in insts for c in chunk.clips]
    assert len(clips) == 4 ** 3 + 1                            # 64 boxes or spheres, a plane
    assert text.count("\nintersection {") == sum(1 for c in clips if c) > 10
    objects = text.count("object { P_")
    assert objects == len(clips) + sum(len(c) for c in clips)
    assert f"{len(clips)} primitives" in capsys.readouterr().out
    assert text.count("P_plane matrix") == 1


def test_export_of_a_graftal_without_max_depth_says_what_to_do(tmp_path, capsys):
    code = main(["export", str(FERN), "--pov", str(tmp_path / "f.pov")])
    err = capsys.readouterr().err
    assert code != 0 and not (tmp_path / "f.pov").exists()
    assert "'FERN' has no rule that ends" in err and "--max-depth N" in err
    assert "barnsley_fern.pcsg:23:1" in err
    assert main(["export", str(FERN), "--pov", str(tmp_path / "f.pov"), "--max-depth", "0"]) != 0
    assert "--max-depth 0: use 1 to 10000" in capsys.readouterr().err


def test_export_leaves_out_what_a_singular_map_empties(tmp_path, capsys):
    source = tmp_path / "flat.pcsg"
    source.write_text(_fern_with_a_flat_pinna())
    out = tmp_path / "flat.pov"
    assert main(["export", str(source), "--pov", str(out), "--max-depth", "3", "-q"]) == 0
    printed = capsys.readouterr()
    left = re.search(r"warning: ([\d,]+) primitives? left out", printed.err).group(1)
    left = int(left.replace(",", ""))
    written = int(re.search(r": (\d+) primitives", printed.out).group(1))
    assert left > 0 and written + left == 4 ** 3 + 1
    assert "nan" not in out.read_text()


def test_a_deep_system_whose_states_recur_at_many_levels_keeps_its_memoised_bounds():
    # bounded again with its levels in the keys, a system deeper than the depth bound
    # whose states recur at many levels ran out of states: the instance walk, its budget
    # spent, refinement capped at depth 25 and a warning
    fib = ("{c = 90} S\nS if(c > 0, 2, 1)\n1: S → cube\n2: S → {c = c-1} (move(0,0.5,0) "
           "uscale(0.7) S ∪ {c = c-1} move(1,0,0) rotz(20) uscale(0.5) S)\n")
    traced = Traced(compile_text(fib), 64)      # without it, its own depth: 91
    assert traced.bounds_method == "memoised" and traced.max_depth == 64
    assert not traced.warnings
