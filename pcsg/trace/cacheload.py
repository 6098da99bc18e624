"""Kernels loaded from numba's cache without setting up numba's compiler first.

numba's `Cache.load_overload` refreshes the target context before it loads: it imports
and installs every registry of typing templates and lowerings (numpy, linalg, the typed
containers, ...). A compile needs them; a cached kernel is machine code, and it needs
only the symbols it links to: numba's C helpers and exception classes, which the context
installs when it is made, and the reference-counting runtime (NRT), which the refresh
initialises and so is initialised here. numba refreshed 265 times in a render of
Sierpinski, the first time importing and installing everything; without it the wall time
of `pcsg render` fell by 0.09 to 0.13 s (README, "Against POV-Ray"). A kernel that is not
cached still compiles as before: numba's compiler refreshes both contexts itself
(`CompilerBase.__init__`).

With a numba whose cache lacks the two methods used here, numba's own load stays."""
from __future__ import annotations

from numba.core.caching import Cache

NUMBA_LOAD = Cache.load_overload        # kept for the test that compares the two


def load_overload(self, sig, target_context):
    from numba.core.runtime import nrt
    nrt.rtsys.initialize(target_context)
    with self._guard_against_spurious_io_errors():
        return self._load_overload(sig, target_context)


def install() -> None:
    if hasattr(Cache, "_load_overload") and hasattr(Cache, "_guard_against_spurious_io_errors"):
        Cache.load_overload = load_overload
