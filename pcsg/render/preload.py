"""The shading kernel loaded from numba's cache on a second thread while the file
compiles. Loading it is mostly LLVM parsing the kernel's bitcode (about a megabyte),
which releases the GIL: some 50 ms that otherwise stand between the compile and the
first ray of every `pcsg render`.

Nothing is loaded unless the cache holds the kernel: compiling it would take minutes,
and whoever waits for the thread (a file that fails to parse) would wait for that."""
from __future__ import annotations

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


def cached() -> bool:
    """Whether numba's cache has an index for the shading kernel (the kernel guard in
    trace/__init__.py removes it whenever a kernel source changes)."""
    from ..trace import _cache_dirs, shading
    from pathlib import Path
    here = Path(shading.__file__).resolve().parent
    return any(any(d.glob("shading.shade_share-*.nbi")) for d in _cache_dirs(here))


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
