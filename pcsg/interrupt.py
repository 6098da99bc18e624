"""Ctrl-C where Python handles it badly: in a finalizer, and inside numba's compiler lock.

In a finalizer: Python cannot raise out of a `__del__` (llvmlite's
and numba's objects have them, and run while kernels load): it prints "Exception ignored
in ..." with a traceback and drops the KeyboardInterrupt, so the command would print a
traceback and go on as if not interrupted. The hook delivers the interrupt again instead,
where the command's own handling takes it. It does so from a thread of its own, once the
hook has returned: raised in the hook, the interrupt would be dropped from the hook in
turn."""
from __future__ import annotations

import _thread
import signal
import sys
import threading


def _hook(unraisable) -> None:
    if unraisable.exc_type is not None and issubclass(unraisable.exc_type, KeyboardInterrupt):
        returned = threading.Event()
        threading.Thread(target=_later, args=(returned,), name="pcsg-interrupt",
                         daemon=True).start()
        returned.set()      # the thread needs the interpreter's lock, which this keeps
        return              # until it has left the hook
    sys.__unraisablehook__(unraisable)


def _later(returned: threading.Event) -> None:
    returned.wait()
    _thread.interrupt_main(signal.SIGINT)


def redeliver_in_finalizers() -> None:
    sys.unraisablehook = _hook


def release_compiler_lock() -> None:
    """Once a KeyboardInterrupt has unwound: numba's global compiler lock, if this thread
    still holds it. numba takes it in a `with` through Python methods
    (`_CompilerLock.__enter__` calls `acquire`), so an interrupt raised as the lock's own
    acquire returns, before the `with` body starts, leaves it held. Every other thread that
    then loads or compiles a kernel (the tracer's helper threads) waits for it forever, and so does the process's exit, which joins them: an
    animate worker interrupted at the wrong moment was seen to hang so, once, in CI."""
    module = sys.modules.get("numba.core.compiler_lock")
    lock = getattr(getattr(module, "global_compiler_lock", None), "_lock", None)
    owned = getattr(lock, "_is_owned", None)
    while owned is not None and owned():
        lock.release()
