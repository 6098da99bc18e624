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


LOADED = """
import sys
from pcsg.cli import main
from pcsg.render import kernelcache
from pcsg.render.camera import _rays
from pcsg.render.image import _gather
from pcsg.trace.shading import shade_share
kernelcache.load()
compiled = (shade_share, _rays, _gather)
loaded = [len(f.signatures) for f in compiled]
main(["render", "grammars/sympodial_tree.pcsg", "--set", "cnt=3", "--size", "16x12", "-q",
      "-o", sys.argv[1]])
print(",".join(map(str, loaded)), ",".join(str(len(f.signatures)) for f in compiled),
      sum(sum(f.stats.cache_misses.values()) for f in compiled))
"""


def test_the_kernels_loaded_before_the_render_are_the_ones_it_uses(tmp_path):
    """render_file loads the shading kernel, the camera rays and the gather into pixels
    by the signatures in numba's cache index before its render phase starts: they must be
    every render's, or the render would load (or compile) other versions after them."""
    warm = subprocess.run([sys.executable, "-m", "pcsg", "render", "grammars/sierpinski.pcsg",
                           "--set", "c=1", "--size", "8x6", "-q", "-o", str(tmp_path / "w.png")],
                          cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert warm.returncode == 0, warm.stderr
    r = subprocess.run([sys.executable, "-c", LOADED, str(tmp_path / "t.png")], cwd=ROOT,
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    loaded, after, misses = r.stdout.splitlines()[-1].split()
    assert all(int(n) >= 1 for n in loaded.split(",")), "a kernel was left unloaded"
    assert after == loaded, "the render needed another version than the ones loaded"
    assert misses == "0", "a kernel was compiled instead of loaded"
    assert (tmp_path / "t.png").stat().st_size > 0


CACHED = """
from pcsg.render import kernelcache
print(kernelcache.cached())
"""


def test_a_render_finds_the_kernels_cached_after_the_first(tmp_path):
    """kernelcache.cached(), which decides whether a render at a terminal first says that
    it will compile the kernels: true once a render has compiled them, false where numba
    keeps no kernel yet (an empty NUMBA_CACHE_DIR)."""
    warm = subprocess.run([sys.executable, "-m", "pcsg", "render", "grammars/sierpinski.pcsg",
                           "--set", "c=1", "--size", "8x6", "-q", "-o", str(tmp_path / "w.png")],
                          cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert warm.returncode == 0, warm.stderr

    def cached(**env):
        r = subprocess.run([sys.executable, "-c", CACHED], cwd=ROOT, capture_output=True,
                           text=True, timeout=600, env={**os.environ, **env})
        assert r.returncode == 0, r.stderr
        return r.stdout.split()[-1]
    assert cached() == "True"
    assert cached(NUMBA_CACHE_DIR=str(tmp_path / "empty")) == "False"
