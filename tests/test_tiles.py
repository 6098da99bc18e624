"""Tiles, sweeps and resuming without a cluster: what pcsg.distributed does in one process."""
import json
import re

import numpy as np
import pytest

from pcsg.cli import main
from pcsg.compiler import compile_file
from pcsg.resume import MANIFEST
from pcsg.distributed.sweep import sweep_outputs, sweep_set
from pcsg.distributed.tiles import bands
from pcsg.render.image import pixels
from pcsg.render.job import Options, prepare_scene, render_scene

from .conftest import GRAMMARS

SIERPINSKI = str(GRAMMARS / "sierpinski.pcsg")


def test_bands_cover_the_image_once():
    for h, n in ((48, 5), (48, 48), (7, 3), (1000, 64)):
        b = bands(h, n)
        assert len(b) == n and b[0][0] == 0 and b[-1][1] == h
        assert all(a[1] == c[0] and a[1] > a[0] for a, c in zip(b, b[1:]))


@pytest.mark.parametrize("name", ["sierpinski", "carpenter_terrain", "fractal_garden"])
@pytest.mark.parametrize("kw", [{}, {"samples": 4}, {"alpha": True, "shadow_samples": 2}],
                         ids=["adaptive", "samples4", "alpha"])
def test_bands_have_the_pixels_of_the_whole_image(name, kw):
    # the adaptive pass compares neighbours across band edges: one-row bands are the test
    # that the apron gives every band the neighbours the whole image has
    opts = Options(size=(80, 60), quiet=True, **kw)
    path = GRAMMARS / f"{name}.pcsg"
    scene = prepare_scene(compile_file(path, {}), opts)
    whole = pixels(render_scene(scene, name, opts)[0], opts.alpha)
    for n in (7, 60):
        parts = [pixels(render_scene(scene, name, opts, rows=r)[0], opts.alpha)
                 for r in bands(60, n)]
        assert np.array_equal(np.concatenate(parts), whole), (n, kw)


def test_tiled_png_is_byte_identical_and_leaves_no_scratch_file(capsys, tmp_path):
    assert main(["render", SIERPINSKI, "--size", "64x48", "-o", str(tmp_path / "a.png")]) == 0
    assert main(["render", SIERPINSKI, "--size", "64x48", "-o", str(tmp_path / "b.png"),
                 "--tiles", "5"]) == 0
    assert (tmp_path / "a.png").read_bytes() == (tmp_path / "b.png").read_bytes()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.png", "b.png"]
    assert "[5/5]" in capsys.readouterr().err


def test_sweep_writes_one_image_per_value_and_resumes(capsys, tmp_path):
    out = tmp_path / "sweep"
    args = ["sweep", SIERPINSKI, "--set", "c=1..3", "--size", "48x36", "-o", str(out), "-q"]
    assert main(args) == 0
    names = ["sierpinski_c=1.png", "sierpinski_c=2.png", "sierpinski_c=3.png"]
    assert sorted(p.name for p in out.glob("*.png")) == names
    assert "rendered 3 of 3 images" in capsys.readouterr().out
    for c, name in zip((1, 2, 3), names):        # each as `pcsg render --set c=N` draws it
        single = tmp_path / f"single{c}.png"
        assert main(["render", SIERPINSKI, "--set", f"c={c}", "--size", "48x36",
                     "-o", str(single), "-q"]) == 0
        assert (out / name).read_bytes() == single.read_bytes()
    capsys.readouterr()

    # restarted: all complete; a truncated image and a forged one are rendered again
    good = (out / names[1]).read_bytes()
    (out / names[1]).write_bytes(good[:len(good) // 2])
    (out / names[2]).write_bytes((out / names[0]).read_bytes())
    assert main(args) == 0
    text = capsys.readouterr().out
    assert "rendered 2 of 3 images" in text and "skipped 1 already complete" in text
    assert (out / names[1]).read_bytes() == good
    assert main(args) == 0
    assert "skipped 3" in capsys.readouterr().out

    # other options, other pixels: nothing is skipped; --force renders everything again
    assert main(args[:-1] + ["--samples", "2", "-q"]) == 0
    assert "skipped" not in capsys.readouterr().out
    assert main(args + ["--samples", "2", "--force"]) == 0
    assert "rendered 3 of 3" in capsys.readouterr().out
    assert set(json.loads((out / MANIFEST).read_text())) == set(names)


def test_a_wider_sweep_replaces_the_images_it_names_with_other_digits(capsys, tmp_path):
    """c=1..2 then c=1..11 into one directory left c=1.png and c=2.png beside c=01.png
    and c=02.png, sorted among them (c=09, c=1, c=10). Images of other values, other
    files' and ones no run recorded stay."""
    out = tmp_path / "sweep"
    small = ["--size", "8x6", "-o", str(out)]
    assert main(["sweep", SIERPINSKI, "--set", "c=1..2", *small, "-q"]) == 0
    assert main(["sweep", SIERPINSKI, "--set", "c=7..8", *small, "-q"]) == 0
    (out / "sierpinski_c=3.png").write_bytes(b"not made by a sweep")
    (out / "other_c=1.png").write_bytes(b"another file's")
    capsys.readouterr()
    assert main(["sweep", SIERPINSKI, "--set", "c=1..11..2", *small, "-q"]) == 0
    err = capsys.readouterr().err
    assert "removed 2 images of these values that an earlier sweep named with other " \
           "digits (sierpinski_c=1.png, sierpinski_c=7.png)" in err
    assert sorted(p.name for p in out.glob("*.png")) == [
        "other_c=1.png", "sierpinski_c=01.png", "sierpinski_c=03.png", "sierpinski_c=05.png",
        "sierpinski_c=07.png", "sierpinski_c=09.png", "sierpinski_c=11.png",
        "sierpinski_c=2.png", "sierpinski_c=3.png", "sierpinski_c=8.png"]
    made = json.loads((out / MANIFEST).read_text())
    assert "sierpinski_c=1.png" not in made and "sierpinski_c=8.png" in made


def test_sweep_names_sort_by_value(tmp_path):
    assert [p.name for p in sweep_outputs("g/tree.pcsg", tmp_path, "cnt", [1.0, 10.0, 12.0])] \
        == ["tree_cnt=01.png", "tree_cnt=10.png", "tree_cnt=12.png"]
    assert sweep_set("c=1..12..5") == ("c", [1.0, 6.0, 11.0])
    assert sweep_set("c=3..1") == ("c", [3.0, 2.0, 1.0])
    assert sweep_set("a=0.5") == ("a", [0.5])


@pytest.mark.parametrize("args, message", [
    (["sweep", SIERPINSKI, "--set", "c=1..x"], "a range is A..B"),
    (["sweep", SIERPINSKI, "--set", "c=1..3..0"], "positive STEP"),
    (["sweep", SIERPINSKI, "--set", "c=2"], "one parameter to sweep"),
    (["sweep", SIERPINSKI, "--set", "c=1..2", "--set", "d=1..2"], "one parameter to sweep"),
    (["render", SIERPINSKI, "--tiles", "0"], "--tiles 0"),
    (["render", SIERPINSKI, "--size", "64x48", "--tiles", "49"], "--tiles 49"),
    (["render", SIERPINSKI, "--tiles", "4", "--depth", "d.npy"], "not written for tiled"),
    (["render", SIERPINSKI, "--workers", "2", "--scheduler", "tcp://x:1"], "give one of them"),
    (["render", SIERPINSKI, "--workers", "0"], "--workers 0"),
])
def test_usage_errors(capsys, args, message):
    try:
        code = main(args)
    except SystemExit as e:         # argparse's own: a --set that is no range
        code = e.code
    assert code == 2
    assert message in capsys.readouterr().err


def test_cluster_options_without_dask_say_how_to_install_it(capsys, monkeypatch, tmp_path):
    monkeypatch.setitem(__import__("sys").modules, "distributed", None)   # import fails
    assert main(["render", SIERPINSKI, "--workers", "2", "-o", str(tmp_path / "x.png")]) == 2
    # from the checkout: `pip install 'pcsg[dask]'` named another project on PyPI
    said = capsys.readouterr().err
    assert "pip install '/path/to/pcsg[dask]', the path of pcsg's checkout" in said
    assert not (tmp_path / "x.png").exists()


def test_an_output_that_cannot_be_written_fails_alone(capsys, tmp_path):
    out = tmp_path / "sweep"
    out.mkdir()
    # a link into a directory that is not there, where the image should go (a directory
    # there is refused before anything renders)
    (out / "sierpinski_c=2.png").symlink_to(tmp_path / "gone" / "c2.png")
    code = main(["sweep", SIERPINSKI, "--set", "c=1..3", "--size", "32x24", "-o", str(out),
                 "-q", "--tiles", "3"])
    captured = capsys.readouterr()
    assert code == 1
    assert "rendered 2 of 3 images" in captured.out and "failed: sierpinski_c=2.png" in \
        captured.out
    assert (out / "sierpinski_c=3.png").is_file()
    assert [p.name for p in out.glob(".*")] == [MANIFEST]     # no scratch file left


def test_a_band_that_fails_ends_its_image(capsys, tmp_path):
    """--tiles 4 --timeout: the bands after the one that ran out of time were rendered
    all the same, and said so after "nothing written"."""
    out = tmp_path / "t.png"
    assert main(["render", str(GRAMMARS / "sympodial_tree.pcsg"), "-o", str(out), "--size",
                 "160x120", "--tiles", "4", "--timeout", "0.000001"]) == 1
    err = capsys.readouterr().err
    said = err.index("stopped by --timeout")
    assert "nothing written" in err[said:] and not out.exists()
    assert not re.search(r"\[\d/4\]", err[said:]), err
