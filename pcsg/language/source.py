"""A source file and the map from its macro-expanded text back to the file."""
from __future__ import annotations

import bisect
from dataclasses import dataclass, field


def one_line(name: str) -> str:
    """A file's name for a line comment of written text: its line breaks (and other
    control characters) escaped, which ended the comment, so `check` refused what expand
    wrote for a file named with a newline, and `graph` wrote a dot file Graphviz could
    not read."""
    return "".join(c if c.isprintable() or c == " " else repr(c)[1:-1] for c in name)


@dataclass(frozen=True)
class Location:
    file: str
    line: int        # 1-based
    column: int      # 1-based, in characters
    offset: int      # 0-based offset in the original text

    def __str__(self):
        return f"{self.file}:{self.line}:{self.column}"


@dataclass(frozen=True)
class Piece:
    """Expanded text [start, start+len) is a copy of original text from `origin`.

    `uses` chains, innermost macro first, (macro name, offset of the use,
    offset of the definition's name) for text that came out of a macro body: a pair
    (that use, the chain of the uses around it), None outside any macro, so that nested
    uses share their tails (Source.macro_uses lists them).
    """
    start: int
    origin: int
    uses: tuple | None = None


@dataclass
class Source:
    file: str
    text: str                       # the original file
    expanded: str = ""              # after #define
    pieces: list[Piece] = field(default_factory=list)
    macros: dict[str, int] = field(default_factory=dict)    # name -> where it is defined
    warnings: list = field(default_factory=list)            # the #define expansion's
    defines: list = field(default_factory=list)     # (start, end) in expanded of each #define

    def explaining(self) -> list:
        """The macro warnings that explain errors at a macro's uses, said beside them: a
        macro written with arguments, one that replaced a directive's word, text left
        after a block replacement (which the file then reads as its own)."""
        return [w for w in self.warnings
                if w.code in ("macro-arguments", "macro-directive", "macro-tail")]

    def defined_below(self, name: str, used: int | None = None) -> str:
        """', a macro defined below, at L:C, ...' where `name`, undefined where it is
        read (at expanded offset `used`, if known), is a macro the file defines after
        that read; where the read is in the macro's own replacement, that; else ''."""
        at = self.macros.get(name)
        if at is None:
            return ""
        if used is not None:
            if any(use[0] == name for use in self.macro_uses(used)):
                return (f" (in the replacement of macro '{name}' itself, where it is not "
                        f"replaced again: a macro that named itself would never end)")
            if self.locate(used).offset > at:
                return ""       # defined above its read: not what went wrong
        loc = self.location(at)
        return (f" (a macro defined below, at {loc.line}:{loc.column}: a macro stands for its "
                f"text only after its #define)")

    def __post_init__(self):
        self._line_starts = [0] + [i + 1 for i, ch in enumerate(self.text) if ch == "\n"]
        self._piece_starts = [p.start for p in self.pieces]

    def _piece(self, offset: int) -> Piece | None:
        i = bisect.bisect_right(self._piece_starts, offset) - 1
        return self.pieces[i] if i >= 0 else None

    def location(self, original_offset: int) -> Location:
        off = max(0, min(original_offset, len(self.text)))
        line = bisect.bisect_right(self._line_starts, off)
        return Location(self.file, line, off - self._line_starts[line - 1] + 1, off)

    def original_offset(self, expanded_offset: int) -> int:
        p = self._piece(expanded_offset)
        if p is None:
            return expanded_offset
        return p.origin + (expanded_offset - p.start)

    def macro_uses(self, expanded_offset: int) -> tuple:
        """(macro name, offset of the use, offset of its definition) of each macro use
        the text at `expanded_offset` came out of, innermost first."""
        p = self._piece(expanded_offset)
        out, chain = [], p.uses if p else None
        while chain is not None:
            out.append(chain[0])
            chain = chain[1]
        return tuple(out)

    def locate(self, expanded_offset: int) -> Location:
        """Where the user should look: for macro text, the outermost place of use."""
        uses = self.macro_uses(expanded_offset)
        if uses:
            return self.location(uses[-1][1])
        return self.location(self.original_offset(expanded_offset))

    def line_text(self, line: int) -> str:
        start = self._line_starts[line - 1]
        end = self.text.find("\n", start)
        # without a CRLF line's CR, which a terminal shows as a return to column 1
        return (self.text[start:] if end < 0 else self.text[start:end]).rstrip("\r")
