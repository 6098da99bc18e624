"""`pcsg export --pov`: the expanded derivation as a POV-Ray scene. The structure is
checked against the derivation itself; where POV-Ray is installed, its picture of the
exported scene is compared with pcsg's own render of the same file."""
import argparse
import math
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from pcsg.cli import _export_progress, _export_total, main
from pcsg.compiler import compile_file, compile_text
from pcsg.graph import leaves as leaves_module
from pcsg.graph.cut import cut_of
from pcsg.graph.flatten import flatten
from pcsg.povray import export_pov
from pcsg.render.camera import make_camera
from pcsg.render.shade import make_lighting
from pcsg.tracer import Traced

from .terminal import on_a_terminal

ROOT = Path(__file__).resolve().parent.parent
SIERPINSKI = ROOT / "grammars" / "sierpinski.pcsg"
TERRAIN = ROOT / "grammars" / "carpenter_terrain.pcsg"
CSG = Path(__file__).resolve().parent / "data" / "csg_export.pcsg"
EMPTY = Path(__file__).resolve().parent / "data" / "empty_export.pcsg"
THIN = Path(__file__).resolve().parent / "data" / "thin_export.pcsg"
FLAT = Path(__file__).resolve().parent / "data" / "flat_export.pcsg"
NESTED = Path(__file__).resolve().parent / "data" / "nested_empty_export.pcsg"
MIRROR = Path(__file__).resolve().parent / "data" / "mirror_export.pcsg"
FLUSH = Path(__file__).resolve().parent / "data" / "flush_export.pcsg"
FERN = ROOT / "grammars" / "barnsley_fern.pcsg"      # a graftal: cut at --max-depth
GLASS = ROOT / "grammars" / "glass_and_mirror.pcsg"
TINY = Path(__file__).resolve().parent / "data" / "tiny_export.pcsg"


def export(tmp_path, grammar, *options):
    out = tmp_path / (grammar.stem + ".pov")
    assert main(["export", str(grammar), "--pov", str(out), "--size", "160x120", *options]) == 0
    return out


def matrices(text):
    return [np.array([float(x) for x in m.split(",")]).reshape(4, 3).T
            for m in re.findall(r"object \{ P_\w+ (?:(?:translate|scale) \S+ )*matrix <([^>]*)>",
                                text)]


def test_every_primitive_is_an_object_with_its_world_matrix(tmp_path):
    text = export(tmp_path, SIERPINSKI, "--set", "c=2").read_text()
    insts = flatten(compile_file(SIERPINSKI, {"c": 2.0}))
    got = matrices(text)
    assert len(got) == len(insts) == 17
    for m, inst in zip(got, insts):
        np.testing.assert_allclose(m, inst.matrix[:3, :], rtol=1e-8, atol=1e-12)
    assert text.count("object { P_tetrahedron") == 16 and text.count("object { P_plane") == 1
    assert "union {" not in text          # top-level unions are left to POV-Ray's bounding


def test_csg_blocks_follow_the_operators(tmp_path):
    text = export(tmp_path, CSG).read_text()
    body = text[text.index("\nintersection {"):]
    assert body.count("{") == body.count("}")
    assert text.count("difference {") == 4       # one per leaf cube-and-sphere
    assert "union {" in text                     # the union inside the outer ∩
    assert len(matrices(text)) == len(flatten(compile_file(CSG)))


def test_terrain_is_one_mesh_with_shared_vertices(tmp_path):
    text = export(tmp_path, TERRAIN, "--set", "cnt=2").read_text()
    faces = int(re.search(r"face_indices \{ (\d+),", text).group(1))
    verts = int(re.search(r"vertex_vectors \{ (\d+),", text).group(1))
    assert faces == 2 * 4 ** 2                   # tri1 and tri2 patches of order 2
    assert verts == 5 * 5                        # the 5x5 grid: every edge shared
    assert text.count("object { P_plane") == 1   # the sea


def test_empty_primitives_are_left_out_with_a_warning(tmp_path, capsys):
    """A NaN or singular world matrix draws nothing in pcsg; POV-Ray could not parse the
    NaNs, and would draw the flattened sphere."""
    text = export(tmp_path, EMPTY).read_text()
    assert not re.search(r"\b(nan|inf)\b", text, re.IGNORECASE)
    # the sphere and the plane; the intersection lost an operand, so it is gone
    assert matrices(text) and len(matrices(text)) == 2
    assert "intersection {\n" not in text and "object { P_cube" not in text
    out, err = capsys.readouterr()
    assert "3 primitives left out" in err and "singular or not finite" in err
    # the count is what the file holds: not the cube that went with its intersection
    assert ": 2 primitives," in out and "1 more went with the ∩" in err


def test_a_matrix_the_tracer_takes_as_singular_is_left_out_too(tmp_path, capsys):
    """numpy's LU determinant of this matrix is -7.1e-15; the tracer's (cofactors) is 0,
    so check warns, render draws nothing, and export wrote the sphere."""
    f = tmp_path / "sing.pcsg"
    f.write_text("matrix(1,2,3,4, 5,6,7,8, 9,10,11,12) sphere ∪ move(3,0,0) cube\n",
                 encoding="utf-8")
    text = export(tmp_path, f).read_text()
    assert "object { P_sphere" not in text and "object { P_cube" in text
    assert "1 primitive left out" in capsys.readouterr().err


def test_an_operand_whose_block_came_out_empty_is_empty(tmp_path, capsys):
    """An ∩ inside an ∩ (or first under a \\) that loses an operand empties the operand
    it is: the outer block went to POV-Ray with one object left (a whole cube where pcsg
    draws nothing, the sphere to subtract drawn instead)."""
    text = export(tmp_path, NESTED).read_text()
    assert [m[:, 3].tolist() for m in matrices(text)] == [[3, 3, 0], [0, 0, -1]]
    assert "\nintersection {" not in text and "\ndifference {" not in text
    assert "object { P_cube" in text and "object { P_sphere" not in text
    assert "; 8 more went with the ∩ or \\ that lost an operand" in capsys.readouterr().err


def test_the_count_is_what_the_file_holds(tmp_path, capsys):
    text = export(tmp_path, CSG).read_text()
    assert f": {len(matrices(text))} primitives," in capsys.readouterr().out
    export(tmp_path, TERRAIN, "--set", "cnt=2")
    assert ": 33 primitives," in capsys.readouterr().out   # 32 mesh faces and the sea


def both_ways(tmp_path, graph):
    """[counts, scene bytes] exported from the compiled walk, then the same from the
    Python derivation."""
    traced = Traced(graph)
    camera = make_camera(traced, 4 / 3)
    lighting = make_lighting(traced, camera, True, 1, 3)
    written = []
    for compiled in (True, False):
        out = tmp_path / f"{compiled}.pov"
        written.append(export_pov(traced, camera, lighting, out, (160, 120), None, compiled))
        written.append(out.read_bytes())
    return written


@pytest.mark.parametrize("grammar, overrides", [
    (SIERPINSKI, {"c": 3}), (TERRAIN, {"cnt": 3}), (ROOT / "grammars" / "table_tower.pcsg", {}),
    (ROOT / "grammars" / "sympodial_tree.pcsg", {"cnt": 4}), (CSG, {}), (EMPTY, {}),
    (Path(__file__).resolve().parent / "data" / "deep_csg_export.pcsg", {})])
def test_the_compiled_derivation_writes_the_python_derivations_scene(tmp_path, grammar,
                                                                     overrides):
    """The export derives with the compiled walk (graph/leaves.py): the scene is the one
    the Python derivation (the reference's) writes, byte for byte, ∩ and \\ blocks, empty
    primitives and the blocks they empty included."""
    written = both_ways(tmp_path, compile_file(grammar, overrides))
    assert written[0] == written[2] and written[0][0] > 0
    assert written[1] == written[3]


def test_a_block_goes_on_across_chunks_of_empty_primitives(tmp_path, monkeypatch):
    """Chunks of two primitives, the middle one all empty (scale 0) inside an ∩: the ∩ is
    one block with both operands, as the Python derivation writes it, not closed where a
    chunk brought no object to write."""
    monkeypatch.setattr(leaves_module, "CHUNK", 2)
    graph = compile_text("(sphere ∪ uscale(0) sphere ∪ uscale(0) sphere ∪ uscale(0) sphere) ∩ "
                         "move(0.5, 0, 0) sphere\n")
    written = both_ways(tmp_path, graph)
    assert written[0] == written[2] == (2, 3, 0)
    assert written[1] == written[3] and written[1].count(b"\nintersection {\n") == 1


def test_export_errors_are_clean(tmp_path, capsys):
    assert main(["export", str(SIERPINSKI), "--pov", str(tmp_path / "no" / "x.pov")]) == 2
    assert "does not exist" in capsys.readouterr().err
    # the view's options are render's, and checked as render checks them
    pov = str(tmp_path / "x.pov")
    assert main(["export", str(SIERPINSKI), "--pov", pov, "--eye", "1,2,3", "--at", "1,2,3"]) == 2
    assert "--eye and --at are the same point 1,2,3" in capsys.readouterr().err
    assert main(["export", str(SIERPINSKI), "--pov", pov, "--fov", "180"]) == 2
    assert "--fov 180: the vertical field of view" in capsys.readouterr().err
    assert not (tmp_path / "x.pov").exists()


def test_a_scene_to_standard_output_and_an_unwritable_place(tmp_path, capsys):
    """--pov - wrote a file named "-" and said `povray +I-`, which POV-Ray 3.7 does not
    read; /proc/x.pov was refused for "its disk has 0.0 MB free"."""
    r = subprocess.run([sys.executable, "-m", "pcsg", "export", str(SIERPINSKI), "--set", "c=1",
                        "--pov", "-"], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("// sierpinski.pcsg: exported by pcsg") and \
        r.stdout.rstrip().endswith("}") and not (tmp_path / "-").exists()
    assert "render with: povray +I/dev/stdin +W640 +H480" in r.stderr
    # found before the export, as a usage error (it was exit 1 after the scene was made)
    assert main(["export", str(SIERPINSKI), "--set", "c=1", "--pov", "/proc/x.pov"]) == 2
    err = capsys.readouterr().err
    assert "--pov /proc/x.pov: cannot write in /proc: No such file or directory" in err and \
        "free" not in err


def test_a_directory_is_no_scene_file(tmp_path, capsys):
    assert main(["export", str(SIERPINSKI), "--pov", str(tmp_path)]) == 2
    assert "that is a directory; name a file in it" in capsys.readouterr().err


def test_a_scene_past_what_povray_holds_is_refused_at_once(tmp_path, capsys):
    # Sierpinski at 14: 268 million primitives, 15 GB of a hidden temporary file in ten
    # minutes, and no word
    out = tmp_path / "s.pov"
    assert main(["export", str(SIERPINSKI), "--set", "c=14", "--pov", str(out)]) == 2
    err = capsys.readouterr().err
    assert "the derivation has 268,435,457 primitives" in err and "--force" in err
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_a_scene_past_what_a_float_holds_is_refused_before_its_bounds(tmp_path, capsys,
                                                                     monkeypatch):
    """Sierpinski at 510: 1.1e307 primitives, an int no float holds; its size was an
    internal error (OverflowError). And the count comes before the bounding walk (a
    system of 27e9 primitives walked its bounds for 96 s before it was refused)."""
    walked = []
    monkeypatch.setattr("pcsg.tracer.Traced.__init__", lambda *a, **k: walked.append(a))
    out = tmp_path / "s.pov"
    assert main(["export", str(SIERPINSKI), "--set", "c=510", "--pov", str(out)]) == 2
    err = capsys.readouterr().err
    assert "the derivation has 1.12e307 primitives, a scene of 1.68e300 GB or so that " \
           "POV-Ray needs about 1.12e301 GB of memory to parse" in err
    # --force was offered, and then refused for the disk ("the about 1.12e307 primitives")
    assert "free, too little even with --force" in err and "about about" not in err
    assert not walked and not out.exists()


def test_an_object_too_large_to_frame_is_said_as_render_says_it(tmp_path, capsys):
    """export's camera error was an internal error (exit 3); render's is exit 1."""
    src = tmp_path / "shear.pcsg"
    src.write_text("xshear(1e300, 0) sphere\n", encoding="utf-8")
    assert main(["export", str(src), "--pov", str(tmp_path / "s.pov")]) == 1
    err = capsys.readouterr().err
    assert f"pcsg export: {src}: the object's box" in err and "too large to frame" in err
    assert not (tmp_path / "s.pov").exists()


def test_a_scene_the_disk_cannot_hold_is_refused_even_with_force(tmp_path, capsys,
                                                                 monkeypatch):
    import shutil
    monkeypatch.setattr(shutil, "disk_usage", lambda p: shutil._ntuple_diskusage(1e9, 1e9, 1e5))
    out = tmp_path / "s.pov"
    assert main(["export", str(SIERPINSKI), "--set", "c=6", "--pov", str(out), "--force"]) == 2
    assert "the 4,097 primitives take at least 0.4 MB, and its disk has 0.1 MB free" in \
        capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize("limit, free, said", [
    (10, 10 ** 12, "the derivation has passed 10 primitives"),
    (10 ** 9, 10 ** 6, "its disk has 1.0 MB free; stopped after 4,097 primitives"),
])
def test_an_export_that_could_not_be_counted_stops_as_it_goes(tmp_path, capsys, monkeypatch,
                                                              limit, free, said):
    # counted 0 (past 20 000 states), the refusals before it did not apply: a scene of any
    # size went on to a full disk
    import shutil
    import pcsg.cli as cli
    monkeypatch.setattr(cli, "_export_total", lambda graph, cut: 0)
    monkeypatch.setattr(cli, "EXPORT_LIMIT", limit)
    monkeypatch.setattr(shutil, "disk_usage", lambda p: shutil._ntuple_diskusage(1e12, 0, free))
    out = tmp_path / "s.pov"
    assert main(["export", str(SIERPINSKI), "--set", "c=6", "--pov", str(out)]) == 2
    assert said in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []           # nor its temporary file
    # counted, the same export is measured against its disk once, before it starts: 4,097
    # primitives fit in 1 MB at 100 bytes each, whatever the floor for uncounted ones
    monkeypatch.undo()
    monkeypatch.setattr(cli, "EXPORT_LIMIT", max(limit, 5000))
    monkeypatch.setattr(shutil, "disk_usage", lambda p: shutil._ntuple_diskusage(1e12, 0, free))
    assert main(["export", str(SIERPINSKI), "--set", "c=6", "--pov", str(out)]) == 0
    assert out.exists()


def test_a_long_export_shows_its_progress_on_a_terminal(tmp_path):
    """The terrain at 10 (2 097 153 primitives) takes seconds: the line counts them out
    of the total stats counts, and the command is stopped once it shows."""
    args = ["export", str(TERRAIN), "--set", "cnt=10", "--pov", str(tmp_path / "t.pov")]
    shown = on_a_terminal(args, dict(os.environ), b"primitives/s", timeout=60.0)
    assert re.search(rb"carpenter_terrain\.pcsg export: +\d+%  +[\d.]+ s, ETA +[\d.]+ s, +"
                     rb"[\d.]+ [kM] primitives/s", shown), shown


def test_export_progress_is_out_of_the_counted_primitives_and_off_with_quiet(monkeypatch):
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)    # as on a terminal
    graph = compile_file(TERRAIN, {"cnt": 3.0})
    args = argparse.Namespace(file=str(TERRAIN), quiet=False)
    shown = _export_progress(args, _export_total(graph, None))
    assert shown.enabled and shown.total == 129         # 128 triangles and the sea
    # cut at a depth: the derivation as the cut ends it (MNT, then T1 and T2 divided
    # once: 8 triangles and the sea)
    cut = _export_progress(args, _export_total(graph, cut_of(Traced(graph, max_depth=2))))
    assert cut.enabled and cut.total == 9
    args.quiet = True
    assert not _export_progress(args, _export_total(graph, None)).enabled


def test_a_scene_framed_from_near_is_written_scaled_up_by_a_power_of_two(tmp_path):
    # its objects, camera and lights alike; any other scene as it is
    text = export(tmp_path, TINY).read_text()
    ((eye,),) = [re.findall(r"location <([^>]*)>", line) for line in text.splitlines()
                 if line.startswith("camera")]
    assert 0.5 < np.linalg.norm(np.array(eye.split(", "), float)) < 4
    sphere = matrices(text)[0]          # uscale(1e-6) sphere, times k
    k = sphere[0, 0] / 1e-6
    assert k > 1e5 and math.log2(k) == pytest.approx(round(math.log2(k)), abs=1e-9)
    assert np.allclose(sphere, np.diag([k * 1e-6] * 3 + [0])[:3], rtol=1e-8, atol=0)
    plain = export(tmp_path, SIERPINSKI, "--set", "c=1").read_text()
    assert "location <" in plain and all(abs(m[0][0]) <= 1 for m in matrices(plain))


POVRAY = shutil.which("povray")


def both_pictures(tmp_path, grammar, *options):
    """POV-Ray's picture of the exported scene and pcsg's of `grammar`, 160x120 with
    point lights, and how far apart each pixel is (the largest channel's difference)."""
    pov = export(tmp_path, grammar, "--shadow-samples", "1", *options)
    subprocess.run([POVRAY, f"+I{pov}", f"+O{tmp_path / 'pov.png'}", "+W160", "+H120", "-D",
                    "-A", "+WT2", "-GA"], check=True, capture_output=True, timeout=300)
    assert main(["render", str(grammar), "-o", str(tmp_path / "pcsg.png"), "--size", "160x120",
                 "--shadow-samples", "1", "--no-adaptive", "-q", *options]) == 0
    a = np.asarray(Image.open(tmp_path / "pov.png").convert("RGB"), float)
    b = np.asarray(Image.open(tmp_path / "pcsg.png").convert("RGB"), float)
    return a, b, np.abs(a - b).max(axis=2)


@pytest.mark.skipif(POVRAY is None, reason="POV-Ray is not installed (apt-get install povray)")
@pytest.mark.parametrize("grammar,options", [(SIERPINSKI, ["--set", "c=2"]), (CSG, []),
                                             # the view and the light of the command line
                                             (SIERPINSKI, ["--set", "c=2", "--eye", "3,-2,4",
                                                           "--at", "0,0,0.2", "--up", "0,1,1",
                                                           "--fov", "45", "--light",
                                                           "-4,-6,8"]),
                                             (EMPTY, []), (THIN, []), (FLAT, []),
                                             (NESTED, []),
                                             (MIRROR, []),
                                             (FERN, ["--max-depth", "4"]),
                                             # no bounce: the surfaces' whole own colours
                                             # (POV-Ray's were dark where they reflect:
                                             # mean 12.1, 11 % of the pixels off by > 48)
                                             (GLASS, ["--set", "k=1", "--bounces", "0"]),
                                             (TINY, [])])
def test_povray_draws_the_same_picture(tmp_path, grammar, options):
    a, b, d = both_pictures(tmp_path, grammar, *options)
    # same geometry, camera and colours: shading models differ a little, edges alias
    assert d.mean() < 12 and (d > 48).mean() < 0.04, (d.mean(), (d > 48).mean())
    # and a mirrored or shifted picture would not pass
    assert np.abs(a[:, ::-1] - b).max(axis=2).mean() > d.mean() + 3


@pytest.mark.skipif(POVRAY is None, reason="POV-Ray is not installed (apt-get install povray)")
def test_cutters_flush_with_the_solid_cut_it_in_povray_too(tmp_path):
    """Holes through, a hole with a post, `cube \\ cube`: POV-Ray kept a face where a
    cutter's lay exactly on it (capped holes, the whole cube drawn: mean 9.1, 3.7 % of
    the pixels off by more than 48, inside the loose bounds above); the export grows
    each cutter by 1e-4 of its size."""
    _, _, d = both_pictures(tmp_path, FLUSH)
    assert "object { P_cube scale 1.0001 matrix" in (tmp_path / "flush_export.pov").read_text()
    assert d.mean() < 3 and (d > 48).mean() < 0.005, (d.mean(), (d > 48).mean())


@pytest.mark.skipif(POVRAY is None, reason="POV-Ray is not installed (apt-get install povray)")
def test_a_face_that_operands_of_an_intersection_share_has_the_first_ones_colour(tmp_path):
    """pcsg shows the first operand's paint where operands of a ∩ share a face, POV-Ray
    the last one's: the top of this slab was red there and green here (mean 17.1, 8.3 %
    of the pixels off by more than 48; 3.0 and 1.6 % with the export's ∩ operands written
    last first)."""
    src = tmp_path / "shared.pcsg"
    src.write_text("#camera eye=(3, -4, 5) at=(0, 0, 0) fov=40\n"
                   "paint(0, 1, 0) cube ∩ paint(1, 0, 0) scale(2, 2, 1) cube\n", encoding="utf-8")
    _, _, d = both_pictures(tmp_path, src)
    assert d.mean() < 8 and (d > 48).mean() < 0.04, (d.mean(), (d > 48).mean())


def test_glass_reflects_by_fresnel_in_povray_too(tmp_path):
    # pcsg reflects reflect + transmit F (shade.fresnel_split); the export wrote a
    # constant `reflection 0`, and POV-Ray's glass showed no reflections at its rims
    src = tmp_path / "glass.pcsg"
    src.write_text("#material glass reflect=0.1 ior=1.5 transmit=0.8\n"
                   "#material chrome reflect=0.7\n"
                   "material(glass) sphere ∪ material(chrome) move(3,0,0) sphere\n")
    text = export(tmp_path, src).read_text()
    assert "reflection { 0.1, 0.9 fresnel on } conserve_energy" in text
    assert "interior { ior 1.5 }" in text and "reflection 0.7 }" in text


def test_a_mirror_keeps_what_it_does_not_reflect_of_its_own_colour(tmp_path):
    # POV-Ray adds reflection to the whole finish: a red mirror (reflect=1) was drawn pink,
    # where pcsg's surface keeps 1 - reflect - transmit of its own colour (0 here)
    text = export(tmp_path, MIRROR).read_text()
    finishes = re.findall(r"finish \{ ambient rgb <([^>]*)> diffuse (\S+) phong (\S+) ", text)
    mirror, half, glass, ground = [(np.array([float(x) for x in a.split(",")]), float(d),
                                    float(p)) for a, d, p in finishes]
    assert mirror[0].max() == mirror[1] == mirror[2] == 0
    np.testing.assert_allclose([half[1], half[2]], [0.35, 0.15])
    np.testing.assert_allclose(half[0], ground[0] / 2)
    # 1 - 0.3 - 0.5 of its own, of which POV-Ray's transmit 0.5 takes half itself
    np.testing.assert_allclose(glass[1], 0.7 * 0.2 / 0.5)
    # but not of its highlight, which POV-Ray does not dim by transmit (it was 0.3 * 0.4)
    np.testing.assert_allclose(glass[2], 0.3 * 0.2)


@pytest.mark.parametrize("samples, grid", [(4, 2), (8, 3), (16, 4), (64, 8)])
def test_an_area_light_has_about_as_many_rays_as_shadow_samples(tmp_path, samples, grid):
    # it was a 3 x 3 grid whatever --shadow-samples said
    src = tmp_path / "l.pcsg"
    src.write_text("#light at=(3, -2, 8) radius=0.5\nsphere\n", encoding="utf-8")
    text = export(tmp_path, src, "--shadow-samples", str(samples)).read_text()
    assert f", {grid}, {grid} circular orient" in text


def test_a_paint_not_finite_is_named_and_a_line_break_in_the_name_stays_in_the_comment(
        tmp_path, capsys):
    """A paint of nan empties its instance (the tracer's rule): the warning named only
    transforms. A file whose name holds a line break ended the header's comment there, and
    POV-Ray failed on the rest of the name."""
    source = tmp_path / "two\nlines.pcsg"
    source.write_text("paint(0, 0, sqrt(-1)) sphere ∪ move(3, 0, 0) cube\n", encoding="utf-8")
    pov = tmp_path / "plain.pov"         # POV-Ray takes no line break on its command line
    assert main(["export", str(source), "--pov", str(pov), "--size", "160x120"]) == 0
    text = pov.read_text()
    assert text.splitlines()[0] == r"// two\nlines.pcsg: exported by pcsg (pcsg export --pov)"
    assert len(matrices(text)) == 1
    err = capsys.readouterr().err
    assert "1 primitive left out" in err and "or their paint not finite" in err
    if POVRAY is not None:
        r = subprocess.run([POVRAY, f"+I{pov}",
                            f"+O{tmp_path / 'pov.png'}", "+W32", "+H24", "-D", "-GA"],
                           capture_output=True, timeout=300)
        assert r.returncode == 0, r.stderr[-400:]


@pytest.mark.skipif(POVRAY is None, reason="POV-Ray is not installed (apt-get install povray)")
def test_the_command_it_says_renders_a_scene_whose_name_has_spaces(tmp_path, capsys):
    """`render with: povray +Idir with space/out file.pov` did not run, and POV-Ray splits
    +I at a space even where the shell kept it whole: it takes its own quotes."""
    where = tmp_path / "dir with space"
    where.mkdir()
    assert main(["export", str(SIERPINSKI), "--set", "c=1", "--size", "32x24", "--pov",
                 str(where / "out file.pov")]) == 0
    said = capsys.readouterr().out.split("render with: ")[1].strip()
    assert said == f"povray '+I\"{where}/out file.pov\"' +W32 +H24"
    r = subprocess.run(f"{said} -D -GA +O{tmp_path}/pov.png", shell=True, cwd=tmp_path,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert Image.open(tmp_path / "pov.png").size == (32, 24)
