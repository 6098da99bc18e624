"""Standard output for the commands whose output is files (render, sweep, animate,
export): there it carries only status lines, one per image.

A reader that leaves (`pcsg render *.pcsg -o out/ | head -1`) ended the batch at its
next line, with exit status 0 and the other images never written; now the lines go
nowhere from then on and the batch goes on. And where an image itself goes to
standard output (`-o /dev/stdout | viewer`), the status lines go to standard error:
they were written into the PNG stream, after its end."""
from __future__ import annotations

import io
import os
import sys


class StatusLines(io.TextIOBase):
    def __init__(self, stream):
        self._stream = stream
        self._gone = stream is None         # started with it closed (`>&-`)

    def write(self, text: str) -> int:
        if not self._gone:
            try:
                self._stream.write(text)
            except BrokenPipeError:
                self._leave()
        return len(text)

    def flush(self):
        if not self._gone:
            try:
                self._stream.flush()
            except BrokenPipeError:
                self._leave()

    def _leave(self):
        self._gone = True
        # what the stream still buffers, and any process started from now on, write into
        # /dev/null rather than the closed pipe
        try:
            null = os.open(os.devnull, os.O_WRONLY)
            os.dup2(null, self._stream.fileno())
            os.close(null)
        except (OSError, AttributeError, ValueError):
            pass

    def writable(self) -> bool:
        return True

    def isatty(self) -> bool:
        return not self._gone and self._stream.isatty()

    def fileno(self) -> int:
        if self._stream is None:
            raise io.UnsupportedOperation("standard output is closed")
        return self._stream.fileno()

    @property
    def encoding(self):
        return getattr(self._stream, "encoding", "utf-8")

    def __getattr__(self, name):
        # what else a library asks of sys.stdout (buffer, name, reconfigure ...)
        if self._stream is None:
            raise AttributeError(name)
        return getattr(self._stream, name)


def status_stream(images_to_stdout: bool):
    """The stream for status lines: a StatusLines over stdout, or over stderr where an
    image is written to standard output."""
    return StatusLines(sys.stderr if images_to_stdout else sys.stdout)


def is_stdout(path) -> bool:
    """Whether writing `path` writes this process's standard output."""
    import stat
    try:
        mine, theirs = os.fstat(sys.__stdout__.fileno()), os.stat(path)
    except (OSError, AttributeError, ValueError, TypeError):
        return False
    # not /dev/null, which an image and the lines may both go to
    return ((mine.st_dev, mine.st_ino) == (theirs.st_dev, theirs.st_ino)
            and not (stat.S_ISCHR(mine.st_mode) and not os.isatty(sys.__stdout__.fileno())))
