"""Notation §8: `paint(r, g, b)` colours its operand, `material(NAME)` gives it a finish,
and the innermost one wins: a material with a `color=` of its own colours over a paint
outside it; one without keeps the paint. Paint outside used to win whatever the nesting."""
import numpy as np
import pytest

from pcsg.compiler import compile_text
from pcsg.render.camera import finite_bounds
from pcsg.tracer import Traced

from .oracle import assert_agrees, camera_rays

MATERIALS = "#material gold color=(0.9, 0.7, 0.1) specular=0.8\n#material matte diffuse=0.9\n"
GOLD = (0.9, 0.7, 0.1)


def first_hit(body: str):
    traced = Traced(compile_text(MATERIALS + body, "t.pcsg"))
    hits = traced.trace(np.array([[0.0, -5.0, 0.0]]), np.array([[0.0, 1.0, 0.0]]))
    assert hits.hit[0]
    return tuple(hits.paint[0]), traced.material_names[hits.material[0]] \
        if hits.material[0] >= 0 else None


@pytest.mark.parametrize("body, paint, material", [
    ("paint(1, 0, 0) material(gold) sphere\n", GOLD, "gold"),          # the material inside
    ("material(gold) paint(1, 0, 0) sphere\n", (1.0, 0.0, 0.0), "gold"),  # the paint inside
    ("paint(1, 0, 0) material(matte) sphere\n", (1.0, 0.0, 0.0), "matte"),  # no colour of its own
    # a paint read from a parameter, which the walk passes and runs only at a hit
    ("{k = 0.5} paint(k, 0, 0) move(0, 0, 0) material(gold) sphere\n", GOLD, "gold"),
    ("{k = 0.5} material(gold) move(0, 0, 0) paint(k, 0, 0) sphere\n", (0.5, 0.0, 0.0), "gold"),
    # the innermost of three
    ("paint(0, 1, 0) material(gold) paint(0, 0, 1) sphere\n", (0.0, 0.0, 1.0), "gold"),
])
def test_the_innermost_colours(body, paint, material):
    got_paint, got_material = first_hit(body)
    np.testing.assert_allclose(got_paint, paint)
    assert got_material == material


def test_the_tracer_agrees_with_the_reference_ray_by_ray():
    # a derivation whose levels nest paint and material both ways, through a selection
    text = MATERIALS + (
        "{n = 3} paint(0.2, 0.3, 0.4) S\nS if(n > 0, 2, 1)\n1: S → sphere\n"
        "2: S → {n = n - 1} (material(gold) move(0.9, 0, 0) uscale(0.7) S ∪ "
        "paint(n / 4, 0.5, 0) move(-0.9, 0, 0) uscale(0.7) S ∪ material(matte) move(0, 0, 0.9) "
        "uscale(0.7) paint(1, 0, n / 3) S ∪ "
        # a paint the walks pass and run only at a hit (graph/defer.py), above gold
        "paint(n / 4, 0, 1) move(0, -0.9, 0) material(gold) uscale(0.4) sphere)\n")
    traced = Traced(compile_text(text, "t.pcsg"))
    for direction in ((0, -1, 0.3), (1, 0.2, 0.5), (-0.3, 1, -0.2)):
        o, d = camera_rays(finite_bounds(traced), 24, np.array(direction), spread=0.3)
        got = assert_agrees(traced, o, d, min_hits=50)
        # both nestings are seen: gold's own colour, and paints below gold
        gold = traced.material_names.index("gold")
        colours = {tuple(np.round(p, 6)) for p in got.paint[got.hit & (got.material == gold)]}
        assert GOLD in colours and len(colours) > 1


def test_the_export_paints_with_the_innermost(tmp_path):
    from pcsg.cli import main
    src = tmp_path / "t.pcsg"
    src.write_text(MATERIALS + "paint(1, 0, 0) material(gold) sphere\n", encoding="utf-8")
    assert main(["export", str(src), "--pov", str(tmp_path / "t.pov")]) == 0
    pov = (tmp_path / "t.pov").read_text()
    assert "rgb <0.9, 0.7, 0.1>" in pov and "rgb <1, 0, 0>" not in pov


def test_a_render_shows_the_material_colour(tmp_path):
    from PIL import Image

    from pcsg.cli import main
    src = tmp_path / "t.pcsg"
    src.write_text(MATERIALS + "#camera eye=(0, -5, 0) at=(0, 0, 0)\n"
                   "paint(1, 0, 0) material(gold) sphere\n", encoding="utf-8")
    assert main(["render", str(src), "-o", str(tmp_path / "t.png"), "--size", "40x30",
                 "-q"]) == 0
    r, g, b = Image.open(tmp_path / "t.png").convert("RGB").getpixel((20, 15))
    assert r > g > b and g > 0.5 * r        # gold; red painted over it had g near 0
