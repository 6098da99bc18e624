"""How the kernels are compiled: on a frame stack of their own (trace/compilestack.py),
and the packet trace, the largest kernel, once per render, not once more for a literal."""
import resource

import numpy as np
from numba import njit, types

import pcsg
from pcsg.trace import compilestack, packet
from pcsg.trace.jit import kernel
from pcsg.render.camera import make_camera
from pcsg.render.shade import make_lighting, shade


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
    from numba.core.dispatcher import Dispatcher
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
    index = packet.trace._cache._cache_file._load_index()
    signatures = [key[0] for key in index]
    assert signatures
    literal = [sig for sig in signatures if any(isinstance(t, types.Literal) for t in sig)]
    assert literal == []
