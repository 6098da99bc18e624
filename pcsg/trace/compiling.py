"""Which threads are in a numba compile now.

A render's first call of a kernel compiles it on the helper thread that calls it, for
minutes on a fresh install. Ctrl-C or SIGTERM then set the walks' stop flag and waited
for every helper to read it, which a compile does not: the command ended only once the
compile had (125 s after a SIGTERM). The waiting side asks here whether a helper is
compiling, and does not wait for one that is (`jit._run_watched`); numba writes a kernel
to its cache whole at the end of its compile, or not at all."""
from __future__ import annotations

import threading

from numba.core.dispatcher import Dispatcher

threads: set[int] = set()


def counted(compile_):
    def compile(self, *args, **kwargs):
        me = threading.get_ident()
        if me in threads:               # a callee's compile inside its caller's
            return compile_(self, *args, **kwargs)
        threads.add(me)
        try:
            return compile_(self, *args, **kwargs)
        finally:
            threads.discard(me)
    compile.__wrapped__ = compile_
    return compile


def install() -> None:
    Dispatcher.compile = counted(Dispatcher.compile)
