"""The numba shading kernel (trace/shading.py) against the numpy model it follows
(render/shade.py): same colours, first hits and ray counts, with area lights,
reflection, refraction and ambient occlusion."""
from pathlib import Path

import numpy as np
import pytest

import pcsg
from pcsg.render.camera import make_camera
from pcsg.render.shade import make_lighting, shade

GLASS = """
#camera eye=(3, -4, 2.5) at=(0, 0, 0) up=(0, 0, 1) fov=40
#light at=(-3, -8, 10) radius=0.8
#light at=(6, 2, 3) color=(0.3, 0.3, 0.4)
#material glass color=(0.9, 0.95, 1.0) diffuse=0.2 specular=0.8 shininess=90 reflect=0.1 ior=1.5 transmit=0.8
#material mirror color=(0.8, 0.8, 0.8) reflect=0.7
{n = 2} (material(glass) S ∪ material(mirror) move(0, 0, -1.2) plane ∪ move(1.5, 1, 0) cube)
S if(n > 0, 2, 1)
1: S → sphere \\ uscale(0.6) move(0, 0, 1) cube
2: S → {n = n-1} (move(0.5, 0, 0) uscale(0.5) S ∪ move(-0.5, 0, 0) uscale(0.5) S)
"""


# glass on a sheet and a graftal (walk.HIT_SHEET, HIT_SHELL)
SHELLS = """
#camera eye=(3, -4, 2.5) at=(0, 0, 0) up=(0, 0, 1) fov=40
#material glass color=(0.9, 0.95, 1.0) diffuse=0.2 specular=0.8 reflect=0.1 ior=1.5 transmit=0.8
material(glass) (move(1.2, 0, 0) uscale(0.8) S ∪ move(-2, -1, -1) rotx(90) uscale(4) tri1) ∪
move(0, 3, 0) scale(4, 0.2, 3) cube
S 1
1: S → uscale(0.5) (move(1, 1, 1) S ∪ move(-1, -1, 1) S ∪ move(1, -1, -1) S ∪ move(-1, 1, -1) S)
"""


# a fractal seen through glass, in a mirror and in shadow rays, and a graftal: the rays
# that leave a surface start with the pixel's width there, in the model as in the kernel
# (the model's started afresh at each surface, and a fractal's surface, marched to the
# width, moved with it)
SECONDARY = """
#camera eye=(3, -4, 2.5) at=(0, 0, 0.5) up=(0, 0, 1) fov=40
#light at=(-2, -6, 8) radius=0.5
#material glass color=(0.9, 0.95, 1.0) diffuse=0.2 specular=0.8 reflect=0.1 ior=1.5 transmit=0.8
#material mirror color=(0.9, 0.9, 0.9) reflect=0.8
material(glass) move(0.3, -1.2, -1) rotx(90) uscale(3) tri1 ∪
move(0, 0.6, 0.6) uscale(0.8) julia(-0.2, 0.6, 0.2, 0) ∪
material(mirror) move(0, 3, 0) scale(4, 0.2, 3) cube ∪
move(-1.6, 0.4, 0) uscale(0.6) S ∪ move(0, 0, -1) plane
S 1
1: S → uscale(0.5) (move(1, 1, 1) S ∪ move(-1, -1, 1) S ∪ move(1, -1, -1) S ∪ move(-1, 1, -1) S)
"""


@pytest.mark.parametrize("obj", [
    pcsg.loads(GLASS),
    pcsg.loads(SHELLS),
    pcsg.loads(SECONDARY),
    pcsg.load("grammars/carpenter_terrain.pcsg", cnt=3),
    pcsg.load("grammars/sympodial_tree.pcsg", cnt=4),
], ids=["glass", "shells", "secondary", "terrain", "tree"])
@pytest.mark.parametrize("shadows,samples,ao", [(True, 8, 0), (True, 1, 0), (False, 1, 0),
                                                (True, 4, 8)])
def test_kernel_shades_like_the_model(obj, shadows, samples, ao):
    cam = make_camera(obj, 4 / 3)
    light = make_lighting(obj, cam, shadows, samples, 3, ao=ao)
    light.lod = cam.pixel_angle(45)
    ys, xs = np.mgrid[0:45, 0:60]
    o, d = cam.rays(60, 45, xs.ravel() + 0.5, ys.ravel() + 0.5)
    light.rays[0] = 0
    want, want_t, want_hits = shade(obj, light, o, d, kernel=False)
    model_rays = light.rays[0]
    light.rays[0] = 0
    got, got_t, got_hits = shade(obj, light, o, d)
    assert light.rays[0] == model_rays
    assert model_rays > len(o) or not shadows
    assert model_rays >= len(o) + ao * want_hits.hit.sum()     # every visible point's AO rays
    np.testing.assert_array_equal(got_hits.hit, want_hits.hit)
    np.testing.assert_allclose(got_t[want_hits.hit], want_t[want_hits.hit], rtol=1e-12)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)
    assert got.std() > 0.02                 # a picture, not a flat colour


LIT_FROM_THE_SIDE = """
#camera eye=(0, -5, 0) at=(0, 0, 0) up=(0, 0, 1) fov=40
#light at=(8, 0, 0)
sphere
"""


@pytest.mark.parametrize("kernel", [False, True], ids=["model", "kernel"])
def test_only_surfaces_facing_a_light_send_shadow_rays(kernel):
    """A lone sphere lit from the side: a point at x sees the light at (8, 0, 0) only where
    its normal (the point itself) turns to it, x > 1/8. Only those points send shadow rays,
    and the picture is the one without shadows (a convex solid shadows nothing of itself
    that the light reaches)."""
    obj = pcsg.loads(LIT_FROM_THE_SIDE)
    cam = make_camera(obj, 4 / 3)
    ys, xs = np.mgrid[0:45, 0:60]
    o, d = cam.rays(60, 45, xs.ravel() + 0.5, ys.ravel() + 0.5)
    pictures = []
    for shadows in (True, False):
        light = make_lighting(obj, cam, shadows, 1, 3)
        light.rays[0] = 0
        color, t, hits = shade(obj, light, o, d, kernel=kernel)
        pictures.append(color)
        if shadows:
            h = hits.hit
            x = o[h, 0] + t[h] * d[h, 0]
            assert np.abs(x - 1 / 8).min() > 1e-3          # no point near the boundary
            facing = int((x > 1 / 8).sum())
            assert 0 < facing < hits.hit.sum()            # both halves are in view
            assert light.rays[0] == len(o) + facing
    np.testing.assert_allclose(pictures[0], pictures[1], rtol=0, atol=1e-12)


BALL_ABOVE = """
#camera eye=(5, 0, 0.5) at=(0, 0, 0) up=(0, 0, 1) fov=40
#light at=(0, 0, 10)
#material glass transmit={t} ior=1.5
{ball} move(0, 0, 2) sphere ∪ paint(0.8, 0.8, 0.8) plane
"""


@pytest.mark.parametrize("kernel", [False, True], ids=["model", "kernel"])
def test_glass_lets_its_transmit_through_each_surface_to_the_shadow(kernel):
    # glass cast a full shadow; the light straight under the ball's centre crosses two
    # surfaces: transmit squared of it comes through (POV-Ray's `transmit` does the same)
    def lit(t, ball="material(glass)"):
        obj = pcsg.loads(BALL_ABOVE.replace("{t}", str(t)).replace("{ball}", ball))
        cam = make_camera(obj, 1.0)
        light = make_lighting(obj, cam, True, 1, 3)
        o, d = np.array([[5.0, 0, 0.5]]), np.array([[-5.0, 0, -0.5]])   # onto (0, 0, 0)
        c, t_hit, hits = shade(obj, light, o, d, kernel=kernel)
        assert hits.hit[0] and abs(t_hit[0] - 1) < 1e-12
        return c[0]
    dark, bare = lit(0), lit(0, "uscale(0.001) move(1000, 0, 0)")
    for t in (0.5, 0.9):
        np.testing.assert_allclose((lit(t) - dark) / (bare - dark), t * t, rtol=1e-9)


def test_a_light_far_away_still_casts_shadows(tmp_path):
    """A shadow ray spans the whole way to its light and begins 1e-9 of it from the
    surface: a light at 1e10 drew no shadows (the surfaces' own included), and one past
    1e154 lit nothing (its squared distance overflowed). The same direction at any
    distance is the same sun."""
    from PIL import Image
    from pcsg.cli import main
    sierpinski = Path(__file__).resolve().parent.parent / "grammars" / "sierpinski.pcsg"
    images = {}
    for name, extra in (("near", ["--light=-3e3,-8e3,1e4"]), ("far", ["--light=-3e10,-8e10,1e11"]),
                        ("farthest", ["--light=-3e200,-8e200,1e201"]),
                        ("unshadowed", ["--light=-3e3,-8e3,1e4", "--no-shadows"])):
        out = tmp_path / f"{name}.png"
        assert main(["render", str(sierpinski), "--size", "96x72", "--shadow-samples", "1",
                     "-q", "-o", str(out), *extra]) == 0
        images[name] = np.asarray(Image.open(out).convert("RGB"), float)
    near = images["near"]
    assert np.abs(near - images["unshadowed"]).max(axis=2).mean() > 2      # it has shadows
    for name in ("far", "farthest"):
        assert np.abs(near - images[name]).max(axis=2).mean() < 0.1, name


def test_an_area_lights_samples_are_shifted_pixel_by_pixel():
    """One pattern of n points for every pixel cast n hard shadows side by side, bands
    across the penumbra (the table tower's at 8 samples). Shifted per pixel (mod 1, as
    the hemisphere's), the samples of many pixels cover the disk evenly: the share of
    them past a chord is the segment's share of the disk's area, where one pattern's is
    a multiple of 1/8 off it. The kernel's disk is the model's."""
    from pcsg.render.shade import _disk
    from pcsg.trace.shading import disk
    from pcsg.trace.vm import hash_to_unit_array, splitmix64_array
    n, pixels, c = 8, 4096, 0.3
    h = splitmix64_array(np.arange(pixels))
    shift = np.stack([hash_to_unit_array(h), hash_to_unit_array(splitmix64_array(h))], 1)
    normal = np.tile([0.0, 0.0, 1.0], (pixels, 1))
    points = np.concatenate([_disk(k, n, 1.0, shift, normal) for k in range(n)])
    segment = (np.arccos(c) - c * np.sqrt(1 - c * c)) / np.pi     # past x = c, radius 1
    u = np.cross(normal[0], [1.0, 0.0, 0.0])                     # the pattern's own axis
    u /= np.linalg.norm(u)
    past = (points @ u > c).mean()
    assert abs(past - segment) < 0.01
    one_pattern = (points[::pixels] @ u > c).mean()
    assert abs(one_pattern - segment) > 0.02          # what every pixel had before
    for k in (0, 3, 7):
        for p in (0, 1, 2):
            got = disk(k, n, 1.0, shift[p, 0], shift[p, 1], 0.0, 0.0, 1.0)
            np.testing.assert_allclose(got, _disk(k, n, 1.0, shift[p:p + 1], normal[:1])[0],
                                       atol=1e-15)
