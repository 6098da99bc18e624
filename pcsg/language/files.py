"""Reading a .pcsg file: UTF-8 text, or a PcsgError that says why not. Kept apart from
the parser so that reading a file does not import lark."""
from __future__ import annotations

import glob
import os
import stat
from pathlib import Path

from .errors import Diagnostic, PcsgError
from .source import Source

MAX_FILE_BYTES = 8 * 1024 * 1024     # lark parses ~100k tokens/s; a PCSG system is short
# what a pipe or device gave, by its (device, inode): it can be read once, and sweep and
# animate read their file twice (checked, then rendered), the second time empty: "no axiom"
_STREAMS: dict[tuple[int, int], bytes] = {}


def pcsg_files(directory: str | Path) -> list[str]:
    """The .pcsg files in a directory, sorted (not a subdirectory named so)."""
    found = glob.glob(os.path.join(glob.escape(str(directory)), "*.pcsg"))
    return sorted(f for f in found if os.path.isfile(f))


def read_source_text(path: str | Path) -> str:
    """Read a .pcsg file as UTF-8 text; PcsgError (not OSError) for anything unreadable."""
    name = str(path)
    try:
        p = Path(path)
        if p.is_dir():
            # a batch takes a directory for its .pcsg files: one without any comes here
            what = ("is a directory, not a .pcsg file" if pcsg_files(p) else
                    "is a directory with no .pcsg file in it")
            raise PcsgError([Diagnostic("error", what, None, Source(name, ""), code="io")])
        st = p.stat()
        size, stream = st.st_size, (st.st_dev, st.st_ino)
        if stat.S_ISREG(st.st_mode):
            stream = None
        if stream in _STREAMS:
            data = _STREAMS[stream]
        elif size <= MAX_FILE_BYTES:
            # at most one byte past the limit, whatever the size said: a device or a pipe
            # (/dev/zero, <(...)) has size 0, and /dev/zero was read until the system's
            # memory ran out
            with open(p, "rb") as f:
                data = f.read(MAX_FILE_BYTES + 1)
            if len(data) > MAX_FILE_BYTES:
                size = None
            elif stream is not None:
                _STREAMS[stream] = data
        if size is None or size > MAX_FILE_BYTES:
            raise too_large(name, size)
    except OSError as e:
        said = f"cannot read: {e.strerror or e}"
        if str(path) == "-" and isinstance(e, FileNotFoundError):
            said += " (pcsg reads a grammar from a file, not from standard input: save it first)"
        raise PcsgError([Diagnostic("error", said, None, Source(name, ""), code="io")]) from None
    return decode(data, name)


def too_large(name: str, size: int | None) -> PcsgError:
    """The error for a grammar of `size` bytes over the limit (None: more than it)."""
    # in bytes: a file just over 8 MiB was "8.0 MiB", over a limit of "8 MiB"
    what = f"more than {MAX_FILE_BYTES:,}" if size is None else f"{size:,}"
    return PcsgError([Diagnostic("error", f"{'file' if name != '<string>' else 'text'} is "
                                 f"{what} bytes; pcsg reads grammars of up to "
                                 f"{MAX_FILE_BYTES:,} bytes ({MAX_FILE_BYTES >> 20} MiB; an "
                                 f"expanded derivation that large: use fewer steps)", None,
                                 Source(name, ""), code="io")])


def check_text_size(text: str, name: str) -> None:
    """A grammar given as text (the API's loads) is held to the files' limit: 50 MB of
    text parsed for minutes where a file of it is refused at once."""
    if len(text) > MAX_FILE_BYTES // 4:      # 4 bytes a character at most: else it fits
        size = len(text.encode("utf-8", "surrogatepass"))
        if size > MAX_FILE_BYTES:
            raise too_large(name, size)


def decode(data: bytes, name: str) -> str:
    if b"\x00" in data:
        raise PcsgError([Diagnostic("error", "this is a binary file, not PCSG text", None,
                                    Source(name, ""), code="encoding")])
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        text = data[:e.start].decode("utf-8", "replace")
        src = Source(name, text)
        raise PcsgError([Diagnostic("error", f"not UTF-8 text (byte 0x{data[e.start]:02x})", None,
                                    src, code="encoding", original=len(text))]) from None
    return text


def line_ends(text: str) -> str:
    """A lone CR (old Mac line ends) as LF: it ended no line, and a file of them was one
    line, every error at 1:N. One character for one, so every offset stays; CRLF stays."""
    if "\r" not in text:
        return text
    return text.replace("\r\n", "\0").replace("\r", "\n").replace("\0", "\r\n")
