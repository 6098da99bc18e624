"""Properties only whole processes show: repeatable at any thread count, and a
second start loads the compiled kernels instead of compiling them."""
import os
import subprocess
import sys

from .conftest import ROOT

PROBE = """
import hashlib, numpy as np, pcsg
from pcsg.render.camera import make_camera
from pcsg.trace.kernel import trace_share
obj = pcsg.load("grammars/{name}.pcsg", **{overrides})
cam = make_camera(obj, 4 / 3)
ys, xs = np.mgrid[0:48, 0:64]
o, d = cam.rays(64, 48, xs.ravel() + 0.5, ys.ravel() + 0.5)
h = obj.trace(o, d)
digest = hashlib.sha256(h.t.tobytes() + h.normal.tobytes() + h.paint.tobytes()).hexdigest()
print(digest, sum(trace_share.stats.cache_hits.values()),
      sum(trace_share.stats.cache_misses.values()))
"""


def probe(threads, name="sierpinski", overrides="{'c': 5}"):
    env = {**os.environ, "NUMBA_NUM_THREADS": str(threads)}
    r = subprocess.run([sys.executable, "-c", PROBE.format(name=name, overrides=overrides)],
                       cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    digest, hits, misses = r.stdout.split()
    return digest, int(hits), int(misses)


def test_same_results_at_one_and_two_threads_and_no_compile_on_second_start():
    probe(2)                                   # may compile and fill the cache
    two = probe(2)
    one = probe(1)
    assert one[0] == two[0]
    assert two[2] == 0 and two[1] >= 1, f"the second start compiled (hits, misses) = {two[1:]}"


def test_tree_with_csg_leaves_is_repeatable_across_threads():
    assert probe(1, "sympodial_tree", "{'cnt': 4}")[0] == probe(2, "sympodial_tree",
                                                               "{'cnt': 4}")[0]


def test_ambient_occlusion_png_is_the_same_at_one_and_two_threads(tmp_path):
    """The hemisphere pattern turns by a hash of the pixel and sample, never of the
    thread: the PNG bytes do not depend on how rows are shared out."""
    pngs = []
    for threads in (1, 2):
        out = tmp_path / f"t{threads}.png"
        env = {**os.environ, "NUMBA_NUM_THREADS": str(threads)}
        r = subprocess.run([sys.executable, "-m", "pcsg", "render",
                            "grammars/menger_sponge.pcsg", "--set", "c=2", "--size", "80x60",
                            "--ao", "8", "-o", str(out), "-q"],
                           cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
        assert r.returncode == 0, r.stderr
        pngs.append(out.read_bytes())
    assert pngs[0] == pngs[1]


PRELOAD = """
import sys
from pcsg.cli import main
from pcsg.render import preload
from pcsg.render.camera import _rays
from pcsg.render.image import _gather
from pcsg.trace.shading import shade_share
assert preload.cached(), "the warm-up render left no cached shading kernel"
loading = preload.start()
assert loading is not None
loading.join()
compiled = (shade_share, _rays, _gather)
loaded = [len(f.signatures) for f in compiled]
main(["render", "grammars/sympodial_tree.pcsg", "--set", "cnt=3", "--size", "16x12", "-q",
      "-o", sys.argv[1]])
print(",".join(map(str, loaded)), ",".join(str(len(f.signatures)) for f in compiled),
      sum(sum(f.stats.cache_misses.values()) for f in compiled), preload.start() is None)
"""


def test_the_preloaded_kernel_is_the_one_the_render_uses(tmp_path):
    """render_file loads the shading kernel, the camera rays and the gather into pixels on
    a second thread while the file compiles, by rendering a sphere built without the
    parser: their types must be every render's, or the render would load (or compile)
    other versions after them."""
    warm = subprocess.run([sys.executable, "-m", "pcsg", "render", "grammars/sierpinski.pcsg",
                           "--set", "c=1", "--size", "8x6", "-q", "-o", str(tmp_path / "w.png")],
                          cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert warm.returncode == 0, warm.stderr
    r = subprocess.run([sys.executable, "-c", PRELOAD, str(tmp_path / "t.png")], cwd=ROOT,
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    preloaded, after, misses, again = r.stdout.splitlines()[-1].split()
    assert preloaded == "1,1,1", "the preload left a function unloaded"
    assert after == "1,1,1", "the render needed another version than the preload's"
    assert misses == "0", "the preload compiled instead of loading"
    assert again == "True", "a second start loads the kernel again"
    assert (tmp_path / "t.png").stat().st_size > 0
