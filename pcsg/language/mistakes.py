"""Syntax errors that are common mistakes, said as the mistake: a transformation the
notation does not have, a rule without its number, '=' for '==', a '#' comment. The
parser stops at the first token it cannot take, which is often well after the mistake
(`rotate(30) sphere` stopped at 'sphere', "expected end of line"); these look back from
there. Each returns (message, span) or None."""
from __future__ import annotations

import re

from .names import FUNCTIONS, PRIMITIVES, TRANSFORMS
from .suggest import closest

# what may be written NAME( ... ): transformations, paint, material, fractals, functions
CALLABLE = (*TRANSFORMS, "paint", "material", "mandelbulb", "julia", *FUNCTIONS)
OPERATOR_WORDS = {"union": "∪", "intersection": "∩", "difference": "\\"}
HASH_COMMENT = "'#' does not start a comment: comments are // to the end of the line, or /* ... */"
_CALL_BEFORE = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)[ \t]*\((?:[^()\n]*\))?[ \t]*$")


def unknown_call(text: str, pos: int):
    """`rotate(30) sphere`, `translate(1,0,0) ...`, `usclae(0.5) S`: a name written with
    arguments that takes none, just before `pos` (its '(' open or its call complete).
    Not on a directive's line (`#sky color (1,1,1)` lacks its '=')."""
    line_start = text.rfind("\n", 0, pos) + 1
    before = text[line_start:pos]
    if before.lstrip().startswith("#"):
        return None
    m = _CALL_BEFORE.search(before)
    if m is None and text.startswith("(", pos):
        m = re.search(r"([A-Za-z_][A-Za-z0-9_]*)[ \t]*$", before)
    if m is None:
        m = re.search(r"([A-Za-z_][A-Za-z0-9_]*)[ \t]*\([^()\n]*$", before)
    if m is None or m.group(1) in ("and", "or", "not"):
        return None
    word = m.group(1)
    span = (line_start + m.start(1), line_start + m.end(1))
    if TRANSFORMS.get(word) == 0 or (word in PRIMITIVES and word not in CALLABLE):
        # `flipxy (sphere ∪ cube) cone` is a flip of a group: only numbers are arguments
        args = text[line_start + m.end(1):].lstrip(" \t")[1:].lstrip(" \t")
        if re.match(r"[-+.0-9)]", args):
            return f"'{word}' takes no arguments", span
        # `flipxy(c)`, `flipxy(c * 2)`: a parameter in brackets reads as the operand the
        # flip takes, and the parse stopped after it; a group of operands has a CSG
        # operator, a primitive or a module (a name with rules) in it
        inner = re.match(r"[^()\n]*", args).group(0)
        names = re.findall(r"[A-Za-z_][A-Za-z0-9_]*", inner)
        modules = set(re.findall(r"(?m)^[ \t]*\d+[ \t]*:[ \t]*([A-Za-z_][A-Za-z0-9_]*)", text))
        if TRANSFORMS.get(word) == 0 and names and not re.search(r"[∪∩∖\\|&]", inner) and \
                not any(n in PRIMITIVES or n in TRANSFORMS or n in modules for n in names):
            return (f"'{word}' takes no arguments: a '(...)' after it is the operand it "
                    f"applies to", span)
        return None
    if word in CALLABLE:
        return None
    if word.lower() in OPERATOR_WORDS:
        return (f"the notation has no '{word}(...)': write the operands with "
                f"'{OPERATOR_WORDS[word.lower()]}' between them, e.g. 'sphere ∪ cube'", span)
    best = closest(word, (*TRANSFORMS, "paint"))
    if best:
        return f"unknown transformation '{word}'; did you mean '{best}'?", span
    known = ", ".join(sorted(TRANSFORMS))
    return (f"'{word}(...)': no transformation has that name (they are {known}, and "
            f"paint(r, g, b)), and modules and primitives take no arguments", span)


def unknown_directive(text: str, pos: int):
    """`#defin X sphere`, `# a comment`: a line whose '#' word is no directive."""
    line_start = text.rfind("\n", 0, pos) + 1
    m = re.match(r"[ \t]*#([A-Za-z_][A-Za-z0-9_]*)?", text[line_start:])
    if m is None:
        return None
    word = m.group(1)
    start = line_start + m.start(0) + (len(m.group(0)) - len(m.group(0).lstrip()))
    if word is None:
        return HASH_COMMENT, (start, start + 1)
    from ..scene import DIRECTIVES         # not at import: scene imports the graph's model
    directives = (*DIRECTIVES, "define")
    if word in directives:
        return None
    best = closest(word, directives)
    hint = f"; did you mean '#{best}'?" if best else ""
    known = ", ".join("#" + d for d in directives)
    return f"unknown directive '#{word}'{hint} (known: {known})", (start, line_start + m.end(0))


def directive_continued(text: str, pos: int):
    """`#camera eye=(3,-4,2)` and `  at=(0,0,0)` on the next line: a newline ends the
    directive, and the key's line read as a named expression `at = ...`, its numbers
    unexpected operands. `pos` is the token the parse stopped at."""
    from ..scene import DIRECTIVES         # not at import: scene imports the graph's model
    line_start = text.rfind("\n", 0, pos) + 1
    m = re.match(r"[ \t]*([A-Za-z_][A-Za-z0-9_]*)[ \t]*=(?!=)", text[line_start:])
    if m is None or line_start == 0:
        return None
    above = text.rfind("\n", 0, line_start - 1) + 1
    d = re.match(r"[ \t]*#([A-Za-z_][A-Za-z0-9_]*)", text[above:line_start])
    if d is None or m.group(1) not in DIRECTIVES.get(d.group(1), ()):
        return None
    return (f"'{m.group(1)}=' continues '#{d.group(1)}' from the line above, but a newline "
            f"ends a directive: write all its keys on the line of '#{d.group(1)}'",
            (line_start + m.start(1), line_start + m.end(0)))


def rule_without_number(text: str, pos: int):
    """`S → sphere`: a rule is `N: S → ...`. `pos` is the arrow's (the '-' of '->')."""
    line_start = text.rfind("\n", 0, pos) + 1
    m = re.match(r"[ \t]*([A-Za-z_][A-Za-z0-9_]*)[ \t]*$", text[line_start:pos])
    if m is None:
        return None
    name = m.group(1)
    return (f"a rule starts with its number: '1: {name} → ...' (rules of a module are "
            f"numbered 1, 2, ... and its selection picks one)",
            (line_start + m.start(1), pos + 1))


def rule_as_selection(text: str, pos: int):
    """`T move(1, 0, 0) sphere`: a module's name and a transformation at the start of a
    line read as the module's declaration with that transformation as its selection, and
    the operand after it was said as unexpected. `pos` is the operand's."""
    line_start = text.rfind("\n", 0, pos) + 1
    m = re.match(r"[ \t]*([A-Za-z_][A-Za-z0-9_]*)[ \t]+(([A-Za-z_][A-Za-z0-9_]*)[ \t]*\(.*\))"
                 r"[ \t]*$", text[line_start:pos])
    if m is None or m.group(3) not in TRANSFORMS or m.group(1) in PRIMITIVES:
        return None
    end = text.find("\n", pos)
    body = f"{m.group(2)} {text[pos:end if end >= 0 else len(text)].strip()}"
    return (f"'{m.group(1)} {m.group(2)}' reads as module '{m.group(1)}' with the selection "
            f"{m.group(2)}; a rule is written '1: {m.group(1)} → {body}'",
            (line_start + m.start(1), line_start + m.end(1)))


def assignment_for_comparison(expected, text: str, pos: int, bracketed: bool) -> str | None:
    """`if(c = 0, ...)`, `S c = 1`: '=' where a comparison may stand. Outside brackets
    that is a module's selection, the one expression a line holds unbracketed, said so
    where the file has rules for the module (`let seg = sphere` is no selection)."""
    if "CMP" not in expected or "EQUAL" in expected:
        return None
    said = "'=' assigns; to compare, write '=='"
    if bracketed:
        return said
    line_start = text.rfind("\n", 0, pos) + 1
    m = re.match(r"[ \t]*([A-Za-z_][A-Za-z0-9_]*)[ \t]", text[line_start:pos])
    if m is None or not re.search(rf"^[ \t]*\d+[ \t]*:[ \t]*{m.group(1)}[ \t]*(→|->)", text,
                                  re.MULTILINE):
        return None
    return (f"{said} (the line reads as the declaration of module '{m.group(1)}', whose "
            f"selection is an arithmetic expression giving a rule's number)")


def axiom_slip(text: str, name: str, name_end: int):
    """`sphere - cube`, `sphere cube`, `sphere(1)`: an axiom with a slip after its first
    name reads as the declaration `NAME selection` of a module; the slip, said as one."""
    i = name_end + len(text[name_end:]) - len(text[name_end:].lstrip(" \t"))
    ch = text[i:i + 1]
    if ch in CSG_SLIPS:
        return f"'{ch}' is not a CSG operator: {CSG_SLIPS[ch]}", (i, i + 1)
    if ch == "(":
        return f"'{name}' takes no arguments", (i, i + 1)
    m = re.match(r"[A-Za-z_][A-Za-z0-9_]*", text[i:])
    if m and m.group(0) not in FUNCTIONS:
        return (f"expected an operator (∪, ∩ or \\) between '{name}' and '{m.group(0)}'",
                (i, i + m.end()))
    if name in PRIMITIVES:
        # `sphere 1`: read as module sphere's declaration, which a primitive's name,
        # reserved, cannot make; said as the axiom it was likely meant to be
        return (f"'{name}' is a primitive, a reserved name, so '{name} ...' declares no "
                f"module; as an axiom it needs an operator (∪, ∩ or \\) after its operand",
                (i, i + 1))
    return None


def missing_operator(text: str, tok_type: str, tok_value: str, pos: int, expected):
    """`1: S → sphere - cube`, `… sphere cube`: after a whole operand, where only a CSG
    operator or the statement's end may follow (the axiom's own slips are `axiom_slip`'s,
    since an axiom that goes on so parses as a module's declaration)."""
    if "UNION" not in expected:
        return None
    if tok_value in CSG_SLIPS:
        return f"'{tok_value}' is not a CSG operator: {CSG_SLIPS[tok_value]}", (pos, pos + 1)
    if tok_type not in ("NAME", "TRANSFORM", "FLIP", "FRACTAL", "PAINT", "MATERIAL"):
        return None
    before = text[max(0, pos - 200):pos].rstrip(" \t")
    if before.endswith("\n"):
        return None     # lines joined inside a bracket: the bracket is the slip more often
    m = re.search(r"([A-Za-z_][A-Za-z0-9_]*|\))\Z", before)
    between = f"between '{m.group(1)}' and" if m and m.group(1) != ")" else "before"
    return (f"expected an operator (∪, ∩ or \\) {between} '{tok_value}'",
            (pos, pos + len(tok_value)))


LOGICAL = {"and": ("and", "intersection", "'∩' or '&'"), "&&": ("and", "intersection", "'∩' or '&'"),
           "or": ("or", "union", "'∪' or '|'"), "||": ("or", "union", "'∪' or '|'")}


def logical_for_csg(text: str, tok_value: str, pos: int, expected):
    """`sphere and cube`, `sphere && cube`: calculations' logical operators between two
    operands, where the CSG ones stand. The parse stops at 'and' where an operator may
    follow, at the operand after it in an axiom (read as a module with the selection
    `and`), or at the second '&' of '&&' (the first is an intersection)."""
    line_start = text.rfind("\n", 0, pos) + 1
    if tok_value in ("and", "or") and "UNION" in expected:
        word, span = tok_value, (pos, pos + len(tok_value))
    elif tok_value in ("&", "|") and text[pos - 1:pos] == tok_value:
        word, span = tok_value * 2, (pos - 1, pos + 1)
    else:
        m = re.search(r"[A-Za-z0-9_)][ \t]+(and|or)[ \t]+$", text[line_start:pos])
        if m is None or text[line_start:pos].lstrip().startswith("#"):
            return None
        word, span = m.group(1), (line_start + m.start(1), line_start + m.end(1))
    logic, csg, spelt = LOGICAL[word]
    return (f"'{word}' is the logical {logic} of calculations (notation §6); the {csg} of "
            f"two operands is written {spelt}", span)


CSG_FOR_LOGICAL = {"INTER": ("intersection", "and", "'&&' or 'and'"),
                   "UNION": ("union", "or", "'||' or 'or'")}


def csg_for_logical(tok_type: str, tok_value: str, pos: int, expected):
    """`if(c > 0 & d > 0, 1, 2)`: a CSG operator inside a calculation, where a logical
    one may stand (`logical_for_csg`'s mirror)."""
    if tok_type not in CSG_FOR_LOGICAL or "AND" not in expected or "UNION" in expected:
        return None
    csg, logic, spelt = CSG_FOR_LOGICAL[tok_type]
    return (f"'{tok_value}' is the {csg} of two operands; the logical {logic} of "
            f"calculations is written {spelt} (notation §6)", (pos, pos + len(tok_value)))


CSG_SLIPS = {"-": "the difference of two operands is written '\\' or '∖'",
             "+": "a union is written '∪' or '|'"}


# characters that look like the notation's, as word processors and other notations type
# them: what to write instead
LOOKALIKES = {"−": "'-'", "–": "'-'", "×": "'*'", "÷": "'/'", "≤": "'<='", "≥": "'>='",
              "≠": "'!='", "⇒": "'→' or '->'", "⟶": "'→' or '->'", "⋃": "'∪' or '|'",
              "⋂": "'∩' or '&'", "∧": "'&&' (or '∩' between operands)",
              "∨": "'||' (or '∪' between operands)", "\u00a0": "a plain space",
              "\u200b": "nothing (it is a zero-width space)"}


def lookalike(ch: str) -> str | None:
    """`unexpected character '−'`, and what the notation writes for it."""
    if ch in "“”‘’":
        return f"unexpected character {ch!r}: the notation has no quoted text"
    if ch == "?":
        return "unexpected character '?': the notation has no 'c ? a : b'; write if(c, a, b)"
    instead = LOOKALIKES.get(ch)
    if instead is None:
        if ch.isalpha() or ch.isdigit():    # `café`: a letter, but not one a name may hold
            return (f"unexpected character {ch!r}: names are ASCII letters, digits and '_' "
                    f"(notation §1)")
        return None
    return f"unexpected character {ch!r} (U+{ord(ch):04X}): write {instead} instead"


def token_slips(text: str, tok_type: str, value: str, pos: int, expected, in_block: bool,
                bracketed: bool):
    """Slips a single token shows, said as what was meant rather than as the parser's
    list of what it would take there."""
    after = text[pos + len(value):pos + len(value) + 1]
    if tok_type == "EQUAL" and in_block and text[pos - 1:pos] == "=" and "EQUAL" not in expected:
        return "'==' compares; a calculation block assigns with '='", (pos - 1, pos + 1)
    if tok_type == "EQUAL" and after in "<>" and after:
        return f"'={after}' is written '{after}='", (pos, pos + 2)
    if tok_type == "NUMBER" and value.startswith(".") and text[pos - 1:pos].isdigit():
        m = re.search(r"[0-9.]*\Z", text[:pos])
        return (f"a number has one decimal point: '{m.group(0)}{value}'",
                (pos - len(m.group(0)), pos + len(value)))
    if tok_type == "NUMBER" and in_block and "NAME" in expected and \
            re.match(r"[ \t]*=(?!=)", text[pos + len(value):]):
        return ("an assignment sets a parameter: its left side is a name, which starts with a "
                "letter or '_'", (pos, pos + len(value)))
    if value == ";" and not bracketed:
        return ("';' separates the assignments of a calculation block { ... }; a statement "
                "ends with its line", (pos, pos + 1))
    line_start = text.rfind("\n", 0, pos) + 1
    m = re.match(r"[ \t]*#[A-Za-z_]+[ \t].*?([A-Za-z_][A-Za-z0-9_]*)[ \t]*\Z",
                 text[line_start:pos])
    if m and "EQUAL" in expected and value.strip():
        word = m.group(1)
        end = text.find("\n", pos)
        rest = text[pos:end if end >= 0 else len(text)]
        close = rest.find(")") if rest.startswith("(") else -1
        value_text = rest[:close + 1] if close > 0 else rest.split()[0]
        return (f"a directive's setting is written NAME=VALUE: '{word}={value_text}'",
                (line_start + m.start(1), pos + len(value)))
    return None
