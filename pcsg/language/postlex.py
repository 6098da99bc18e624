"""Line joining (notation §2): a newline ends a statement unless a bracket
is open or the line ends with a binary CSG operator, an arrow or `=`.
Inside a `{...}` block a newline separates assignments, so it is kept there, but
for one between an assignment's name and its `=`, where no assignment ends (joined
only where the `=` follows: `{c = 1` and a `}` left out keeps its error at the end of
the line after it).

A line ending in `&&` or `==` ends, by the letter of §2, with `&` or `=`; so
it joins, and so does one ending in any other arithmetic operator: no
statement can end with one, so joining there accepts what would only be an
error otherwise."""
from __future__ import annotations

import re

from lark import Token

JOINERS = {"UNION", "INTER", "DIFF", "ARROW", "EQUAL",
           "OR", "AND", "CMP", "PLUS", "MINUS", "STAR", "SLASH", "PERCENT", "CARET",
           "BANG", "NOT"}
OPENERS = {"LPAR": ")", "LBRACE": "}"}
CLOSERS = {"RPAR", "RBRACE"}
# a fractal's name that heads a rule or a named expression: the file's own
_OWNED = re.compile(r"^[ \t]*(?:[0-9]+[ \t]*:[ \t]*(mandelbulb|julia)[ \t]*(?:→|->)"
                    r"|(mandelbulb|julia)[ \t]*=(?!=))", re.M)
# what no statement's head stands in: comments, and calculation blocks (whose lines are
# assignments to parameters, which may take the names too)
_NOT_HEADS = re.compile(r"/\*.*?(?:\*/|\Z)|//[^\n]*|\{[^{}]*\}", re.S)


# an '=' (not '==') after blanks, newlines and comments
_EQUALS_NEXT = re.compile(r"(?:\s|//[^\n]*|/\*.*?\*/)*=(?!=)", re.S)


def owned_names(text: str) -> frozenset:
    """The fractals' names that the file's rules or named expressions take."""
    if "julia" not in text and "mandelbulb" not in text:
        return frozenset()          # every parse asks: most files have neither
    blank = lambda m: re.sub(r"[^\n]", " ", m.group())     # noqa: E731 (lines stay put)
    heads, before = text, None
    while heads != before:          # nested blocks, innermost first
        before, heads = heads, _NOT_HEADS.sub(blank, heads)
    return frozenset(m.group(1) or m.group(2) for m in _OWNED.finditer(heads))


class LineJoiner:
    always_accept = ("_NL",)

    def __init__(self):
        self.open_brackets: list[Token] = []
        self.last: Token | None = None      # the last token passed on
        # fractal names the file defines as its own modules or named expressions (owned):
        # read as names, not as the fractal, even before a '(' (`julia (c > 0) + 1`)
        self.owned: frozenset = frozenset()
        # the text being parsed, to look past a newline (the contextual lexer lexes each
        # token in the parser's state, so the joiner may not hold one back to see the next)
        self.text = ""

    def process(self, stream):
        self.open_brackets = []
        self.last = None
        prev = None
        last = None
        target = False      # prev is a block's NAME where an assignment starts
        for tok in stream:
            kind = tok.type
            if kind == "_NL":
                inside = self.open_brackets[-1].type if self.open_brackets else None
                if (inside == "LPAR" or prev in JOINERS or prev in (None, "_NL")
                        or (target and _EQUALS_NEXT.match(self.text, tok.end_pos))):
                    continue
                prev = "_NL"
                yield tok
                continue
            target = (kind == "NAME" and bool(self.open_brackets)
                      and self.open_brackets[-1].type == "LBRACE"
                      and (prev == "_NL" or (last is not None and last.value in ("{", ";", ","))))
            if kind == "FRACTAL" and tok.value in self.owned:
                tok = Token.new_borrow_pos("NAME", tok.value, tok)
                kind = "NAME"
            if kind in OPENERS:
                self.open_brackets.append(tok)
            elif kind in CLOSERS and self.open_brackets:
                self.open_brackets.pop()
            prev = kind
            last = self.last = tok
            yield tok
        if prev not in (None, "_NL") and last is not None and not self.open_brackets:
            # The file's last statement needs its end, even without a final newline.
            yield Token.new_borrow_pos("_NL", "", last)
