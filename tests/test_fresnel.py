"""Reflection and refraction against optics worked out by hand: Fresnel's equations, a
glass of index 1 that does not show, the reflection of a glass slab seen head-on, and
the rays a deep stack of glass bounces may take."""
import math

import numpy as np
import pytest

import pcsg
from pcsg.render.camera import make_camera
from pcsg.render.image import render_frame
from pcsg.render.shade import fresnel_split, make_lighting


def reflectance(cos_i, n1, n2):
    """Fresnel's unpolarised reflectance, written from the textbook form in angles."""
    ti = math.acos(cos_i)
    s = n1 / n2 * math.sin(ti)
    if s >= 1:
        return 1.0
    if ti == 0:
        return ((n1 - n2) / (n1 + n2)) ** 2
    tt = math.asin(s)
    rs = math.sin(ti - tt) ** 2 / math.sin(ti + tt) ** 2
    rp = math.tan(ti - tt) ** 2 / math.tan(ti + tt) ** 2
    return (rs + rp) / 2


@pytest.mark.parametrize("n1, n2", [(1.0, 1.5), (1.5, 1.0), (1.0, 1.33), (2.4, 1.0)])
@pytest.mark.parametrize("cos_i", [1.0, 0.95, 0.8, 0.5, 0.3, 0.1, 0.01])
def test_a_clear_surface_reflects_what_fresnel_says(n1, n2, cos_i):
    kr, kt = fresnel_split(np.array([cos_i]), np.array([n1 / n2]), np.array([0.0]),
                           np.array([1.0]))
    f = reflectance(cos_i, n1, n2)
    assert kr[0] == pytest.approx(f, abs=1e-12)
    assert kt[0] == pytest.approx(0.0 if f == 1.0 else 1 - f, abs=1e-12)


def test_reflectance_is_the_same_both_ways_and_whole_at_the_critical_angle():
    # light crossing a surface either way is reflected by the same share (Stokes), and
    # leaving glass the share rises to 1 without a jump at the critical angle
    for cos_i in np.linspace(0.05, 1.0, 20):
        sin_t = math.sqrt(1 - cos_i ** 2) / 1.5
        cos_t = math.sqrt(1 - sin_t ** 2)
        out_in = fresnel_split(np.array([cos_i]), np.array([1 / 1.5]), 0.0, 1.0)[0]
        in_out = fresnel_split(np.array([cos_t]), np.array([1.5]), 0.0, 1.0)[0]
        assert out_in[0] == pytest.approx(in_out[0], abs=1e-12)
    critical = math.sqrt(1 - 1 / 1.5 ** 2)          # cos of the critical angle inside
    near = fresnel_split(np.array([critical + 1e-9]), np.array([1.5]), 0.0, 1.0)[0]
    assert near[0] > 0.999


def test_an_index_of_one_reflects_nothing_at_any_angle():
    cos_i = np.linspace(0.0, 1.0, 101)
    kr, kt = fresnel_split(cos_i, np.ones_like(cos_i), np.zeros_like(cos_i),
                           np.full_like(cos_i, 0.7))
    assert np.all(kr[1:] < 1e-20) and np.allclose(kt[1:], 0.7, atol=0, rtol=1e-15)


def test_reflect_and_transmit_together_never_pass_on_more_than_comes():
    rng = np.random.default_rng(5)
    cos_i, eta = rng.random(1000), rng.uniform(0.3, 3.0, 1000)
    reflect, transmit = rng.random(1000), rng.random(1000)
    kr, kt = fresnel_split(cos_i, eta, reflect, transmit)
    assert np.all(kr >= 0) and np.all(kt >= 0) and np.all(kr + kt <= 1 + 1e-15)


BEHIND = """
#camera eye=(0,-8,0) at=(0,0,0) fov=30
#light at=(0,-8,3)
#sky color=(0,0,0)
paint(1,0,0) move(-2,6,2) scale(2,0.1,2) cube ∪ paint(0,1,0) move(2,6,2) scale(2,0.1,2) cube ∪
paint(0,0,1) move(-2,6,-2) scale(2,0.1,2) cube ∪ paint(1,1,0) move(2,6,-2) scale(2,0.1,2) cube
"""
CLEAR = "#material clear color=(1,1,1) diffuse=0 specular=0 ior=1 transmit=1\n"


def render(text, size=(80, 60), **kw):
    obj = pcsg.loads(text)
    cam = make_camera(obj, size[0] / size[1])
    light = make_lighting(obj, cam, shadows=False, **kw)
    return render_frame(obj, cam, light, *size, adaptive=False).rgb


def test_glass_of_index_one_does_not_show():
    # Schlick's approximation reflected (1 - cos)^5 even here: a dark ring over the
    # sphere's outer quarter, up to 77 levels off
    without = render(BEHIND)
    with_ball = render(CLEAR + BEHIND.rstrip() + " ∪ material(clear) sphere\n")
    assert np.abs(with_ball - without).max() < 1e-6     # a ray that passes starts EPS on


SLAB = """
#camera eye=(0,-5,0) at=(0,0,0) fov=30
#light at=(0,-3,0) color=(0.5,0.5,0.5)
#sky color=(0,0,0)
#material wall color=(1,1,1) diffuse=1 specular=0
material(MAT) scale(1,0.2,1) cube ∪ material(wall) move(0,-12,0) scale(20,0.1,20) cube
"""


def test_a_glass_slab_head_on_reflects_its_two_surfaces():
    # each face reflects 4 % of what meets it ((1.5 - 1) / (1.5 + 1))^2: the front 0.04
    # of the wall, the back 0.04 of the 0.96 let in, of which 0.96 comes out again
    # (bounces 3 follow no further). Before, the glass passed on F^2 of the wall
    glass = render("#material MAT color=(1,1,1) diffuse=0 specular=0 ior=1.5 transmit=1\n"
                   + SLAB)
    f = 0.04
    share = f + (1 - f) * f * (1 - f)
    mirror = render(f"#material MAT color=(0,0,0) diffuse=0 specular=0 reflect={share!r}\n"
                    + SLAB)
    c = glass[30, 40]
    assert c[0] > 0.01                              # the lit wall, seen in the glass
    np.testing.assert_allclose(c, mirror[30, 40], rtol=1e-3)


def test_deep_bounces_in_glass_stop_where_rays_no_longer_count():
    # every glass surface splits a ray in two: without a floor on the weight a ray's
    # colour enters its pixel with, --bounces 20 traced millions of rays here
    balls = ("#material glass color=(1,1,1) diffuse=0 specular=0 ior=1.5 transmit=1\n"
             + BEHIND.rstrip() + " ∪ material(glass) (sphere ∪ move(0,2.5,0) uscale(0.8) sphere)\n")
    obj = pcsg.loads(balls)
    cam = make_camera(obj, 4 / 3)
    rays = {}
    for bounces in (8, 24):
        light = make_lighting(obj, cam, shadows=False, max_bounces=bounces)
        render_frame(obj, cam, light, 40, 30, adaptive=False)
        rays[bounces] = light.rays[0]
    assert rays[24] < 1.5 * rays[8]


def test_a_glass_sheet_bends_nothing_that_passes_through_it():
    # a triangle has no thickness: a ray bent where it enters would never be bent back,
    # and the wall behind a pane of index 1.5 showed shifted
    pane = ("#material pane color=(1,1,1) diffuse=0 specular=0 ior=1.5 transmit=1\n"
            + BEHIND.rstrip() + " ∪ material(pane) move(-3, 2, -3) rotx(80) uscale(6) tri1\n")
    without = render(BEHIND)
    with_pane = render(pane)
    assert np.abs(with_pane - without).max() < 1e-6
    bent = render(pane.replace("tri1", "scale(1, 1, 0.05) cube").replace("uscale(6)",
                                                                          "scale(6, 6, 1)"))
    assert np.abs(bent - without).max() > 0.1        # a slab of thickness does bend


@pytest.mark.parametrize("shell", ["julia(0, 0, 0, 0)", "S", "move(0, 0, 0) S"])
def test_nothing_passes_through_a_fractal_or_a_graftal(shell):
    """Traced to their first surface only, they have no inside to leave: a ray sent into
    one hit it again at once, and a glass julia(0, 0, 0, 0) (the unit ball) showed grey
    noise. They are drawn as the same material that lets nothing through, and `check`
    says so."""
    system = ("S 1\n1: S → uscale(0.5) (move(1, 1, 1) S ∪ move(-1, -1, 1) S ∪ "
              "move(1, -1, -1) S ∪ move(-1, 1, -1) S)\n")         # Sierpinski's
    glass = ("#material glass color=(1,1,1) diffuse=0.3 specular=0.5 reflect=0.1 ior=1.5 "
             "transmit=0.8\n" + BEHIND.rstrip() + f" ∪ material(glass) {shell}\n" + system)
    opaque = glass.replace("transmit=0.8", "transmit=0")
    got = render(glass)
    assert np.abs(got - render(opaque)).max() < 1e-9
    assert np.abs(got - render(BEHIND + system)).max() > 0.1      # and it is there
    [warning] = [w for w in pcsg.loads(glass).graph.warnings if w.code == "opaque"]
    assert "is traced to its first surface only" in warning.message
    assert not [w for w in pcsg.loads(opaque).graph.warnings if w.code == "opaque"]
    # under ∩ the graftal's volume is a solid's interval, which lets light through
    cut = glass.replace(f"material(glass) {shell}", f"material(glass) ({shell} ∩ uscale(9) cube)")
    assert shell == "julia(0, 0, 0, 0)" or not [
        w for w in pcsg.loads(cut).graph.warnings if w.code == "opaque"]


def test_the_reference_lets_nothing_through_a_glass_graftal_either(tmp_path):
    # --reference drew a glass graftal as glass: its cut instances' volumes counted as solid
    from PIL import Image
    from pcsg.cli import main
    src = tmp_path / "g.pcsg"
    src.write_text("#material glass color=(1,1,1) transmit=0.9 ior=1.5 diffuse=0.1\n"
                   "#camera eye=(0,-4,1.5) at=(0,0,0.3) fov=40\n#light at=(3,-5,6)\n"
                   "material(glass) S ∪ paint(1,0,0) move(0,2,0) cube\n"
                   "1: S → uscale(0.5) (move(1,0,0) S ∪ move(-1,0,0) S ∪ move(0,0,1.2) S)\n",
                   encoding="utf-8")
    pictures = []
    for extra in ([], ["--reference"]):
        out = tmp_path / f"g{len(extra)}.png"
        assert main(["render", str(src), "--max-depth", "5", "--size", "40x30", "-q",
                     "-o", str(out), *extra]) == 0
        pictures.append(np.asarray(Image.open(out)).astype(int))
    assert (np.abs(pictures[0] - pictures[1]).max(axis=2) > 8).sum() <= 3


@pytest.mark.parametrize("axiom, what", [("S", 3), ("S ∩ uscale(10) cube", 1),
                                         ("S \\ move(20, 0, 0) cube", 1)])
def test_the_reference_says_what_the_tracer_hit(axiom, what):
    # under ∩ or \ the tracer takes a graftal's volume from interval lists, a solid's
    # ends: the reference said shell there, and drew a glass graftal otherwise
    from pcsg.graph.cut import cut_of
    from pcsg.trace.reference import Reference
    obj = pcsg.loads(axiom + "\n1: S → uscale(0.5) (move(1, 1, 1) S ∪ move(-1, -1, 1) S ∪ "
                     "move(1, -1, -1) S ∪ move(-1, 1, -1) S)\n", max_depth=2)
    o, d = np.array([[0.1, 0.2, -5.0]]), np.array([[0.0, 0.0, 1.0]])
    hits = obj.trace(o, d)
    ref = Reference(obj.graph, cut=cut_of(obj)).trace(o, d, exits=True)
    assert hits.what[0] == ref["what"][0] == what and hits.t[0] == ref["t"][0]
