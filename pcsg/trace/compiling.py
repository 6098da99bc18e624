"""Which threads are in a numba compile now, and what lasts one compile.

A render's first call of a kernel compiles it on the helper thread that calls it, for
minutes on a fresh install. Ctrl-C or SIGTERM then set the walks' stop flag and waited
for every helper to read it, which a compile does not: the command ended only once the
compile had (125 s after a SIGTERM). The waiting side asks here whether a helper is
compiling, and does not wait for one that is (`jit._run_watched`); numba writes a kernel
to its cache whole at the end of its compile, or not at all.

Each thread's outermost compile (a callee that is not inlined compiles inside its
caller's) also has a dict of its own, dropped when it ends: what may be shared within
one compile but not across two, such as a callee's untyped IR (`inlinepasses`), which
holds the globals the callee read at the time."""
from __future__ import annotations

import threading

import numba
from numba.core.dispatcher import Dispatcher

threads: dict[int, dict] = {}


def numba_followed() -> bool:
    """Whether this is numba 0.68, whose compiler ssablocks, livebits, inlinecopy and
    inlinepasses follow step by step: under another numba they leave it its own way."""
    return numba.__version__.split(".")[:2] == ["0", "68"]


def this_compile() -> dict | None:
    """The dict of the outermost compile this thread is in; None outside one."""
    return threads.get(threading.get_ident())


def tracked(compile_):
    def compile(self, *args, **kwargs):
        me = threading.get_ident()
        if me in threads:
            return compile_(self, *args, **kwargs)
        threads[me] = {}
        try:
            return compile_(self, *args, **kwargs)
        finally:
            del threads[me]
    compile.__wrapped__ = compile_
    return compile


def install() -> None:
    Dispatcher.compile = tracked(Dispatcher.compile)
