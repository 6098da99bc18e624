"""Writing files so that an interrupted write never leaves a broken or half file
and never destroys an earlier good one: a temporary file beside it, then rename."""
from __future__ import annotations

import contextlib
import errno
import os
import stat
import tempfile
from pathlib import Path


@contextlib.contextmanager
def open_atomic(path: Path, mode: str = "wb"):
    """A file to write `path` through: it replaces `path` only when the block ends
    without an exception. A symbolic link is written through (the file it names is
    replaced, the link stays), and a device, pipe or socket (/dev/stdout, a fifo) is
    written into: a rename would put a plain file in its place, /dev/null's too."""
    path = Path(path)
    try:
        kind = os.stat(path).st_mode    # through links: /dev/stdout is its pipe or terminal
    except FileNotFoundError:
        kind = None
    if kind is not None and stat.S_ISDIR(kind):
        raise IsADirectoryError(errno.EISDIR, os.strerror(errno.EISDIR), str(path))
    if kind is not None and not stat.S_ISREG(kind):
        with open(path, mode) as f:
            yield f
        return
    target = Path(os.path.realpath(path))
    try:
        fd, tmp = tempfile.mkstemp(prefix=_temporary_prefix(target), suffix=".part",
                                   dir=target.parent)
    except OSError as e:        # named by what was asked for, not the temporary file
        raise type(e)(e.errno, e.strerror, str(path)) from None
    try:
        # mkstemp makes the file private; give it the permissions of the file it replaces
        # (a read-only image stayed read-only), or those a plain open() would
        if kind is not None:
            os.fchmod(fd, stat.S_IMODE(kind))
        else:
            umask = os.umask(0)
            os.umask(umask)
            os.fchmod(fd, 0o666 & ~umask)
        with os.fdopen(fd, mode) as f:
            yield f
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, target)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def _temporary_prefix(target: Path) -> str:
    """`.NAME.` for the temporary file beside `target`, unless that would make its name
    longer than the file system takes (a legal name of 241 to 255 bytes failed with "File
    name too long" on the temporary file): then `.pcsg.`."""
    try:
        most = os.pathconf(target.parent, "PC_NAME_MAX")
    except (OSError, ValueError):
        most = 255
    prefix = f".{target.name}."
    # mkstemp adds 8 characters, and the suffix .part
    if len(os.fsencode(prefix)) + 8 + len(".part") > most:
        return ".pcsg."
    return prefix


def write_atomic(path: Path, data: bytes) -> None:
    with open_atomic(path) as f:
        f.write(data)


def cannot_write_in(directory: Path) -> str | None:
    """Why no file can be written in `directory`, found by writing one (access() says
    yes to root in /sys, where the write fails), or None: a render into a directory it
    cannot write in failed only after it had rendered (QA)."""
    try:
        fd, tmp = tempfile.mkstemp(prefix=".pcsg.", suffix=".part", dir=directory)
    except OSError as e:
        return f"cannot write in {directory}: {e.strerror or e}"
    os.close(fd)
    os.unlink(tmp)
    return None


def make_directory(path: Path) -> str | None:
    """Makes the directory `path` with its parents; what stands in the way, said for an
    option's message (Python's 'Not a directory: x/y' named neither the file nor why),
    or None."""
    path = Path(path)
    try:
        path.mkdir(parents=True, exist_ok=True)
        return cannot_write_in(path)
    except (FileExistsError, NotADirectoryError):
        for p in (path, *path.parents):
            if p.is_symlink() and not p.exists():
                # it said "dangling is a file, not a directory" (QA)
                return f"{p} is a link to {os.readlink(p)}, which does not exist"
        blocking = next((p for p in (path, *path.parents) if p.exists() and not p.is_dir()),
                        path)
        return f"{blocking} is a file, not a directory"
    except OSError as e:
        return f"cannot make the directory {path}: {e.strerror or e}"


def directory_in_the_way(paths) -> Path | None:
    """The first of the files about to be written that is a directory: the render ran to
    its end and then failed on 'Is a directory' (QA), where `-o` and `--depth` are
    refused before anything renders."""
    return next((Path(p) for p in paths if Path(p).is_dir()), None)
