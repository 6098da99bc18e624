"""The bench's other POV-Ray peer (tools/bench.py, MACROS): the objects built by
recursive macros in POV-Ray's own language (tools/pov/), as a POV-Ray user writes them.
Where a macro builds the grammar's object, POV-Ray's picture of it is pcsg's."""
import importlib.util
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from pcsg.cli import main

ROOT = Path(__file__).resolve().parent.parent
POVRAY = shutil.which("povray")
SIZE = "160x120"
pytestmark = pytest.mark.skipif(POVRAY is None,
                                reason="POV-Ray is not installed (apt-get install povray)")


def bench():
    spec = importlib.util.spec_from_file_location("bench", ROOT / "tools" / "bench.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def macro_picture(tmp_path, grammar, param, order) -> np.ndarray:
    """POV-Ray's picture of the macro scene, with the camera, lights and sky of the scene
    `pcsg export --pov` writes, as the bench builds it."""
    b = bench()
    exported = tmp_path / "exported.pov"
    assert main(["export", str(ROOT / "grammars" / f"{grammar}.pcsg"), "--set",
                 f"{param}={order}", "--pov", str(exported), "--size", SIZE,
                 "--shadow-samples", "1"]) == 0
    scene = b.write_macro_scene(b.MACROS[(grammar, param)][0], order, exported,
                                tmp_path / f"macros{order}.pov")
    png = tmp_path / f"macros{order}.png"
    w, h = SIZE.split("x")
    subprocess.run([POVRAY, f"+I{scene}", f"+O{png}", f"+W{w}", f"+H{h}", "-D", "-A", "+WT2",
                    "-GA"], check=True, capture_output=True, timeout=300)
    return np.asarray(Image.open(png).convert("RGB"), float)


@pytest.mark.parametrize("grammar,param,order", [("sierpinski", "c", 3),
                                                 ("sympodial_tree", "cnt", 4)])
def test_the_macro_builds_the_grammars_object(tmp_path, grammar, param, order):
    a = macro_picture(tmp_path, grammar, param, order)
    assert main(["render", str(ROOT / "grammars" / f"{grammar}.pcsg"), "--set",
                 f"{param}={order}", "-o", str(tmp_path / "pcsg.png"), "--size", SIZE,
                 "--shadow-samples", "1", "--no-adaptive", "-q"]) == 0
    b = np.asarray(Image.open(tmp_path / "pcsg.png").convert("RGB"), float)
    d = np.abs(a - b).max(axis=2)
    # the tolerance of tests/test_povray.py: shading models differ a little, edges alias
    assert d.mean() < 12 and (d > 48).mean() < 0.04, (d.mean(), (d > 48).mean())
    assert np.abs(a[:, ::-1] - b).max(axis=2).mean() > d.mean() + 3


def test_the_terrain_macro_subdivides(tmp_path):
    """The terrain's macro cannot compute the grammar's rand(seed) (see the head of its
    file), so its island has another shape: checked to parse, and to draw a finer
    terrain at a higher order."""
    two = macro_picture(tmp_path, "carpenter_terrain", "cnt", 2)
    three = macro_picture(tmp_path, "carpenter_terrain", "cnt", 3)
    assert (np.abs(two - three).max(axis=2) > 24).mean() > 0.005
