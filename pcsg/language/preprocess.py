"""`#define` (notation §2): textual, C-like macros without arguments.

The expanded text is assembled from pieces of the original file; each piece
remembers where it came from and through which macro uses, so that a
diagnostic can name both the place of use and the place of definition.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

from .errors import Diagnostic
from .names import RESERVED
from .source import Piece, Source

# Numbers are matched so that the `e5` of `1e5` is never taken for a name.
_TOKEN = re.compile(
    r"(?P<comment>//[^\n]*|/\*.*?(?:\*/|\Z))"
    r"|(?P<define>^[ \t]*\#define\b)"
    r"|(?P<number>(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?)"
    r"|(?P<name>[A-Za-z_][A-Za-z0-9_]*)",
    re.S | re.M,
)
_BRACE = re.compile(r"//[^\n]*|/\*.*?(?:\*/|\Z)|[{}]", re.S)
_NAME = re.compile(r"[ \t]*([A-Za-z_][A-Za-z0-9_]*)")
MAX_EXPANSION = 8_000_000       # characters of expanded text
MAX_USES = 20_000               # macro expansions, nested ones included


@dataclass
class Macro:
    name: str
    body: tuple[int, int]     # the replacement: a range of the original text
    defined: int              # offset of the macro's name in its #define


class _Expander:
    def __init__(self, text: str, source: Source):
        self.text = text
        self.source = source
        self.macros: dict[str, Macro] = {}
        self.out: list[str] = []
        self.pieces: list[Piece] = []
        self.length = 0
        self.errors: list[Diagnostic] = []
        self.warnings: list[Diagnostic] = []
        self.used: set[str] = set()
        self.in_directives: set[str] = set()     # macros said to replace a directive's word
        self.uses = 0
        self.defines: list[tuple[int, int]] = []

    def emit(self, start: int, end: int, uses: tuple | None):
        if end <= start:
            return
        self.pieces.append(Piece(self.length, start, uses))
        self.out.append(self.text[start:end])
        self.length += end - start
        if self.length > MAX_EXPANSION:
            raise _TooLarge(start, uses)

    def error(self, offset: int, message: str):
        self.errors.append(Diagnostic("error", message, None, self.source, code="macro",
                                      original=offset))

    def warn(self, offset: int, message: str, code: str):
        self.warnings.append(Diagnostic("warning", message, None, self.source, code=code,
                                        original=offset))

    def unused(self):
        """Macros no text below their #define reads: a misspelt use leaves one unread
        (and reports an undefined name where it stands), a leftover is dead text."""
        for name, macro in self.macros.items():
            if name not in self.used:
                self.warn(macro.defined, f"macro '{name}' is never used", "unused")

    def expand(self, start: int, end: int, uses: tuple | None, active: set, top: bool):
        """Copy text[start:end], replacing macro names (and, at top level, consuming
        #define). `uses` is a chain of the macro uses this text is inside, innermost first
        (Piece.uses), `active` the macros being expanded, each left out of its own text.
        Both grow by one where a use nests, in place: copied at every level, a chain of
        10,000 macros each naming the one before held a copy per level, 2.8 GB."""
        text, pos = self.text, start
        while pos < end:
            m = _TOKEN.search(text, pos, end)
            if m is None:
                break
            kind = m.lastgroup
            if kind == "define":
                if not top:
                    pos = m.end()
                    continue
                self.emit(pos, m.start(), uses)
                blank = self.length
                pos = self.define(m.start(), m.end())
                self.defines.append((blank, self.length))
                continue
            if kind == "name" and m.group() in self.macros and m.group() not in active:
                macro = self.macros[m.group()]
                self.used.add(macro.name)
                if top and macro.name not in self.in_directives and \
                        _directive_word(text, m.start(), m.end()):
                    self.in_directives.add(macro.name)
                    self.warn(m.start(), f"macro '{macro.name}' replaces a directive's own "
                                         f"word here: #define changes directives' names and "
                                         f"keys too", "macro-directive")
                self.uses += 1
                if self.uses > MAX_USES:
                    raise _TooLarge(m.start(), uses)
                self.emit(pos, m.start(), uses)
                inner = ((macro.name, m.start(), macro.defined), uses)
                active.add(macro.name)
                self.expand(*macro.body, inner, active, top=False)
                active.discard(macro.name)
                # An empty expansion still marks its place, so errors can point at the use.
                self.pieces.append(Piece(self.length, m.start(), uses))
                pos = m.end()
                continue
            self.emit(pos, m.end(), uses)
            pos = m.end()
        self.emit(pos, end, uses)

    def define(self, start: int, directive_end: int) -> int:
        """Register a #define; emit its newlines so that line numbers stay put."""
        text = self.text
        line_end = text.find("\n", directive_end)
        line_end = len(text) if line_end < 0 else line_end
        # comments are spaces before the name too (`#define /* c */ R 0.5`)
        m = _NAME.match(code_of(text[directive_end:line_end]))
        if m is None:
            # at what stands where the name goes (`#define 3 sphere`), else at #define
            rest = text[directive_end:line_end]
            what = directive_end + len(rest) - len(rest.lstrip())
            found = rest.strip()
            self.error(what if found else start, "#define needs a name" + (
                f", and '{found.split()[0]}' is none (a name starts with an ASCII letter or '_')"
                if found else ""))
            return self._blank(start, line_end)
        name, name_at, after = m.group(1), directive_end + m.start(1), directive_end + m.end()
        if text.startswith("(", after):
            # C's function-like macro: legal (the replacement is the rest of the line), and
            # at each use it stands for "(a) rotz(a) ...", which is seldom what was meant
            self.warn(after, f"macros take no arguments (notation §2): '{name}' stands for "
                             f"the text from this '(' on; a space before the '(' says that "
                             f"is meant", "macro-arguments")
        line_end = _define_end(text, after)
        if line_end < 0:
            self.error(-line_end - 1, "comment opened with '/*' is never closed")
            return self._blank(start, len(text))
        rest = code_of(text[after:line_end])
        body_start = after + len(rest) - len(rest.lstrip())
        stripped = rest.strip()
        if stripped.startswith("{"):
            end = self._block_end(body_start, name)
            body = (body_start, end)
            self._after_block(end, name)
        elif not stripped and self._next_line_starts_block(line_end):
            brace = text.index("{", line_end)
            end = self._block_end(brace, name)
            body = (brace, end)
            self._after_block(end, name)
        else:
            end = line_end
            body = (body_start, body_start + len(stripped))
        if name in self.macros:
            first = self.source.location(self.macros[name].defined)
            self.error(name_at, f"macro '{name}' is defined twice (first at {first})")
        else:
            self.macros[name] = Macro(name, body, name_at)
            if name in RESERVED:
                # legal (the text is replaced before any name means anything), and it
                # silently changes what every later use of the word is
                self.warn(name_at, f"macro '{name}' replaces {RESERVED[name]} of that "
                                      f"name: every '{name}' below stands for this text",
                          "reserved")
        return self._blank(start, end)

    def _blank(self, start: int, end: int) -> int:
        for i in range(start, end):
            if self.text[i] == "\n":
                self.emit(i, i + 1, ())
        return end

    def _next_line_starts_block(self, line_end: int) -> bool:
        nxt = self.text[line_end + 1:line_end + 1 + 4096].lstrip(" \t\r")
        return nxt.startswith("{")

    def _after_block(self, end: int, name: str):
        """Text after a block replacement, on the line its '}' ends: not the macro's (§2),
        so it stays in the file, a statement of its own (`#define AX {c = 2} S`: AX was
        the block, and S the file's axiom)."""
        tail = code_of(self.text[end:line_end(self.text, end)])
        if tail.strip():
            at = end + len(tail) - len(tail.lstrip())
            self.warn(at, f"'{tail.strip()}' after the block that is macro '{name}''s "
                          f"replacement is not part of it (notation §2: a replacement that "
                          f"starts with '{{' is that block); it stays in the file where it "
                          f"stands", "macro-tail")

    def _block_end(self, brace: int, name: str) -> int:
        depth = 0
        for m in _BRACE.finditer(self.text, brace):
            if m.group() == "{":
                depth += 1
            elif m.group() == "}":
                depth -= 1
                if depth == 0:
                    return m.end()
        self.error(brace, f"the '{{' of macro '{name}' is never closed")
        return len(self.text)


class _TooLarge(Exception):
    def __init__(self, offset: int, uses: tuple | None):
        super().__init__()
        self.macro = None       # the use in the file's own text whose expansion grew so
        self.offset = offset
        while uses is not None:
            (self.macro, self.offset, _), uses = uses


_LINE_PARTS = re.compile(r"/\*.*?(?:\*/|\Z)|//[^\n]*|\n", re.S)


def _directive_word(text: str, start: int, end: int) -> bool:
    """Whether text[start:end] is a directive's name (`#light`) or one of its keys
    (`up=`) on a directive's line: `#define light paint(...)` made `#light` '#paint'."""
    line = text.rfind("\n", 0, start) + 1
    if not text[line:start].lstrip().startswith("#"):
        return False
    after = text[end:end + 64].lstrip(" \t")
    return text[start - 1:start] == "#" or (after.startswith("=") and
                                             not after.startswith("=="))


def line_end(text: str, start: int) -> int:
    """The end of the line from `start`, where a comment that opens on it and closes on
    a later line goes on to that line's end, as in C (the comment is a space)."""
    end = _define_end(text, start)
    return end if end >= 0 else len(text)


def _define_end(text: str, start: int) -> int:
    """line_end, or -1 - the offset of a comment that opens there and never closes
    (which took the rest of the file into the macro)."""
    for m in _LINE_PARTS.finditer(text, start):
        if m.group() == "\n":
            return m.start()
        if m.group().startswith("/*") and not m.group().endswith("*/"):
            return -1 - m.start()
    return len(text)


def code_of(line: str) -> str:
    """The line with its comments as blanks (so that offsets stay put), up to a `//`:
    `#define R /* half */ 0.5` is 0.5, not nothing."""
    line = re.sub(r"/\*.*?(?:\*/|\Z)", lambda m: " " * len(m.group()), line, flags=re.S)
    m = re.search(r"//", line)
    return line if m is None else line[:m.start()]


def preprocess(text: str, file: str) -> tuple[Source, list[Diagnostic]]:
    """Expand the macros of `text`; return the Source (with its map) and any errors."""
    if "#define" not in text:
        return Source(file, text, text, [Piece(0, 0)]), []
    source = Source(file, text)
    ex = _Expander(text, source)
    try:
        ex.expand(0, len(text), None, set(), top=True)
        ex.unused()
    except _TooLarge as e:
        what = "macros expand" if e.macro is None else f"macro '{e.macro}' expands"
        ex.error(e.offset, f"{what} to more than {MAX_USES:,} uses or {MAX_EXPANSION:,} "
                           f"characters here; nested macros multiply")
    expanded = Source(file, text, "".join(ex.out), ex.pieces,
                      {name: m.defined for name, m in ex.macros.items()}, ex.warnings,
                      ex.defines)
    for d in ex.errors + ex.warnings:
        d.source = expanded
    return expanded, ex.errors
