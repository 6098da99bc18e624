"""numba's compiles, each run on a Python frame stack of its own.

CPython 3.11 keeps a thread's Python frames in chunks of 16 KiB: a call that does not
fit in the current chunk maps a new one, and its return unmaps it. numba's compiler
recurses deep and back, across a chunk's end, millions of times: compiling the
render's kernels made 32 million page faults and spent as long in the system as in
the compiler (238 s of 514 s; README, "Compiling the kernels"). A compile here runs
under one frame of 2 MiB, which starts a chunk of 4 MiB (chunks double from 16 KiB to
fit a frame), and the compiler's own frames fill the other half, never crossing a
chunk's end. The stack slots of that frame are never written, so the pages stay
unmapped memory. A Python that keeps its frames otherwise pays one large frame per
compile, nothing more."""
from __future__ import annotations

import types

from numba.core.dispatcher import Dispatcher

NUMBA_COMPILE = Dispatcher.compile
SPARE_SLOTS = 1 << 18   # the frame's 2 MiB: its chunk is 4 MiB, 2 MiB left for the compiler


def _call(fn, *args, **kwargs):
    return fn(*args, **kwargs)


on_own_stack = types.FunctionType(
    _call.__code__.replace(co_stacksize=_call.__code__.co_stacksize + SPARE_SLOTS + 64),
    _call.__globals__, "on_own_stack")
on_own_stack.__doc__ = "fn(*args, **kwargs), under a frame that starts a chunk of its own."


def compile_on_own_stack(self, *args, **kwargs):
    return on_own_stack(NUMBA_COMPILE, self, *args, **kwargs)


def install() -> None:
    Dispatcher.compile = compile_on_own_stack
