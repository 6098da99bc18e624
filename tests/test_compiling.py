"""How the kernels are compiled: on a frame stack of their own (trace/compilestack.py),
with one copy of an inlined callee's scope per call site (trace/inlinecopy.py), the
packet trace, the largest kernel, once per render and not once more for a literal, and
a person at a terminal told when a render is about to compile them."""
import os
import resource
import subprocess
import sys

import numpy as np
import pytest
from numba import njit, types
from numba.core import inline_closurecall
from numba.core.compiler import run_frontend
from numba.core.dispatcher import Dispatcher

import pcsg
from pcsg.trace import compilestack, inlinecopy, packet
from pcsg.trace.dispatch import cached
from pcsg.trace.jit import kernel
from pcsg.render.camera import make_camera
from pcsg.render.shade import make_lighting, shade

from .terminal import on_a_terminal


def _down(d):
    return 0 if d == 0 else _down(d - 1) + 1


def _oscillate(times):
    for _ in range(times):
        _down(400)      # 400 frames: more than one 16 KiB chunk of frame stack


def _faults(fn, *args):
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    fn(*args)
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before


def test_deep_calls_on_their_own_stack_do_not_map_chunks_again_and_again():
    _oscillate(10)
    inside = _faults(compilestack.on_own_stack, _oscillate, 3000)
    outside = _faults(_oscillate, 3000)
    # outside, each descent maps a chunk and touches its pages, each return unmaps it
    # (a Python that keeps its chunks shows few faults either way)
    assert inside < 200
    assert inside < outside / 5 or outside < 200


def test_compiles_go_through_the_own_stack_and_work():
    assert Dispatcher.compile is compilestack.compile_on_own_stack

    @njit
    def inner(x):
        return x * 2.0

    @kernel
    def outer(a):       # a kernel calling another compiles it nested, inside outer's
        s = 0.0
        for v in a:
            s += inner(v)
        return s

    assert outer(np.arange(4.0)) == 12.0


def test_a_shaded_render_compiles_the_packet_trace_without_literal_arguments():
    """Every signature the kernel cache holds for packet.trace, from any run since the
    kernels last changed: an argument typed as a constant (Literal[int](0)) cost a
    second compile of the whole packet walk, minutes on a fresh install."""
    obj = pcsg.load("grammars/carpenter_terrain.pcsg", cnt=2)
    cam = make_camera(obj, 4 / 3)
    light = make_lighting(obj, cam, True, 2, 3, ao=2)
    ys, xs = np.mgrid[0:6, 0:8]
    o, d = cam.rays(8, 6, xs.ravel() + 0.5, ys.ravel() + 0.5)
    rgb, _, hits = shade(obj, light, o, d)
    assert hits.hit.any()
    index = cached(packet.trace)._cache._cache_file._load_index()
    signatures = [key[0] for key in index]
    assert signatures
    literal = [sig for sig in signatures if any(isinstance(t, types.Literal) for t in sig)]
    assert literal == []


def _two_branches(x):
    s = 0
    for i in range(x):
        if i % 2:
            s += i
        else:
            s -= 1
    return s


def test_blocks_copied_at_one_call_site_share_one_copy_of_the_scope():
    blocks = list(run_frontend(_two_branches).blocks.values())
    assert len(blocks) > 3
    inlinecopy._memos.stack = [{}]
    try:
        first = [inlinecopy._Copy.deepcopy(b) for b in blocks]
        again = [inlinecopy._Copy.deepcopy(b) for b in blocks]
    finally:
        inlinecopy._memos.stack = []
    assert len({id(b.scope) for b in first}) == 1
    assert first[0].scope is not blocks[0].scope
    assert first[0].scope.localvars._con.keys() == blocks[0].scope.localvars._con.keys()
    # a second copy of the same blocks shares nothing with the first
    assert len({id(b.scope) for b in again}) == 1
    assert again[0].scope is not first[0].scope
    assert not {id(s) for b in first for s in b.body} & {id(s) for b in again for s in b.body}


def test_a_callee_inlined_at_two_call_sites_computes_as_in_python():
    assert inline_closurecall.InlineWorker.inline_ir is inlinecopy.inline_ir

    @njit(inline="always")
    def step(a, k):
        s = 0.0
        for i in range(a.shape[0]):
            if a[i] > k:
                s += a[i]
            else:
                s -= 1.0
        return s

    @njit
    def twice(a):
        return step(a, 0.5) + 2.0 * step(a, 2.0)

    a = np.linspace(0.0, 3.0, 7)
    # above 0.5: 1 + 1.5 + 2 + 2.5 + 3, less 2; above 2: 2.5 + 3, less 5
    assert twice(a) == twice.py_func(a) == 8.0 + 2.0 * 0.5


NOTICE = b"pcsg: compiling the tracing kernels"


def test_a_person_at_a_terminal_is_told_when_a_render_compiles_the_kernels(tmp_path):
    args = ["render", "grammars/sierpinski.pcsg", "--set", "c=1", "--size", "32x24",
            "-o", str(tmp_path / "s.png")]
    cold = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "empty"))
    assert NOTICE in on_a_terminal(args, cold, NOTICE)
    # the kernels compiled and cached first, if no earlier test did
    subprocess.run([sys.executable, "-m", "pcsg.cli", *args, "-q"], check=True)
    warm = on_a_terminal(args, dict(os.environ), b"rays/s")
    assert b"s.png: 32x24" in warm and NOTICE not in warm
    quiet = on_a_terminal(args + ["-q"], cold, NOTICE, timeout=5.0)
    assert NOTICE not in quiet


@pytest.mark.parametrize("cold", [True, False])
def test_a_render_that_compiled_the_kernels_says_so_in_its_summary(tmp_path, capsys,
                                                                    monkeypatch, cold):
    """A first run's summary charged the three minutes of the compile to the render
    (`barnsley_fern.png: 640x480, 186.97 s, 0.00 M rays/s`) without a word, piped too."""
    from pcsg.cli import main
    from pcsg.render import kernelcache
    monkeypatch.setattr(kernelcache, "cached", lambda: not cold)
    assert main(["render", "grammars/sierpinski.pcsg", "--set", "c=1", "--size", "8x6",
                 "-o", str(tmp_path / "s.png")]) == 0
    out = capsys.readouterr().out
    assert "s.png: 8x6, " in out
    assert ("M rays/s, compiling the kernels included" in out) == cold
