"""Rendered images have the properties a person would check by eye."""
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from PIL import Image

from pcsg.cli import main
from pcsg.render.camera import finite_bounds, make_camera
from pcsg.render.image import render_frame
from pcsg.render.shade import make_lighting
from pcsg.tracer import loads

from .conftest import GRAMMARS, ROOT, sigint_reaches_children

BALL = """#camera eye=(0,-6,3) at=(0,0,0.6) fov=40
#light at=(3,-2,8)
paint(0.9,0.3,0.2) move(0,0,1) sphere ∪ paint(0.8,0.8,0.8) plane"""


def frame_of(text, size=(96, 72), **kw):
    obj = loads(text)
    cam = make_camera(obj, size[0] / size[1])
    return obj, cam, render_frame(obj, cam, make_lighting(obj, cam), *size, **kw)


def luminance(rgb):
    return rgb @ np.array([0.2126, 0.7152, 0.0722])


def test_lit_sphere_is_brightest_where_it_faces_the_light():
    obj, cam, fr = frame_of("#camera eye=(0,-5,0) at=(0,0,0) fov=30\n#light at=(4,-3,5)\n"
                            "paint(0.7,0.7,0.7) material(matte) sphere\n"
                            "#material matte specular=0", adaptive=False)
    lum = np.where(fr.coverage > 0, luminance(fr.rgb), -1)
    y, x = np.unravel_index(np.argmax(lum), lum.shape)
    # the brightest pixel's ray hits the sphere where the normal points at the light
    o, d = cam.rays(96, 72, np.array([x + 0.5]), np.array([y + 0.5]))
    h = obj.trace(o, d)
    to_light = np.array([4.0, -3, 5]) - (o[0] + h.t[0] * d[0])
    cos = h.normal[0] @ to_light / np.linalg.norm(to_light)
    assert cos > 0.97


def test_shadowed_ground_is_darker_than_without_the_occluder():
    _, _, with_ball = frame_of(BALL, adaptive=False)
    _, _, without = frame_of(BALL.replace("paint(0.9,0.3,0.2) move(0,0,1) sphere ∪ ", ""),
                             adaptive=False)
    # pixels that show the ground in both pictures (the same depth): some are much darker
    # with the ball (its shadow), none brighter
    ground = np.isfinite(without.depth) & (with_ball.depth == without.depth)
    darker = luminance(without.rgb) - luminance(with_ball.rgb)
    assert darker[ground].max() > 0.2
    assert (darker[ground] > -1e-9).all()


def test_terrain_from_above_has_no_sky_inside_its_square(tmp_path):
    out = tmp_path / "top.png"
    depth = tmp_path / "top.npy"
    code = main(["render", str(GRAMMARS / "carpenter_terrain.pcsg"), "--set", "cnt=4",
                 "--eye", "0.5,0.5,6", "--at", "0.5,0.5,0", "--up", "0,1,0", "--fov", "12",
                 "--size", "64x64", "-o", str(out), "--depth", str(depth), "--no-shadows",
                 "--bounces", "0", "-q"])
    assert code == 0
    d = np.load(depth)
    # the unit square spans the middle of the view: every pixel there hits the terrain or sea
    assert np.isfinite(d[16:48, 16:48]).all()


def test_alpha_and_depth_agree_with_the_hit_mask(tmp_path):
    src = tmp_path / "b.pcsg"
    src.write_text("#camera eye=(0,-6,2) at=(0,0,0) fov=30\nsphere\n", encoding="utf-8")
    png, npy = tmp_path / "b.png", tmp_path / "b.npy"
    assert main(["render", str(src), "-o", str(png), "--alpha", "--depth", str(npy),
                 "--size", "80x60", "-q"]) == 0
    img = np.asarray(Image.open(png))
    d = np.load(npy)
    assert img.shape == (60, 80, 4) and d.dtype == np.float32 and d.shape == (60, 80)
    hit = np.isfinite(d)
    assert 0.1 < hit.mean() < 0.9
    assert (img[..., 3][hit] > 0).all()            # the pixel centre hit: never transparent
    assert (img[..., 3][~hit & (img[..., 3] > 0)] < 255).all()   # edges only partly
    assert (img[..., 3] == 0).sum() > 0
    # each depth is the analytic distance along that pixel's centre ray to the unit sphere
    obj = loads(src.read_text(encoding="utf-8"))
    cam = make_camera(obj, 80 / 60)
    ys, xs = np.mgrid[0:60, 0:80]
    o, dirs = cam.rays(80, 60, xs.ravel() + 0.5, ys.ravel() + 0.5)
    b = np.einsum("ij,ij->i", o, dirs)
    disc = b * b - (np.einsum("ij,ij->i", o, o) - 1)
    analytic = np.where(disc >= 0, -b - np.sqrt(np.maximum(disc, 0)), np.inf).reshape(60, 80)
    assert np.array_equal(np.isfinite(analytic), hit)
    assert np.allclose(d[hit], analytic[hit], rtol=1e-6)


def test_same_png_bytes_every_time(tmp_path):
    a, b = tmp_path / "a.png", tmp_path / "b.png"
    args = [str(GRAMMARS / "sierpinski.pcsg"), "--set", "c=3", "--size", "64x48", "-q"]
    assert main(["render", *args, "-o", str(a)]) == 0
    assert main(["render", *args, "-o", str(b), "--samples", "1"]) == 0
    assert a.read_bytes() == b.read_bytes()


def test_cli_options(tmp_path, capsys):
    out = tmp_path / "t.png"
    code = main(["render", str(GRAMMARS / "sierpinski.pcsg"), "--set", "c=2", "-o", str(out),
                 "--size", "48x36", "--samples", "4", "--eye", "3,-4,2", "--at", "0,0,0",
                 "--fov", "35", "--max-depth", "10", "--bounces", "1", "-q"])
    assert code == 0 and Image.open(out).size == (48, 36)
    line = capsys.readouterr().out.strip()
    assert line.startswith(f"{out}: 48x36, ") and line.endswith("M rays/s")
    assert main(["render", str(GRAMMARS / "sierpinski.pcsg"), "--size", "0x0"]) == 2
    assert main(["render", str(GRAMMARS / "sierpinski.pcsg"), "--size", "100000x100000"]) == 2
    err = capsys.readouterr().err
    assert "width and height must be at least 1" in err and "GiB of memory" in err


def test_reference_renders_the_same_picture(tmp_path):
    a, b = tmp_path / "a.png", tmp_path / "b.png"
    args = [str(GRAMMARS / "sierpinski.pcsg"), "--set", "c=2", "--size", "40x30", "-q",
            "--no-shadows", "--bounces", "0"]
    assert main(["render", *args, "-o", str(a)]) == 0
    assert main(["render", *args, "-o", str(b), "--reference"]) == 0
    x = np.asarray(Image.open(a)).astype(int)
    y = np.asarray(Image.open(b)).astype(int)
    assert np.abs(x - y).max() <= 2


GLASS_OF_TWO_BALLS = [
    # a lens of inner faces where the balls overlap, through the refracted rays
    "#camera eye=(0,-6,1) at=(0,0,0) fov=40\n#material glass transmit=0.9 ior=1.5 "
    "specular=0.5\n#material red color=(1,0,0)\nmaterial(glass) (move(-0.5,0,0) sphere ∪ "
    "move(0.5,0,0) sphere) ∪ material(red) move(0,0,-1.2) scale(4,4,0.2) cube ∪ "
    "move(0,3,0) paint(0,0,1) uscale(0.7) cube\n",
    # its shadow: the light through four surfaces where the balls overlap, not two
    "#camera eye=(0,-0.01,8) at=(0,0,0) up=(0,1,0) fov=40\n#light at=(50,0,50)\n"
    "#material glass transmit=0.9 ior=1\nmaterial(glass) move(0,0,2) (move(-0.3,0,0) "
    "uscale(0.8) sphere ∪ move(0.3,0,0) uscale(0.8) sphere) ∪ paint(1,1,1) plane\n",
    # glass given operand by operand beside a floor that is no solid, and beside a rand()
    "#camera eye=(0.5, -6, 2.5) at=(0, 0, 0.8)\n#material glass ior=1.5 transmit=0.9\n"
    "material(glass) move(-0.4,0,1) sphere ∪ material(glass) move(0.5,0,1) uscale(0.8) "
    "sphere ∪ paint(0.3,0.5,0.3) scale(4,4,1) tri1\n",
    "#camera eye=(0.5, -6, 2.5) at=(0, 0, 0.8)\n#material glass ior=1.5 transmit=0.9\n"
    "material(glass) (move(-0.4,0,1) sphere ∪ move(0.5,0,1) uscale(0.8) sphere) ∪ "
    "paint(0.3, 0.5 + 0 * rand(), 0.3) move(0,0,-0.05) scale(4,4,0.05) cube\n",
]


@pytest.mark.parametrize("text", GLASS_OF_TWO_BALLS)
def test_glass_of_overlapping_parts_is_one_solid_as_in_the_reference(tmp_path, text):
    """The graph tracer's union is the nearest surface of any operand, so a ray inside the
    glass stopped at the faces inside it: 1,229 and 814 of 96x72 pixels differed from the
    reference, which merges the intervals (QA; graph/solidglass.py)."""
    src = tmp_path / "g.pcsg"
    src.write_text(text, encoding="utf-8")
    pictures = []
    for extra in ([], ["--reference"]):
        out = tmp_path / f"g{len(pictures)}.png"
        assert main(["render", str(src), "--size", "64x48", "-q", "-o", str(out), *extra]) == 0
        pictures.append(np.asarray(Image.open(out)).astype(int))
    assert np.array_equal(*pictures)


FAR_SCENE = ("#camera eye=({x}+4, {y}-6, 4) at=({x}, {y}, 0) fov=40\n"
             "#light at=({x}-3, {y}-4, 6) color=(1, 0.9, 0.8)\n"
             "{{k=1}} move({x}, {y}, 0) (paint(0.8,0.3,0.3) move(0,0,1) uscale(0.7) cube ∪ "
             "paint(0.3,0.3,0.8) move(1.5,0,0.5) sphere \\ move(1.5,-0.5,0.8) uscale(0.5) sphere "
             "∪ paint(0.3,0.8,0.3) move(0,1.5,0) cone ∪ paint(0.6,0.6,0.6) move(0,0,-0.5) plane)\n")


def test_a_scene_far_from_the_origin_is_drawn_as_at_the_origin(tmp_path):
    """A shaded point moved off its surface by 1e-6 of its largest coordinate: 1.4 units a
    million units out, past its neighbours' shadows (QA: 6.6 % of the pixels more than 30
    of 255 apart, shadows cast the wrong way)."""
    pictures = []
    for x, y in ((0, 0), (1_000_000, -1_000_000)):
        src = tmp_path / f"at{x}.pcsg"
        src.write_text(FAR_SCENE.format(x=x, y=y), encoding="utf-8")
        out = tmp_path / f"at{x}.png"
        assert main(["render", str(src), "--size", "120x90", "--no-adaptive",
                     "--shadow-samples", "1", "-o", str(out), "-q"]) == 0
        pictures.append(np.asarray(Image.open(out)).astype(int))
    assert len(np.unique(pictures[0].reshape(-1, 3), axis=0)) > 100     # the scene, shaded
    d = np.abs(pictures[0] - pictures[1]).max(axis=2)
    assert d.mean() < 0.2 and (d > 30).mean() < 0.002, (d.mean(), (d > 30).mean())


def test_reference_empties_an_invalid_selection_as_render_does(tmp_path, capsys):
    """--reference failed the file (as --strict does) where render draws the rest (QA)."""
    src = tmp_path / "e.pcsg"
    src.write_text("{c = 2; x = 1} S\nS if(c > 0, 2, if(x > 0.5, 1, 3))\n1: S → cube\n"
                   "2: S → {c = c-1} (move(-1,0,0) uscale(0.5) {x = 0} S ∪ "
                   "move(1,0,0) uscale(0.5) {x = 1} S)\n", encoding="utf-8")
    a, b = tmp_path / "a.png", tmp_path / "b.png"
    args = [str(src), "--size", "40x30", "-q", "--no-shadows", "--bounces", "0"]
    assert main(["render", *args, "-o", str(a)]) == 0
    assert main(["render", *args, "-o", str(b), "--reference"]) == 0
    assert "the selection of module 'S' gives 3" in capsys.readouterr().err
    x = np.asarray(Image.open(a)).astype(int)
    y = np.asarray(Image.open(b)).astype(int)
    assert np.abs(x - y).max() <= 2 and (x != x[0, 0]).any()      # the cubes drawn alike
    assert main(["render", *args, "-o", str(b), "--reference", "--strict"]) == 1


def test_a_long_reference_render_says_so_and_stops_at_its_timeout(tmp_path, capsys):
    """The default Sierpinski at 80x60 ran 6 minutes without a word, and its --timeout 2
    stopped it after 2 minutes (QA): the reference's Python walk polls every 64 rays."""
    out = tmp_path / "r.png"
    args = ["render", str(GRAMMARS / "sierpinski.pcsg"), "--size", "80x60", "-o", str(out),
            "--reference", "--timeout", "1"]
    assert main(args) == 1 and not out.exists()
    err = capsys.readouterr().err
    assert "--reference traces the expansion's 4,097 primitives one by one for every ray, " \
           "in Python: at 80x60 about 4 minutes" in err
    assert "stopped by --timeout 1 s" in err
    assert main(args + ["-q"]) == 1
    assert "--reference traces" not in capsys.readouterr().err


def test_batch_with_a_broken_file(tmp_path, capsys):
    bad = tmp_path / "broken.pcsg"
    bad.write_text("{c = 1} S\n1: S → nothing\n", encoding="utf-8")
    good = tmp_path / "good.pcsg"
    good.write_text("sphere\n", encoding="utf-8")
    out = tmp_path / "renders"
    code = main(["render", str(bad), str(good), "-o", str(out) + "/", "--size", "32x24", "-q"])
    captured = capsys.readouterr()
    assert code == 1
    assert (out / "good.png").exists() and not (out / "broken.png").exists()
    assert "broken.pcsg:3:8: error: undefined name 'nothing'" in captured.err or \
        "undefined name 'nothing'" in captured.err
    assert "rendered 1 of 2 files" in captured.out and "failed: " in captured.out


def interrupted_render(out, args, after: float):
    """`pcsg render ... -o out` over an earlier PNG, sent Ctrl-C `after` seconds in:
    its stderr, once it has checked that pcsg exited with 130 and kept that PNG."""
    out.write_bytes(b"an earlier good image")
    with sigint_reaches_children():
        proc = subprocess.Popen([sys.executable, "-m", "pcsg", "render", *args, "-o", str(out)],
                                cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    time.sleep(after)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert out.read_bytes() == b"an earlier good image"
    assert not [p for p in out.parent.iterdir() if p.name.endswith(".part")]
    return err


def test_interrupted_render_keeps_the_earlier_png(tmp_path):
    # about 120 M camera rays: minutes of work, so the signal comes mid-render however
    # fast the tracer gets (800x600 at 16 samples once finished within the 8 s)
    interrupted_render(tmp_path / "tree.png", [str(GRAMMARS / "sympodial_tree.pcsg"),
                                               "--size", "1600x1200", "--samples", "64"], 8)


def test_ctrl_c_in_a_long_bounding_walk_ends_the_render_cleanly(tmp_path):
    """The terrain at 12 walks its instances for seconds before it renders: Ctrl-C then
    lands in the bounding walk, which stops (its threads read a flag), and pcsg exits as
    from a render, with no traceback."""
    err = interrupted_render(tmp_path / "terrain.png",
                             [str(GRAMMARS / "carpenter_terrain.pcsg"), "--set", "cnt=12",
                              "--size", "32x24"], 2)
    assert b"interrupted" in err and b"Traceback" not in err


def test_sigterm_ends_an_export_as_ctrl_c_does(tmp_path):
    """`kill`, `timeout` or a scheduler's SIGTERM: the scene being written was left as a
    hidden .part file beside it (62 MB four seconds into the terrain at 10), with no word
    and status -15. Now the export stops as from Ctrl-C, removes it, and exits with 143."""
    out = tmp_path / "terrain.pov"
    proc = subprocess.Popen([sys.executable, "-m", "pcsg", "export",
                             str(GRAMMARS / "carpenter_terrain.pcsg"), "--set", "cnt=10",
                             "--pov", str(out)], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while not list(tmp_path.glob(".*.part")) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert list(tmp_path.glob(".*.part")), "the export never began writing"
    proc.terminate()
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 143 and b"pcsg: terminated (SIGTERM)" in err, err
    assert b"Traceback" not in err and list(tmp_path.iterdir()) == []


def test_the_render_checks_its_deadline_while_a_batch_is_traced():
    """render_frame's check (--timeout, and where Ctrl-C and SIGTERM land) runs every 50
    ms while the shading kernel traces a batch, not only between batches: a batch that
    traces for seconds is stopped in it. The first call comes before the first batch has
    counted any ray (the counts are added when a batch ends)."""
    obj = loads("#camera eye=(0,-0.5,6) at=(0,0,0) fov=30\n"
                "#light at=(3,-4,8) radius=2\nplane ∪ sphere\n")
    cam = make_camera(obj, 4 / 3)
    light = make_lighting(obj, cam, shadow_samples=256)
    counted = []

    def check():
        counted.append(int(light.rays[0]))
        raise TimeoutError("stopped")
    with pytest.raises(TimeoutError):
        # 30,720 camera rays in its first batch, 256 shadow rays each: seconds of work
        render_frame(obj, cam, light, 640, 480, adaptive=False, check=check)
    assert counted == [0]


def test_sigterm_stops_a_render_mid_batch(tmp_path):
    """SIGTERM (or Ctrl-C) while the shading kernel runs: its shares stop before their
    next chunk of rays, and the render ends as from Ctrl-C, its earlier PNG kept. A
    batch of rows runs in helper threads while the main thread waits (jit.stoppable):
    run on the main thread, a heavy batch held the signal until it ended."""
    out = tmp_path / "tree.png"
    out.write_bytes(b"an earlier good image")
    proc = subprocess.Popen([sys.executable, "-m", "pcsg", "render",
                             str(GRAMMARS / "sympodial_tree.pcsg"), "--size", "1600x1200",
                             "--samples", "64", "-o", str(out)],
                            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    time.sleep(8)
    proc.terminate()
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 143 and b"terminated" in err and b"Traceback" not in err, err
    assert out.read_bytes() == b"an earlier good image"
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".part")]


def test_a_mirror_shows_what_is_in_front_of_it():
    # looking down at a mirror floor: the red ball appears below the horizon in it
    scene = """#camera eye=(0,-6,1.2) at=(0,0,0) fov=40
#light at=(0,-4,6)
#material mirror reflect=1 diffuse=0 specular=0
paint(1,0,0) move(0,2,1.2) sphere ∪ material(mirror) plane"""
    obj, cam, fr = frame_of(scene, adaptive=False)
    matte, _, plain = frame_of(scene.replace("reflect=1 diffuse=0", "reflect=0 diffuse=0.7"),
                               adaptive=False)
    ys, xs = np.mgrid[0:72, 0:96]
    o, d = cam.rays(96, 72, xs.ravel() + 0.5, ys.ravel() + 0.5)
    z = (o[:, 2] + fr.depth.ravel() * d[:, 2]).reshape(72, 96)
    floor = np.isfinite(fr.depth) & (np.abs(z) < 1e-6)      # pixels that see the floor
    redness = fr.rgb[..., 0] - fr.rgb[..., 1]
    assert redness[floor].max() > 0.3             # the ball, seen in the mirror
    assert (plain.rgb[..., 0] - plain.rgb[..., 1])[floor].max() < 0.3


def test_glass_lets_the_wall_behind_show_through():
    scene = """#camera eye=(0,-6,0) at=(0,0,0) fov=30
#light at=(0,-6,4)
#material glass transmit=1 ior=1 diffuse=0 specular=0
material(glass) sphere ∪ paint(0,0.8,0) move(0,3,0) scale(5,0.1,5) cube"""
    _, _, fr = frame_of(scene, adaptive=False)
    centre = fr.rgb[36, 48]
    assert centre[1] > 2 * centre[0] and centre[1] > 0.2   # the green wall, through the glass


def test_tile_order_covers_every_pixel_block_by_block():
    from pcsg.render.image import TILE, tile_order
    rows, width = TILE + 5, 3 * TILE + 7           # partial blocks at the right and bottom
    order = tile_order(rows, width)
    assert np.array_equal(np.sort(order), np.arange(rows * width))
    first = order[:TILE * TILE]
    assert set(first // width) == set(range(TILE)) and set(first % width) == set(range(TILE))
    blocks = (order // width // TILE) * width + (order % width) // TILE
    runs = blocks[np.r_[True, blocks[1:] != blocks[:-1]]]
    assert len(runs) == len(set(runs.tolist()))       # each block's pixels come together


def test_the_order_rays_are_traced_in_does_not_change_the_picture(monkeypatch):
    """Tiles only change which calculated states a worker's cache still holds."""
    text = (GRAMMARS / "carpenter_terrain.pcsg").read_text().replace("cnt = 8;", "cnt = 4;")
    size = (70, 40)                                 # partial tiles
    _, _, tiled = frame_of(text, size)
    monkeypatch.setattr("pcsg.render.image.TILE", 1)     # 1x1 tiles: row after row
    _, _, rows = frame_of(text, size)
    assert rows.rays == tiled.rays
    assert np.array_equal(rows.rgb, tiled.rgb) and np.array_equal(rows.depth, tiled.depth)
    assert np.array_equal(rows.coverage, tiled.coverage)


def test_light_option_replaces_the_files_lights(tmp_path):
    """--light X,Y,Z is one point light in the default sun's colour, in place of #light."""
    moved = tmp_path / "moved.pcsg"
    moved.write_text(BALL.replace("#light at=(3,-2,8)",
                                  "#light at=(-4,-1,6) color=(1.0,0.97,0.92)"), encoding="utf-8")
    ball = tmp_path / "ball.pcsg"
    ball.write_text(BALL, encoding="utf-8")
    tiny = ["--size", "48x36", "-q"]
    a, b, c = tmp_path / "a.png", tmp_path / "b.png", tmp_path / "c.png"
    assert main(["render", str(ball), "-o", str(a), *tiny, "--light=-4,-1,6"]) == 0
    assert main(["render", str(moved), "-o", str(b), *tiny]) == 0
    assert main(["render", str(ball), "-o", str(c), *tiny]) == 0
    assert a.read_bytes() == b.read_bytes() != c.read_bytes()


def test_a_light_that_is_not_a_point_is_a_usage_error(tmp_path, capsys):
    ball = tmp_path / "ball.pcsg"
    ball.write_text(BALL, encoding="utf-8")
    assert main(["render", str(ball), "-o", str(tmp_path / "x.png"), "--light=1,nan,2"]) == 2
    err = capsys.readouterr().err
    assert "--light 1,nan,2: give a point with finite coordinates" in err
    assert not (tmp_path / "x.png").exists()


def test_srgb_follows_the_standards_two_pieces():
    """to_srgb works in place where it can; it is still the sRGB transfer function:
    12.92 x up to 0.0031308, 1.055 x^(1/2.4) - 0.055 above, clipped to [0, 1], and it
    leaves its input alone."""
    from pcsg.render.image import to_srgb
    x = np.array([[-0.5, 0.0, 0.001, 0.0031308], [0.0031309, 0.18, 1.0, 7.0]])
    before = x.copy()
    got = to_srgb(x)
    assert np.array_equal(x, before)
    want = [[0.0, 0.0, 0.01292, 12.92 * 0.0031308],
            [1.055 * 0.0031309 ** (1 / 2.4) - 0.055, 1.055 * 0.18 ** (1 / 2.4) - 0.055,
             1.0, 1.0]]
    assert np.allclose(got, want, rtol=0, atol=1e-15)
    assert abs(got[1, 1] - 0.4613561295) < 1e-9        # mid grey


def test_a_refined_pixel_is_the_mean_of_its_samples_each_traced_alone(monkeypatch):
    # the adaptive pass traces a pixel's samples side by side, in batches that end
    # anywhere (5 pixels here): each sample must still be what it is traced on its own
    from pcsg.render import image
    from pcsg.render.shade import shade
    monkeypatch.setattr(image, "REFINE_BATCH", 5)
    w, h = 80, 60
    obj = loads((GRAMMARS / "sierpinski.pcsg").read_text(encoding="utf-8"))
    cam = make_camera(obj, w / h)
    light = make_lighting(obj, cam)
    once = render_frame(obj, cam, light, w, h, adaptive=False)
    fine = render_frame(obj, cam, light, w, h)
    ys, xs = np.nonzero((fine.rgb != once.rgb).any(axis=2))
    assert len(ys) > 50
    offs = image._offsets(image.ADAPTIVE_SAMPLES, np.random.default_rng(image.JITTER_SEED))
    for y, x in list(zip(ys, xs))[::len(ys) // 16]:
        acc = once.rgb[y, x] * 1.0
        for k, (ox, oy) in enumerate(offs):
            o, d = cam.rays(w, h, np.array([x + ox]), np.array([y + oy]))
            c, _, _ = shade(obj, light, o, d,
                            ids=image.sample_ids(np.array([y * w + x]), 1 + k, w, h))
            acc += c[0]
        assert np.array_equal(fine.rgb[y, x], acc / (1 + len(offs))), (y, x)


def test_the_oversampling_has_its_own_progress_line(monkeypatch, capsys):
    # the line was the first pass's alone: at 100 %, "ETA 0.0 s", while the adaptive
    # pass took longer than the first on the terrain
    import itertools
    from pcsg.render import image
    clock = itertools.count(0.0, 2.0)              # every reading 2 s after the last
    monkeypatch.setattr(image.time, "perf_counter", lambda: next(clock))
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    monkeypatch.setattr(image, "REFINE_BATCH", 40)
    obj = loads((GRAMMARS / "sierpinski.pcsg").read_text(encoding="utf-8"))
    cam = make_camera(obj, 4 / 3)
    render_frame(obj, cam, make_lighting(obj, cam), 80, 60,
                 progress=image.Progress("s.pcsg", 80 * 60, True))
    err = capsys.readouterr().err
    first = err.index("s.pcsg: 100%")
    steps = re.findall(r"s\.pcsg oversampling: +(\d+)%", err[first:])
    assert len(steps) > 2 and steps[-1] == "100" and int(steps[0]) < 100
    assert steps == sorted(steps, key=int)


def test_the_default_camera_frames_the_derived_object_as_its_expansion_does():
    """Notation §8: without a camera the renderer frames the object's box. A system whose
    module's hyper box holds all its instances (the unit sphere of the last level here) was
    framed by that box too, so its expanded file, of the same two spheres, was framed
    closer (1,368 of 19,200 pixels differed)."""
    from pcsg.graph.expand import expand_file
    text = ("{c = 1} S\nS if(c > 0, 2, 1)\n1: S → sphere\n"
            "2: S → {c = c - 1} (move(-1.5, 0, 0) uscale(0.6) S ∪ move(1.5, 0, 0) uscale(0.6) S)\n")
    system = loads(text)
    expanded = loads(expand_file(system.graph, 2))
    a, b = make_camera(system, 4 / 3), make_camera(expanded, 4 / 3)
    assert np.allclose(a.eye, b.eye) and np.allclose(a.at, b.at)
    assert np.allclose(b.at, 0) and np.linalg.norm(b.eye) < np.linalg.norm(
        make_camera(loads("uscale(2.1) sphere"), 4 / 3).eye)
    # with a ground plane under the axiom's block: the module's hyper box below it holds
    # the sphere of radius 5 it derives at the last level, the object is 0.05 across
    text = ("{c = 2} (S ∪ move(0, 0, -1) plane)\nS if(c > 0, 2, 1)\n"
            "1: S → uscale(5) sphere\n2: S → {c = c - 1} uscale(0.1) S\n")
    system = loads(text)
    assert not np.isfinite(system.bounds).all()
    np.testing.assert_allclose(finite_bounds(system), [-0.05] * 3 + [0.05] * 3)
    expanded = loads(expand_file(system.graph, 3))
    a, b = make_camera(system, 4 / 3), make_camera(expanded, 4 / 3)
    assert np.allclose(a.eye, b.eye) and np.allclose(a.at, b.at)


@pytest.mark.parametrize("text", [
    # a plane under ∩ is no ground: the slab of the cube is the object, not the sphere
    "((plane ∪ sphere) ∩ uscale(20) cube) ∪ move(0, -5, 0) plane\n",
    # planes at every level: no finite part but the point they gather at
    "S\n1: S → plane ∪ move(1, 0, 0) uscale(0.5) S\n",
])
def test_the_default_camera_does_not_frame_what_dropping_planes_made_up(text):
    from pcsg.graph.bounds import finite_root
    system = loads(text)
    assert finite_root(system.graph) is None
    box = finite_bounds(system)
    assert np.all(box[3:] - box[:3] >= 2)


def test_a_render_of_many_samples_is_checked_after_each_samples_pass():
    # --timeout and the progress line waited for a batch of 48 rows with all its samples:
    # with --samples 1024, --timeout 1 stopped after 19 s
    calls = []
    frame_of(BALL, (16, 12), samples=9, check=lambda: calls.append(1))
    assert len(calls) == 9 + 1          # each pass of the one batch, and the batch's end
    calls.clear()
    frame_of(BALL, (16, 12), samples=1, adaptive=False, check=lambda: calls.append(1))
    assert len(calls) == 1


def test_a_tiny_scene_casts_its_shadows_as_a_large_one(tmp_path):
    """A light far from a scene stands REACH times its size away, but that size had a
    floor of 1e-12: at 1e-20 the light stood 1e-8 away, its shadow rays began 1e-17 off
    the surface, past the balls, and the slab under them had no shadow (QA: 35 pixels of
    64x48 far from the picture at scale 1)."""
    pictures = {}
    for size in ("1", "1e-20", "1e-100", "1e40"):
        src = tmp_path / f"balls_{size}.pcsg"
        src.write_text(f"uscale({size}) (move(0,0,1.5) uscale(0.5) sphere ∪ "
                       f"move(0.6,0,1) uscale(0.3) sphere ∪ scale(2,2,0.1) cube)\n")
        out = tmp_path / f"balls_{size}.png"
        assert main(["render", str(src), "-o", str(out), "--size", "64x48", "-q"]) == 0
        pictures[size] = np.asarray(Image.open(out).convert("RGB"), float)
    one = pictures.pop("1")
    for size, picture in pictures.items():
        apart = np.abs(picture - one).sum(axis=2) > 40
        assert apart.sum() <= 4, (size, apart.sum())


def test_a_tiny_scene_on_a_ground_plane_casts_its_shadows_as_a_large_one(tmp_path):
    """A shaded point moves off its surface by 1e-6 of the object's size, which the
    plane's infinite box left at 1: at 1e-6 the hollow's shadow was gone and the floor's
    cut short (QA: 15,011 of 160x120 pixels apart from the picture at scale 1)."""
    pictures = {}
    for size in ("1", "1e-6", "1e-30"):
        src = tmp_path / f"hollow_{size}.pcsg"
        src.write_text(f"#camera eye=(3*{size}, -4*{size}, 3*{size}) at=(0, 0, 0)\n"
                       f"#light at=(-2*{size}, -{size}, 6*{size})\n"
                       f"uscale({size}) ((paint(1,0.5,0.2) cube \\ move(0.5,-0.5,0.5) "
                       f"uscale(0.9) sphere) ∪ move(0,0,-1) plane)\n", encoding="utf-8")
        out = tmp_path / f"hollow_{size}.png"
        assert main(["render", str(src), "-o", str(out), "--size", "80x60", "-q"]) == 0
        pictures[size] = np.asarray(Image.open(out).convert("RGB"), float)
    one = pictures.pop("1")
    assert (np.abs(one - one[0, 0]).max(axis=2) > 30).mean() > 0.3       # a scene, shaded
    for size, picture in pictures.items():
        apart = np.abs(picture - one).max(axis=2) > 8
        assert apart.sum() <= 4, (size, apart.sum())


def test_a_tiny_csg_object_is_drawn_as_a_large_one(tmp_path):
    """∩ and \\ dropped their pieces thinner than 1e-9 below t = 1 as slivers: from 1e-9
    down, `sphere \\ cube` was drawn as nothing and `sphere ∩ cube` said no ray met it (QA:
    79 of 171 pixels apart from the picture at scale 1). The reference drops what the
    walk drops, so it agreed; the picture at scale 1 is the check."""
    pictures = {}
    for size in ("1", "1e-9", "1e-20", "1e-100"):
        src = tmp_path / f"cut_{size}.pcsg"
        src.write_text(f"uscale({size}) (sphere \\ move(0.5, 0, 0.5) cube ∪ "
                       f"move(2, 0, 0) (uscale(0.8) cube ∩ sphere))\n", encoding="utf-8")
        out = tmp_path / f"cut_{size}.png"
        assert main(["render", str(src), "-o", str(out), "--size", "48x36", "-q",
                     "--no-adaptive", "--shadow-samples", "1", "--depth",
                     str(out.with_suffix(".npy"))]) == 0
        pictures[size] = np.isfinite(np.load(out.with_suffix(".npy")))
    # and the reference, which drops the same slivers
    ref = tmp_path / "cut_ref.png"
    assert main(["render", str(tmp_path / "cut_1e-20.pcsg"), "-o", str(ref), "--size", "48x36",
                 "-q", "--no-adaptive", "--shadow-samples", "1", "--reference", "--depth",
                 str(ref.with_suffix(".npy"))]) == 0
    pictures["reference"] = np.isfinite(np.load(ref.with_suffix(".npy")))
    one = pictures.pop("1")
    assert one.sum() > 200
    for size, met in pictures.items():
        assert (met != one).sum() <= 4, (size, (met != one).sum())


def test_an_object_smaller_than_1e_9_is_framed_and_drawn_as_a_larger_one(tmp_path):
    """The camera rays started at t = 1e-9, so an object smaller than that was drawn as
    nothing or as a dark speck, and the framing gave every object a radius of 1e-9 at
    least (`uscale(1e-10) sphere`, QA); a shaded point moved 1e-6 off its surface at
    least, so below 1e-11 one was lit from past its light, dark (Lighting.unit)."""
    pictures = []
    for size in ("1e-6", "1e-10", "1e-20", "1e-100"):
        src = tmp_path / f"ball_{size}.pcsg"
        src.write_text(f"uscale({size}) sphere\n", encoding="utf-8")
        out = tmp_path / f"ball_{size}.png"
        assert main(["render", str(src), "-o", str(out), "--size", "48x36", "-q"]) == 0
        pictures.append(np.asarray(Image.open(out).convert("RGB"), float))
    big, *small = pictures
    ball = np.abs(big - big[0, 0]).max(axis=2) > 30
    assert 0.1 < ball.mean() < 0.8                      # the ball is framed
    for picture in small:                               # and each is the same ball
        assert np.abs(picture - big).max() <= 2
