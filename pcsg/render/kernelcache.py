"""Whether the tracing kernels are in numba's cache, and the notice for a render that
will compile them first.

A render loads its kernels from the cache where it first calls them. Until 2026-12-04 a
second thread loaded the shading kernel (by rendering a sphere at 2x2 pixels) while the
file compiled; once a cached kernel no longer had its bitcode parsed (trace/cacheload.py),
that thread's work, which held the interpreter's lock, delayed the compile by more than
the load it saved: without it the terrain at 9 took 0.863 s against 0.878 s, Sierpinski
at 8 0.394 s against 0.405 s, the tree at 14 0.386 s against 0.393 s (medians of 10
alternating renders each, the same PNG bytes)."""
from __future__ import annotations

import sys


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
