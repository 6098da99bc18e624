"""The shading kernels loaded from numba's cache before a render's clock starts; whether
they are cached, and the notice for a render that will compile them first.

`load` loads each with every signature numba's cache index holds for it, so that the
render phase, and the rays per second it reports, time tracing only (the shading
kernel's load is about 20 ms). Until 2026-12-04 a second thread loaded it (by rendering a
sphere at 2x2 pixels) while the file compiled; once a cached kernel no longer had its
bitcode parsed (trace/cacheload.py), that thread's work, which held the interpreter's
lock, delayed the compile by more than the load it saved: without it the terrain at 9
took 0.863 s against 0.878 s, Sierpinski at 8 0.394 s against 0.405 s, the tree at 14
0.386 s against 0.393 s (medians of 10 alternating renders each, the same PNG bytes)."""
from __future__ import annotations

import functools
import sys


@functools.cache
def load() -> None:
    """Every cached version of the kernels a render calls, loaded (once a process): a
    kernel not cached, or a numba without the cache index read here, loads or compiles
    where the render first calls it, as before."""
    from ..trace.shading import shade_share
    from .camera import _rays
    from .image import _gather
    for kernel in (shade_share, _rays, _gather):
        for signature in cached_signatures(kernel):
            kernel.compile(signature)


def cached_signatures(kernel) -> list:
    """The signatures numba's cache index holds for `kernel`: none without a cache (or
    under NUMBA_DISABLE_JIT), or with a numba whose cache reads its index otherwise."""
    from ..trace.dispatch import cached
    try:
        return [key[0] for key in cached(kernel)._cache._cache_file._load_index()]
    except AttributeError:
        return []


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
    from ..trace.dispatch import cached
    from ..trace.shading import shade_share
    cache = getattr(cached(shade_share), "_cache", None)
    if cache is None:
        return True
    return any(Path(cache.cache_path).glob("shading.shade_share-*.nbi"))
