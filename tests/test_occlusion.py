"""Ambient occlusion (--ao, --ao-distance, #occlusion): the fraction of the ambient
light a point keeps, in the numba kernel and in the numpy model, against what the
geometry says it must be."""
import math

import numpy as np
import pytest

import pcsg
from pcsg.cli import main
from pcsg.render.shade import DEFAULT_HORIZON, DEFAULT_ZENITH, Lighting, shade

from .conftest import GRAMMARS

N = 16                     # hemisphere rays per point
FLOOR = "paint(0.8, 0.8, 0.8) plane"
# a wall x >= h standing on the floor, far larger than any --ao-distance used here
WALL = "paint(0.8, 0.8, 0.8) move({h} + 50, 0, 0) uscale(50) cube"


def unoccluded(obj, points, ao=N, distance=1.0, kernel=True):
    """The ambient fraction each floor point keeps: with no lights a point's colour
    is the ambient term alone, so it is the ratio of its colour with and without AO."""
    o = points + [0.0, 0.0, 2.0]
    d = np.tile([0.0, 0.0, -1.0], (len(points), 1))

    def colour(samples):
        light = Lighting([], DEFAULT_HORIZON, DEFAULT_ZENITH, np.zeros((0, 9)),
                         max_bounces=0, ao_samples=samples, ao_distance=distance)
        rgb, t, hits = shade(obj, light, o, d, kernel=kernel)
        assert hits.hit.all() and np.allclose(t, 2.0)
        return rgb[:, 1], light.rays[0]

    plain, _ = colour(0)
    shaded, rays = colour(ao)
    assert rays == len(points) * (1 + ao)
    return shaded / plain


def floor_points(x, count=400, y=(-20, 20)):
    """count points on the floor along y at a given x, each its own pixel id."""
    return np.column_stack([np.full(count, x), np.linspace(*y, count), np.zeros(count)])


@pytest.mark.parametrize("kernel", [True, False], ids=["kernel", "model"])
def test_open_floor_keeps_all_its_ambient(kernel):
    got = unoccluded(pcsg.loads(FLOOR), floor_points(0.3), kernel=kernel)
    np.testing.assert_array_equal(got, 1.0)


@pytest.mark.parametrize("kernel", [True, False], ids=["kernel", "model"])
@pytest.mark.parametrize("h", [0.25, 0.5, 0.8])
def test_floor_beside_a_wall_matches_the_analytic_fraction(kernel, h):
    # Cosine-weighted directions project to points spread evenly over the unit disk
    # (Malley), so a ray reaches the wall within distance D exactly when its x
    # component is at least h / D: a circular segment of the disk is blocked.
    a = h / 1.0
    blocked = (math.acos(a) - a * math.sqrt(1 - a * a)) / math.pi
    obj = pcsg.loads(f"{FLOOR} ∪ {WALL.format(h=h)}")
    got = unoccluded(obj, floor_points(0.0), distance=1.0, kernel=kernel)
    # each point: a whole number of N rays; the shifts differ from point to point, so
    # the mean of 400 points is within 4 standard deviations of p(1-p)/(N * 400)
    np.testing.assert_allclose(got * N, np.round(got * N), atol=1e-9)
    sd = math.sqrt(blocked * (1 - blocked) / (N * len(got)))
    assert abs(got.mean() - (1 - blocked)) < 4 * sd + 1e-9
    assert got.std() > 0            # the pattern turns from pixel to pixel


CORNER = (f"{FLOOR} ∪ paint(0.8, 0.8, 0.8) (move(50.5, 0, 0) uscale(50) cube ∪ "
          "move(0, 50.5, 0) uscale(50) cube)")      # walls x >= 0.5 and y >= 0.5


@pytest.mark.parametrize("kernel", [True, False], ids=["kernel", "model"])
def test_a_concave_corner_is_darker_unless_the_distance_is_too_short(kernel):
    obj = pcsg.loads(CORNER)
    corner = np.tile([0.4, 0.4, 0.0], (200, 1)) + np.linspace(0, 1e-3, 200)[:, None] * [1, 0, 0]
    open_floor = floor_points(-20.0, 200, y=(-20, -2))          # 2.5 from the nearest wall
    near = unoccluded(obj, corner, distance=2.0, kernel=kernel)
    far = unoccluded(obj, open_floor, distance=2.0, kernel=kernel)
    np.testing.assert_array_equal(far, 1.0)
    # two walls 0.1 away cut off a little over half of the cosine-weighted hemisphere
    assert near.mean() < 0.5
    # the walls are 0.1 away: a shorter reach sees nothing
    np.testing.assert_array_equal(unoccluded(obj, corner, distance=0.09, kernel=kernel), 1.0)


def test_kernel_and_model_agree_on_every_point():
    obj = pcsg.loads(CORNER)
    pts = np.column_stack([np.linspace(-0.5, 0.45, 300), np.linspace(0.45, -1, 300),
                           np.zeros(300)])
    np.testing.assert_array_equal(unoccluded(obj, pts, kernel=True),
                                  unoccluded(obj, pts, kernel=False))


def test_occlusion_directive_switches_it_on_and_the_option_wins(tmp_path):
    text = (GRAMMARS / "menger_sponge.pcsg").read_text()
    assert "#occlusion" in text
    plain = tmp_path / "plain.pcsg"
    plain.write_text("\n".join(line for line in text.splitlines()
                               if not line.startswith("#occlusion")))
    outs = {}
    for name, src, extra in [("file", GRAMMARS / "menger_sponge.pcsg", []),
                             ("off", GRAMMARS / "menger_sponge.pcsg", ["--ao", "0"]),
                             ("plain", plain, []), ("plain_on", plain, ["--ao", "8"])]:
        out = tmp_path / f"{name}.png"
        assert main(["render", str(src), "-o", str(out), "--size", "48x36", "-q",
                     "--no-adaptive", *extra]) == 0
        outs[name] = out.read_bytes()
    assert outs["off"] == outs["plain"]
    assert outs["file"] != outs["plain"]
    assert outs["plain_on"] != outs["plain"]


@pytest.mark.parametrize("args", [["--ao", "-1"], ["--ao", "1025"], ["--ao-distance", "0"],
                                  ["--ao-distance", "-2"], ["--ao-distance", "nan"]])
def test_bad_ao_options_are_usage_errors(capsys, args):
    assert main(["render", str(GRAMMARS / "sierpinski.pcsg"), *args]) == 2
    assert args[0] in capsys.readouterr().err
