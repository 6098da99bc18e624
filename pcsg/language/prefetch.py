"""A .pcsg file parsed in a child process while the command imports numpy and numba.

Every `pcsg` command spends its first quarter of a second importing numpy, numba and the
kernels' helpers, on one core. The parse needs none of them: lark and this package
only, 40 to 65 ms with lark's own import. So the console command (cli.run) forks before
its imports; the child reads and parses the command's first file and sends the syntax
tree (or the file's error) back through a pipe, and the compiler takes it for that file
if the text it reads then is the text the child parsed. Anything else, a system without
fork, a child that failed, a file changed in between, and the compiler parses as
before: the result is the same either way, only the time differs. PCSG_PREFETCH=0
parses in the command's own process."""
from __future__ import annotations

import os
import pickle
import signal
import sys

from ..interrupt import STOPS, take_unless_ignored
from .errors import PcsgError

_children: dict[str, tuple[int, int]] = {}     # the file's real path -> (pid, pipe)


def _forget() -> None:
    """In a process forked later (animate's and sweep's workers): no child of its own to
    ask, and no pipe held open that would keep a child writing to it waiting."""
    for _, read in _children.values():
        os.close(read)
    _children.clear()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget)


def first_file(argv: list[str]) -> None:
    """Start the parse of the first .pcsg file among a command's arguments, if any."""
    for arg in argv:
        if arg.lower().endswith(".pcsg") and os.path.isfile(arg):
            start(arg)
            return


def start(path: str) -> None:
    """Parse `path` in a child process, for take()."""
    key = os.path.realpath(path)
    threading = sys.modules.get("threading")
    if (not hasattr(os, "fork") or key in _children
            or os.environ.get("PCSG_PREFETCH", "1") == "0"
            # a lock another thread holds at the fork would stay held in the child
            or (threading is not None and threading.active_count() > 1)):
        return
    # Ctrl-C reaches the whole process group: the parent reports it, the child just
    # ends. Held back across the fork, so that no KeyboardInterrupt can take the child
    # back into the command's own code before its handler says so
    held = signal.pthread_sigmask(signal.SIG_BLOCK, set(STOPS))
    try:
        child = _fork_parse(path, held)
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, held)
    if child is not None:
        _children[key] = child


def _fork_parse(path: str, held) -> tuple[int, int] | None:
    """(pid, pipe) of a child that parses `path`; None where none could be made (too many
    processes, say): the compiler parses then. The child never returns from here."""
    try:
        read, write = os.pipe()
    except OSError:
        return None
    try:
        pid = os.fork()
    except OSError:
        os.close(read)
        os.close(write)
        return None
    if pid == 0:
        try:
            # SIGTERM and SIGHUP reach it with the group too (`timeout` signals it)
            take_unless_ignored(STOPS, lambda *_: os._exit(1))
            signal.pthread_sigmask(signal.SIG_SETMASK, held)
            os.close(read)
            with os.fdopen(write, "wb") as out:
                out.write(_parsed(path))
        finally:
            os._exit(0)       # never the parent's exit handlers, nor its buffered output
    os.close(write)
    return pid, read


def _parsed(path: str) -> bytes:
    """The pickled (path, text, result): `result` the parse, or the PcsgError it raised;
    None for anything else, which the parent then meets itself."""
    from ..collector import collector_paused
    from ..recursion import SYNTAX_DEPTH, recursion_limit
    from .files import read_source_text
    from .parser import parse
    try:
        text = read_source_text(path)
        try:
            with recursion_limit(SYNTAX_DEPTH), collector_paused():     # as compile_text
                found = parse(text, path)
        except PcsgError as e:
            found = e
        return pickle.dumps((path, text, found), protocol=pickle.HIGHEST_PROTOCOL)
    except BaseException:       # noqa: BLE001 -- the parent parses again, and reports it
        return pickle.dumps(None)


def take(path: str, text: str):
    """The child's parse of `path` (program, source) if it parsed this very text, else
    None; raises the PcsgError it met."""
    entry = _children.pop(os.path.realpath(path), None) if _children else None
    if entry is None:
        return None
    pid, read = entry
    try:
        with os.fdopen(read, "rb") as pipe:
            data = pipe.read()
        got = pickle.loads(data)
    except Exception:           # noqa: BLE001 -- a child that died: parse here
        got = None
    try:
        os.waitpid(pid, 0)
    except ChildProcessError:   # reaped already
        pass
    if got is None or got[1] != text:
        return None
    if isinstance(got[2], PcsgError):
        if got[0] != path:      # the name is in every diagnostic
            return None
        raise got[2]
    program, source = got[2]
    source.file = path          # the name the command gives it (`./x.pcsg` may come as `x.pcsg`)
    return program, source
