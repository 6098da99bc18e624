"""Diagnostics that point at file:line:col, with the source line and a caret."""
from __future__ import annotations

import math
import unicodedata
from dataclasses import dataclass, field

from .source import Source


@dataclass
class Diagnostic:
    severity: str                  # 'error' or 'warning'
    message: str
    span: tuple[int, int] | None   # expanded-text offsets, or None for the whole file
    source: Source | None = None
    notes: list[tuple[tuple[int, int] | None, str]] = field(default_factory=list)
    code: str = ""                 # a stable short name of the class, for tests and tools
    original: int | None = None    # an offset in the file itself, where no expanded text exists

    @property
    def location(self):
        if self.source is None:
            return None
        if self.original is not None:
            return self.source.location(self.original)
        return self.source.locate(self.span[0] if self.span else 0)

    def format(self, show_source: bool = True) -> str:
        src = self.source
        if src is None:
            return f"pcsg: {self.severity}: {self.message}"
        whole = self.span is None and self.original is None     # of the file, no place
        lines = [f"{src.file if whole else self.location}: {self.severity}: {self.message}"]
        if show_source and not whole:
            lines += _excerpt(src, self.span, self.original)
        for span, text in self._all_notes():
            if span is None:
                lines.append(f"{src.file}: note: {text}")
            else:
                lines.append(f"{src.locate(span[0])}: note: {text}")
        return "\n".join(lines)

    def _all_notes(self):
        """Explicit notes, then the macro chain of the primary span."""
        out = [(span, text + self._macro_of(span, text)) for span, text in self.notes]
        if self.span is not None and self.original is None:
            uses = self.source.macro_uses(self.span[0])
            inner = self.source.location(self.source.original_offset(self.span[0]))
            for i, (name, _use, defined) in enumerate(uses):
                where = self.source.location(defined)
                what = f"in macro '{name}' defined at {where}"
                if i == 0:      # the macro's name, and where in its text the error is
                    what += (f", whose text has it at line {inner.line}, column "
                             f"{inner.column}")
                out.append((None, what))
        return out

    def _macro_of(self, span, text: str) -> str:
        """Where in the file a note's span stands when a macro wrote it (unless the note
        names the macro itself): the note is located at the macro's use (an error about a
        `tri1` in macro X said "'tri1' used here" at the line `X` is written on, and no
        more)."""
        uses = self.source.macro_uses(span[0]) if span is not None else ()
        if not uses or f"macro '{uses[0][0]}'" in text:
            return ""
        inner = self.source.location(self.source.original_offset(span[0]))
        return (f" (in macro '{uses[0][0]}' defined at {self.source.location(uses[0][2])}, "
                f"whose text has it at line {inner.line}, column {inner.column})")

    def __str__(self):
        return self.format(show_source=False)


def labelled(label, note: str) -> str:
    """A note about a render as its line: after the file or frame it is about, unless it
    starts with that already (a formatted Diagnostic names its own file)."""
    return note if note.startswith(f"{label}:") else f"{label}: {note}"


def _excerpt(src: Source, span, original=None) -> list[str]:
    """The source line with a caret run under the span (under the use, for macro text)."""
    if original is not None:
        start, width = src.location(original), 1
    elif src.macro_uses(span[0]):
        start, width = src.locate(span[0]), len(src.macro_uses(span[0])[-1][0])
    else:
        start = src.locate(span[0])
        end = src.location(src.original_offset(max(span[0], span[1] - 1)))
        width = (end.column - start.column + 1) if end.line == start.line else 1
    text = src.line_text(start.line).expandtabs(1)
    col = start.column
    if len(text) > 160:
        lo = max(0, col - 60)
        text, col = text[lo:lo + 160], col - lo
    gutter = f"{start.line:>5} | "
    # in a terminal's columns: a CJK character takes two, and the caret stood left of its
    # token after one (column numbers stay characters)
    lead = _cells(text[:col - 1])
    run = _cells(text[col - 1:col - 1 + width]) if width > 0 else 1
    return [gutter + text, " " * (len(gutter) - 2) + "| " + " " * lead + "^" * max(1, run)]


def _cells(text: str) -> int:
    """The terminal columns `text` takes: two for wide and full-width characters."""
    return sum(2 if unicodedata.east_asian_width(ch) in "WF" else 1 for ch in text)


class PcsgError(Exception):
    """One or more errors in a .pcsg file; str() is the full report."""

    def __init__(self, diagnostics: list[Diagnostic]):
        self.diagnostics = diagnostics
        super().__init__("\n".join(d.format() for d in diagnostics))

    def __reduce__(self):
        # as it was made, not from its message (language/prefetch.py sends it between
        # processes)
        return type(self), (self.diagnostics,)

    @property
    def first(self) -> Diagnostic:
        return self.diagnostics[0]


def sort_key(d: Diagnostic):
    # in the file's order; one without a place (no axiom) after the others, which are
    # often its cause: '#camera fov=' took the axiom on the next line as its value
    if d.span is None and d.original is None:
        return (math.inf, d.message)
    loc = d.location
    return (loc.offset if loc else -1, d.message)
