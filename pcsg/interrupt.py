"""Ctrl-C where Python handles it badly: in a finalizer, and inside numba's compiler lock;
and SIGTERM and SIGHUP handled as Ctrl-C is.

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
        # a SIGTERM or SIGHUP (Terminated) is delivered again as itself: as Ctrl-C, the
        # command said "interrupted" and exited with 130
        signum = getattr(unraisable.exc_value, "signum", signal.SIGINT)
        returned = threading.Event()
        threading.Thread(target=_later, args=(returned, signum), name="pcsg-interrupt",
                         daemon=True).start()
        returned.set()      # the thread needs the interpreter's lock, which this keeps
        return              # until it has left the hook
    if _closed_twice(unraisable):
        return
    sys.__unraisablehook__(unraisable)


def _closed_twice(unraisable) -> bool:
    """llvmlite's ObjectRef.__del__ run again on a reference whose close an interrupt cut
    short (in an animate worker stopped as kernels load): it fails on the attribute its
    first close removed, and nothing is left to free; the traceback was noise beside the
    command's own 'interrupted'."""
    return (unraisable.exc_type is AttributeError
            and getattr(unraisable.object, "__qualname__", "") == "ObjectRef.__del__"
            and "_as_parameter_" in str(unraisable.exc_value))


def _later(returned: threading.Event, signum: int) -> None:
    global _terminating
    returned.wait()
    if signum != signal.SIGINT:
        _terminating = False        # the first was lost in the finalizer: not a second one
    _thread.interrupt_main(signum)


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


class Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP (`kill`, `timeout`, a scheduler, a closed terminal), raised where
    Ctrl-C's KeyboardInterrupt is and handled as it is: the walk or render stops, what is
    being written is removed, manifests are saved. Killed outright, the command left the
    hidden `.NAME.part` file it was writing (an export's, gigabytes), and animate's
    workers told of leaked semaphores."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum

    @property
    def exit_status(self) -> int:
        return 128 + self.signum


_terminating = False


def _terminate(signum, frame) -> None:
    # once: a second SIGTERM (`timeout` signals the group, then the user the command)
    # raised inside the first one's clean-up cut it short, and animate then waited for
    # ever on a worker that no one had told to stop
    global _terminating
    if _terminating:
        return
    _terminating = True
    raise Terminated(signum)


TERMINATIONS = (signal.SIGTERM, signal.SIGHUP)     # handled as Ctrl-C is
STOPS = (signal.SIGINT, *TERMINATIONS)


def terminate_as_interrupt() -> None:
    """The console command's (never the API's: a library leaves a program's signals
    alone)."""
    take_unless_ignored(TERMINATIONS, _terminate)


def take_unless_ignored(signums, handler) -> None:
    """handler for each signal, but one that was ignored when the process started (nohup,
    a parent that chose so) stays ignored."""
    for signum in signums:
        if signal.getsignal(signum) is not signal.SIG_IGN:
            signal.signal(signum, handler)


def tell(text: str) -> None:
    """A line on stderr that may have nowhere to go (SIGHUP: the terminal is gone): what
    follows it (the exit status, a manifest) matters more."""
    try:
        print(text, file=sys.stderr, flush=True)
    except (OSError, ValueError):
        pass
