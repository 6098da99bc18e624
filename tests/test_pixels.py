"""`pixels`: the read-only size of the instance on the screen, for selections that switch
to an alternative geometry when an instance is small (Bekaert & Willems; Oppenheimer)."""
import math

import numpy as np
import pytest
from PIL import Image

import pcsg
from pcsg.cli import main
from pcsg.compiler import compile_text
from pcsg.graph.bounds import hyper_boxes
from pcsg.graph.expand import expand_file
from pcsg.graph.stats import count_by_primitive
from pcsg.language.errors import PcsgError

from .conftest import expand_and_recheck
from .oracle import assert_agrees, camera_rays

# red sphere when large, a blue cube when small
SWITCH = """
T if(pixels < 50, 2, 1)
1: T → paint(1, 0, 0) sphere
2: T → paint(0, 0, 1) move(0, 0, 0) cube
{ k = 1 } T
"""


def _paint_at(traced, distance, lod):
    o = np.array([[0.0, -distance, 0.0]])
    d = np.array([[0.0, 1.0, 0.0]])
    hits = traced.trace(o, d, lod=lod)
    assert hits.hit[0]
    return tuple(hits.paint[0])


def test_the_selection_sees_the_size_in_pixels():
    """pixels = the diagonal of the instance's box over the footprint where the ray
    enters it: 2*sqrt(3) / (lod * t_enter) for the unit sphere's box."""
    traced = pcsg.loads(SWITCH)
    lod = 0.01
    diagonal = 2 * math.sqrt(3)
    near = 1 + diagonal / lod / 60          # t_enter = distance - 1 gives 60 pixels
    far = 1 + diagonal / lod / 40           # 40 pixels
    assert _paint_at(traced, near, lod) == (1, 0, 0)
    assert _paint_at(traced, far, lod) == (0, 0, 1)
    # twice as large, at the same distance from the box: 80 pixels
    bigger = pcsg.loads(SWITCH.replace("{ k = 1 } T", "{ k = 1 } uscale(2) T"))
    assert _paint_at(bigger, far + 1, lod) == (1, 0, 0)     # 80 pixels


def test_without_a_camera_pixels_is_infinite():
    """lod 0 (no footprint), stats, the reference: every instance is large."""
    traced = pcsg.loads(SWITCH)
    assert _paint_at(traced, 1e6, 0.0) == (1, 0, 0)
    assert count_by_primitive(traced.graph) == {"sphere": 1}
    o, d = camera_rays(traced.bounds, 16, (1, -2, 1))
    assert_agrees(traced, o, d)


def test_the_bounds_hold_every_rule_the_size_can_pick():
    graph = compile_text("T if(pixels < 8, 2, 1)\n1: T → sphere\n2: T → move(5, 0, 0) sphere\n"
                         "{ k = 1 } T")
    boxes = hyper_boxes(graph)[0]
    root = boxes[graph.modules["T"]]
    assert root[0] <= -1 and root[3] >= 6        # both spheres: [-1, 6] along x
    far = pcsg.Traced(graph).trace(np.array([[5.0, -1e4, 0.0]]), np.array([[0.0, 1.0, 0.0]]),
                                   lod=1e-3)
    assert far.hit[0]                            # a small T is the moved sphere: not culled


def test_a_render_switches_where_the_instances_are_small(tmp_path):
    """Trees along a row: near ones branched, far ones the cheap geometry."""
    src = tmp_path / "row.pcsg"
    src.write_text("""
#camera eye=(3, -6, 2) at=(0, 8, 2) fov=40
{ n = 8 } ROW
ROW if(n > 1, 2, 1)
1: ROW → TREE
2: ROW → { n = n / 2 } (ROW ∪ move(0, 3 * n, 0) ROW)
TREE if(pixels < 60, 2, 1)
1: TREE → paint(1, 0, 0) scale(0.1, 0.1, 4) cylinder
2: TREE → paint(0, 0, 1) scale(0.1, 0.1, 4) cylinder
""")
    out = tmp_path / "row.png"
    depth = tmp_path / "row.npy"
    assert main(["render", str(src), "-o", str(out), "--size", "160x120", "--no-adaptive",
                 "-q", "--depth", str(depth)]) == 0
    from PIL import Image
    rgb = np.asarray(Image.open(out).convert("RGB")).astype(int)
    red = rgb[..., 0] > rgb[..., 2] + 40
    blue = rgb[..., 2] > rgb[..., 0] + 40
    assert red.sum() > 20 and blue.sum() > 5
    z = np.load(depth)
    assert np.nanmax(z[red]) < np.nanmin(z[blue])       # every red one is nearer


@pytest.mark.parametrize("text, message", [
    ("T if(pixels < 4, 1, 1)\n1: T → uscale(pixels) sphere\n{ k = 1 } T",
     "'pixels' (the instance's size in pixels) can only be read in a module's selection"),
    ("T 1\n1: T → { a = pixels } uscale(a) sphere\n{ k = 1 } T",
     "can only be read in a module's selection"),
])
def test_errors(text, message):
    with pytest.raises(PcsgError) as e:
        compile_text(text, "p.pcsg")
    assert message in str(e.value) and "p.pcsg:" in str(e.value)


def test_an_endless_cycle_that_the_size_ends_is_not_a_warning(capsys):
    graph = compile_text("T if(pixels < 2, 1, 2)\n1: T → sphere\n"
                         "2: T → uscale(0.5) T ∪ move(1, 0, 0) uscale(0.5) T\n{ k = 1 } T")
    assert not [w for w in graph.warnings if w.code == "endless"]


def test_expand_leaves_pixels_out(tmp_path, capsys):
    assert "pixels =" not in expand_and_recheck(tmp_path, capsys, SWITCH, 0)


def test_a_file_that_assigns_pixels_has_a_parameter_of_that_name():
    """Notation §2 does not reserve `pixels`: a file that assigns it has a parameter like any
    other, which the tracer leaves alone (a module and a named expression may take the name
    too)."""
    text = ("{pixels = 2} S\nS if(pixels > 0, 2, 1)\n1: S → sphere\n"
            "2: S → {pixels = pixels - 1} (cube ∪ move(2.5, 0, 0) S)\n")
    graph = compile_text(text, "p.pcsg")
    assert graph.pixels == -1 and graph.param_names == ["pixels"]
    assert expand_file(graph, 3).splitlines()[1] == \
        "{pixels = 2} (cube ∪ move(2.5, 0, 0) (cube ∪ move(2.5, 0, 0) sphere))"
    traced = pcsg.loads(text)
    assert traced.bounds[3] == pytest.approx(6)     # the cubes at 0 and 2.5, the sphere at 5
    o, d = camera_rays(traced.bounds, 16, (1, -2, 1))
    assert_agrees(traced, o, d, min_hits=20)
    assert compile_text("pixels = sphere\npixels ∪ cube", "n.pcsg").pixels == -1
    assert compile_text("1: pixels → sphere\npixels", "m.pcsg").pixels == -1


def test_a_pixels_system_that_only_an_instance_walk_bounds_says_it_is_unbounded():
    """rand() in its maps: the memoised walk has too many states, the instance walk knows
    no pixel sizes, so nothing is bounded; the render was 100 times slower than without
    `pixels`, and said nothing (QA)."""
    text = ("{c = 6} S\nS if(c <= 0 || pixels < 4, 1, 2)\n1: S → uscale(0.5) sphere\n"
            "2: S → cylinder ∪ {c = c-1} (move(0,0,1) rotz(360*rand()) uscale(0.6) S ∪ "
            "move(0,0,0.7) rotz(360*rand()) uscale(0.5) S ∪ "
            "move(0,0,0.5) rotz(360*rand()) uscale(0.5) S)\n")
    obj = pcsg.loads(text)
    assert obj.bounds_method == "unbounded"
    (w,) = obj.warnings
    assert w.code == "unbounded" and w.message.startswith("selections read `pixels`, and this "
                                                          "system's instances differ")
    # without `pixels`, the same system is walked and bounded
    plain = pcsg.loads(text.replace(" || pixels < 4", ""))
    assert plain.bounds_method == "every instance" and not plain.warnings


# the camera sees a red ball (rule 1) where `pixels` is below T: its shadow and its mirror
# image must be the ball's too, not the cross of rule 2
SEEN_SMALL = """#camera eye=(0, -30, 12) at=(0, 0, 0.5) fov=30
#light at=(0, 0, 40)
#material mirror reflect=0.9
A ∪ {FLOOR}
A if(pixels < 200, 1, 2)
1: A → paint(1,0,0) move(0,0,2) sphere
2: A → paint(0,0,1) move(0,0,2) (scale(1,0.1,0.1) cube ∪ scale(0.1,1,0.1) cube)
"""


@pytest.mark.parametrize("floor, options", [
    ("paint(0.8,0.8,0.8) plane", ["--shadow-samples", "1"]),
    ("material(mirror) plane", ["--no-shadows"]),
])
def test_shadows_and_mirror_images_choose_the_rule_the_camera_sees(tmp_path, floor, options):
    """A shadow or reflected ray's footprint is the beam's from the eye (Bekaert &
    Willems §3.1): it starts as wide as the pixel it leaves. Without that width a shadow
    ray leaving the ground beside the ball saw it hundreds of pixels large, and the ball
    cast the shadow of the cross (QA), its mirror image too."""
    pictures = []
    for text in (SEEN_SMALL, SEEN_SMALL.replace("if(pixels < 200, 1, 2)", "1")):
        src = tmp_path / "s.pcsg"
        src.write_text(text.replace("{FLOOR}", floor), encoding="utf-8")
        out = tmp_path / f"s{len(pictures)}.png"
        assert main(["render", str(src), "--size", "160x120", "-q", "-o", str(out),
                     "--no-adaptive", *options]) == 0
        pictures.append(np.asarray(Image.open(out).convert("RGB"), int))
    switching, ball = pictures
    assert (np.abs(ball - ball[0, 0]).max(axis=2) > 30).sum() > 200     # ball, and more
    assert np.array_equal(switching, ball)
