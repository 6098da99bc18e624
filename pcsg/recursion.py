"""Python's recursion limit raised for a deep pass, safely across threads.

The limit belongs to the interpreter, not to a thread. Two passes that each saved it,
raised it and put the saved value back could, on two threads, leave one of them running
under the other's lower limit (render_file once bounded a sphere on a second thread
while the file compiled). So the passes inside are counted, the limit is the
highest any of them asked for, and the first one's saved value returns when the last one
leaves."""
from __future__ import annotations

import sys
import threading
from contextlib import contextmanager

SYNTAX_DEPTH = 60_000      # the parse and the AST passes recurse with the nesting
# the C stack of a thread that runs such a pass: reserved address space, not memory
# (pages are touched only as deep as the recursion goes)
DEEP_STACK = 1 << 29
_lock = threading.Lock()
_asked: list[int] = []      # the limits of the passes inside
_saved = 0                  # the limit before the first of them came in


@contextmanager
def recursion_limit(at_least: int):
    global _saved
    with _lock:
        if not _asked:
            _saved = sys.getrecursionlimit()
        _asked.append(at_least)
        sys.setrecursionlimit(max([_saved, *_asked]))
    try:
        yield
    finally:
        with _lock:
            _asked.remove(at_least)
            sys.setrecursionlimit(max([_saved, *_asked]))


_stack_lock = threading.Lock()


def on_deep_stack(fn, *args):
    """fn(*args) on a thread whose C stack holds SYNTAX_DEPTH levels of any pass. Python
    calls Python without the C stack, but a generator consumed by a builtin (`tuple(f(a)
    for a in ...)`), pickle and lark's callbacks recurse in C too: a sum of 20 000 terms
    overflowed the main thread's 8 MiB and the process died of a segmentation fault,
    before the recursion limit could raise its RecursionError."""
    result: list = []

    def run():
        try:
            result.append((True, fn(*args)))
        except BaseException as e:      # noqa: BLE001 -- raised again on the caller's thread
            result.append((False, e))

    with _stack_lock:
        before = threading.stack_size()
        try:
            threading.stack_size(DEEP_STACK)
            worker = threading.Thread(target=run, name="pcsg-deep", daemon=True)
            worker.start()
        except (ValueError, RuntimeError, MemoryError):
            worker = None               # no such stack here: the caller's own
        finally:
            threading.stack_size(before)
    if worker is None:
        return fn(*args)
    worker.join()
    ok, value = result[0]
    if ok:
        return value
    raise value
