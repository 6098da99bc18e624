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
