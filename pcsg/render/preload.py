"""The shading kernel loaded from numba's cache on a second thread while the file
compiles. Loading it is mostly LLVM linking the kernel's machine code (about 400 KB),
which releases the GIL: some 20 ms (50 ms while numba parsed its bitcode too, see
trace/cacheload.py) that otherwise stand between the compile and the first ray of every
`pcsg render`.

Nothing is loaded unless the cache holds the kernel: compiling it would take minutes,
and whoever waits for the thread (a file that fails to parse) would wait for that."""
from __future__ import annotations

import sys
import threading


def start() -> threading.Thread | None:
    """The loading thread, started; None when there is nothing to load. Join it before
    the process can end: a thread left inside LLVM at exit can crash the interpreter."""
    from ..trace.shading import shade_share
    # no `signatures` under NUMBA_DISABLE_JIT: a plain function, nothing to load
    if getattr(shade_share, "signatures", True) or not cached():
        return None
    thread = threading.Thread(target=_load, name="pcsg-preload", daemon=False)
    thread.start()
    return thread


def compile_notice(quiet: bool) -> str | None:
    """The line for a person at a terminal whose render is about to compile the kernels:
    three minutes or so on two cores, before any progress line can show."""
    if quiet or not sys.stderr.isatty() or cached():
        return None
    return ("pcsg: compiling the tracing kernels, once for this version of pcsg "
            "(about 3 minutes on two cores) ...")


def cached() -> bool:
    """Whether numba's cache has an index for the shading kernel, in the folder numba
    reads (beside the sources, or under NUMBA_CACHE_DIR when that is set; the kernel
    guard in trace/__init__.py empties both whenever a kernel source changes). True
    under NUMBA_DISABLE_JIT: nothing is compiled."""
    from pathlib import Path
    from ..trace.shading import shade_share
    cache = getattr(shade_share, "_cache", None)
    if cache is None:
        return True
    return any(Path(cache.cache_path).glob("shading.shade_share-*.nbi"))


def _load() -> None:
    """Render a sphere at 2x2 pixels, built without the parser (its line joiner keeps
    state, so two threads must not parse at once): the same types as any render's
    calls, hence the same compiled shading kernel, camera rays and gather into pixels.
    The last two are small, but loading each from the cache took 4 ms of the render."""
    from ..graph.expr import ExprTable
    from ..graph.model import PRIMITIVE, Graph, Node, Scene
    from ..language.source import Source
    from ..tracer import Traced
    from .camera import make_camera
    from .image import render_frame
    from .shade import make_lighting
    try:
        graph = Graph(Source("<preload>", "sphere"), [Node(PRIMITIVE, "sphere")], 0, {}, {},
                      ExprTable({}, lambda *_: None), [], Scene(), [])
        traced = Traced(graph)
        camera = make_camera(traced, 1.0)
        render_frame(traced, camera, make_lighting(traced, camera), 2, 2, adaptive=False)
    except Exception:       # only ever a head start: the render loads what it needs itself
        pass
