"""How the kernels are compiled: on a frame stack of their own (trace/compilestack.py),
with one copy of an inlined callee's scope per call site (trace/inlinecopy.py), a
callee's untyped passes once per compile however many its sites (trace/inlinepasses.py),
SSA rewritten block by block where a variable is named (trace/ssablocks.py), live
variables found on bit sets (trace/livebits.py), the packet trace, the largest kernel,
once per render and not once more for a literal, a person at a terminal told when a
render is about to compile them, and SIGTERM not held by a compile (trace/compiling.py)."""
import copy
import operator
import os
import re
import resource
import subprocess
import sys
import time

import numpy as np
import pytest
from numba import njit, types
from numba.core import analysis, inline_closurecall, ir, ssa
from numba.core.compiler import run_frontend
from numba.core.dispatcher import Dispatcher

import pcsg
from pcsg.trace import (compilestack, compiling, dispatch, inlinecopy, inlinepasses,
                        livebits, nodes, packet, ssablocks, windows)
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
    compile_ = Dispatcher.compile
    while hasattr(compile_, "__wrapped__"):     # the wrappers that count and share
        compile_ = compile_.__wrapped__
    assert compile_ is compilestack.compile_on_own_stack

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
    inlinecopy._memos.stack = [inlinecopy._Site()]
    try:
        first = [inlinecopy._Copy.deepcopy(b) for b in blocks]
        again = [inlinecopy._Copy.deepcopy(b) for b in blocks]
        # numba's copy of its copy, which its callers do not read: not made under 0.68
        kept = [inlinecopy._Copy.deepcopy(b) for b in first]
    finally:
        inlinecopy._memos.stack = []
    assert all(k is b for k, b in zip(kept, first))
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


def _translations(monkeypatch):
    """The functions the inliner runs the untyped passes of, as it runs them."""
    names = []
    run = inline_closurecall.InlineWorker.run_untyped_passes

    def counted(self, func, enable_ssa=False):
        names.append(func.__name__)
        return run(self, func, enable_ssa)
    monkeypatch.setattr(inline_closurecall.InlineWorker, "run_untyped_passes", counted)
    return names


@njit(inline="always")
def _inner(x, k):
    return x * k if x > k else x - k


@njit(inline="always")
def _middle(x):
    return _inner(x, 1.0) + _inner(x, 2.0)


def _outer(a):
    s = 0.0
    for v in a:
        s += _middle(v) - 2.0 * _middle(v + 1.0)
    return s + _middle(s)


def test_a_callee_inlined_at_many_sites_is_translated_once_per_compile(monkeypatch):
    assert inline_closurecall.InlineWorker.inline_function is inlinepasses.inline_function
    a = np.linspace(-1.0, 3.0, 9)
    want = _outer(a)            # _middle compiled alone from Python, before the count
    translated = _translations(monkeypatch)
    assert njit(_outer)(a) == want
    assert sorted(translated) == ["_inner", "_middle"]
    assert compiling.this_compile() is None         # it lasts one compile
    # numba's own: _middle at its 3 sites, and _inner at its 2 in each of those
    translated.clear()
    monkeypatch.setattr(inline_closurecall.InlineWorker, "inline_function",
                        inlinepasses.NUMBA_INLINE_FUNCTION)
    assert njit(_outer)(a) == want
    assert sorted(translated) == ["_inner"] * 6 + ["_middle"] * 3


def _llvm_of_box_window():
    window = njit(error_model="numpy")(windows.box_window.py_func)    # slabs, _slab inlined
    boxes = np.array([[-1.0, -2.0, -3.0, 1.0, 2.0, 3.0]])
    F = np.zeros((1, nodes.INV + 3))
    F[0, nodes.OX:nodes.OX + 3] = [-5.0, 0.5, 0.25]
    F[0, nodes.INV:nodes.INV + 3] = [1.0, np.inf, np.inf]      # along x
    assert window(boxes, 0, F, 0) == (4.0, 6.0)
    # the unique ids numba numbers functions and inlined variables by, which differ
    # between any two compiles
    llvm = window.inspect_llvm(window.signatures[0])
    return re.sub(r"B\d+v\d+", "BvN", re.sub(r"_v\d+", "_vN", llvm))


def test_a_kernel_function_compiled_with_translations_shared_is_numbas_code(monkeypatch):
    translated = _translations(monkeypatch)
    ours = _llvm_of_box_window()
    assert len(translated) == 2
    monkeypatch.setattr(inline_closurecall.InlineWorker, "inline_function",
                        inlinepasses.NUMBA_INLINE_FUNCTION)
    theirs = _llvm_of_box_window()
    assert len(translated) == 2 + 4             # _slab at each of slabs' three sites
    assert "slabs_vN__slab_vN_t0" in ours and ours == theirs


FACTOR = 2.0


@njit(inline="always")
def _by_factor(x):
    return x * FACTOR


def test_a_later_compile_translates_again_and_reads_the_globals_then(monkeypatch):
    """The translation a compile shares is of the globals at its time: a process-wide one
    would give a later compile the old value."""
    def twice(x):
        return _by_factor(x) + _by_factor(1.0)
    assert njit(twice)(3.0) == 8.0
    monkeypatch.setattr(sys.modules[__name__], "FACTOR", 10.0)
    assert njit(twice)(3.0) == 40.0


def _statements(blocks):
    return [(label, [str(stmt) for stmt in blk.body]) for label, blk in blocks.items()]


def _variables(blocks):
    return sorted(next(iter(blocks.values())).scope.localvars._con) if blocks else []


def _numbas_and_ours(blocks):
    """numba's SSA reconstruction and ssablocks' of the same IR, each on a copy: their
    statements and the variables in the scope."""
    theirs = ssablocks.NUMBA_RUN_SSA(copy.deepcopy(blocks))
    ours = ssablocks.run_ssa(copy.deepcopy(blocks))
    return (_statements(theirs), _variables(theirs)), (_statements(ours), _variables(ours))


def test_ssa_of_every_kernel_function_is_numbas_statement_for_statement():
    assert ssa._run_ssa is ssablocks.run_ssa
    rewritten = 0
    for d in dispatch._deferred_all:
        blocks = run_frontend(d.py_func).blocks
        theirs, ours = _numbas_and_ours(blocks)
        assert ours == theirs, d.__qualname__
        if ours[1] != _variables(blocks):
            rewritten += 1
            # as numba's, every block given anew (the statements it leaves are shared)
            given = copy.deepcopy(blocks)
            out = ssablocks.run_ssa(given)
            assert not {id(b) for b in out.values()} & {id(b) for b in given.values()}
    # most assign some variable more than once, which the rewrite renames
    assert rewritten > 50


def _two_products(c, n):
    p = n
    u = n           # a variable numba rewrites between p and w: the order that shows it
    w = n
    if c:
        p = n + 1
        u = 2
        w = 5
    if n > 3:
        a = p * w
        w = a
    else:
        a = 0
    b = p * w
    return a + b


def test_ir_whose_statements_share_an_expression_is_rewritten_as_numba_does():
    """One expression object as the value of two statements: numba's rewrite reads its
    operands once, in the pass that first visits it, which a rewrite that skips blocks
    would read later (it then lacks a phi that numba puts in); such IR goes to numba's."""
    blocks = run_frontend(_two_products).blocks
    products = [stmt for blk in blocks.values() for stmt in blk.body
                if isinstance(stmt, ir.Assign) and isinstance(stmt.value, ir.Expr)
                and stmt.value.op == "binop" and stmt.value.fn is operator.mul]
    assert len(products) == 2
    products[1].value = products[0].value
    theirs, ours = _numbas_and_ours(blocks)
    assert ours == theirs


def test_another_numba_keeps_its_own_ssa_and_live_variables(monkeypatch):
    """Both follow numba 0.68's functions; what another numba does is its own."""
    import numba
    monkeypatch.setattr(numba, "__version__", "0.69.0")
    monkeypatch.setattr(ssa, "_run_ssa", ssablocks.NUMBA_RUN_SSA)
    monkeypatch.setattr(analysis, "compute_live_map", livebits.NUMBA_LIVE_MAP)
    monkeypatch.setattr(inline_closurecall.InlineWorker, "inline_function",
                        inlinepasses.NUMBA_INLINE_FUNCTION)
    ssablocks.install()
    livebits.install()
    inlinepasses.install()
    assert ssa._run_ssa is ssablocks.NUMBA_RUN_SSA
    assert analysis.compute_live_map is livebits.NUMBA_LIVE_MAP
    assert inline_closurecall.InlineWorker.inline_function is \
        inlinepasses.NUMBA_INLINE_FUNCTION


def _live_maps(blocks):
    """numba's map of live variables and livebits' for the same IR."""
    cfg = analysis.compute_cfg_from_blocks(blocks)
    usedefs = analysis.compute_use_defs(blocks)
    theirs = livebits.NUMBA_LIVE_MAP(cfg, blocks, usedefs.usemap, usedefs.defmap)
    ours = livebits.compute_live_map(cfg, blocks, usedefs.usemap, usedefs.defmap)
    return (list(theirs), theirs), (list(ours), ours)


def test_the_live_variables_of_every_kernel_function_are_numbas():
    assert analysis.compute_live_map is livebits.compute_live_map
    live = 0
    for d in dispatch._deferred_all:
        blocks = run_frontend(d.py_func).blocks
        for ir_ in (blocks, ssablocks.run_ssa(copy.deepcopy(blocks))):
            theirs, ours = _live_maps(ir_)
            assert ours == theirs, d.__qualname__
            live += sum(map(len, ours[1].values()))
    assert live > 10_000


def test_a_compile_with_inlined_steps_finds_ssa_and_live_variables_as_numba_does(monkeypatch):
    """In a compile, after the per-node steps are inlined, where the rewrites matter."""
    compared = []

    def both_ssas(blocks):
        theirs, ours = _numbas_and_ours(blocks)
        compared.append(ours == theirs)
        return ssablocks.run_ssa(blocks)

    def both_maps(cfg, blocks, usemap, defmap):
        theirs, ours = _live_maps(blocks)
        compared.append(ours == theirs)
        return ours[1]

    monkeypatch.setattr(ssa, "_run_ssa", both_ssas)
    monkeypatch.setattr(analysis, "compute_live_map", both_maps)
    window = njit(error_model="numpy")(windows.box_window.py_func)    # slabs, _slab inlined
    boxes = np.array([[-1.0, -2.0, -3.0, 1.0, 2.0, 3.0]])
    F = np.zeros((1, nodes.INV + 3))
    F[0, nodes.OX:nodes.OX + 3] = [-5.0, 0.5, 0.25]
    F[0, nodes.INV:nodes.INV + 3] = [1.0, np.inf, np.inf]      # along x
    assert window(boxes, 0, F, 0) == windows.box_window(boxes, 0, F, 0) == (4.0, 6.0)
    assert len(compared) > 10 and all(compared)


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


def test_sigterm_during_the_first_compile_ends_the_render_at_once(tmp_path):
    """A render's first call of a kernel compiles it, for minutes, on the helper thread
    that calls it, which reads no stop flag: SIGTERM and Ctrl-C waited for the compile
    to end (125 s), where the command should end at once (trace/compiling.py)."""
    cold = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "empty"))
    proc = subprocess.Popen([sys.executable, "-m", "pcsg", "render",
                             "grammars/sierpinski.pcsg", "--size", "8x6",
                             "-o", str(tmp_path / "s.png")],
                            env=cold, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    time.sleep(3)           # imports, the file, and into the compile of the walks
    proc.terminate()
    try:
        _, err = proc.communicate(timeout=30)
    finally:
        proc.kill()
    assert proc.returncode == 143 and b"pcsg: terminated (SIGTERM)" in err, err
    assert b"Traceback" not in err and not (tmp_path / "s.png").exists()


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
