"""Text -> AST: preprocess, lark LALR parse (inline transformer, so deep
nesting builds no intermediate tree and never recurses), positioned errors."""
from __future__ import annotations

import functools
import re
from pathlib import Path

from lark import Lark, Token, Transformer
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken

from . import ast
from .errors import Diagnostic, PcsgError
from .files import line_ends, read_source_text
from .mistakes import (HASH_COMMENT, assignment_for_comparison, csg_for_logical,
                       directive_continued, logical_for_csg, lookalike, missing_operator,
                       rule_as_selection, rule_without_number, token_slips, unknown_call,
                       unknown_directive)
from .names import FREE, RESERVED
from .postlex import LineJoiner, owned_names
from .preprocess import code_of, preprocess
from .source import Source

CSG_OPS = {"∪": "union", "|": "union", "∩": "intersection", "&": "intersection",
           "\\": "difference", "∖": "difference"}
ARITH_OPS = {"and": "&&", "or": "||", "not": "!"}


def _span(x):
    if isinstance(x, Token):
        return (x.start_pos, x.end_pos)
    return x.span


def _join(a, b):
    return (_span(a)[0], _span(b)[1])


class _ToAst(Transformer):
    """Each callback gets the children of one grammar rule; spans come from tokens."""

    # ---- statements
    def start(self, c):
        return ast.Program([s for s in c if s is not None])

    def rule(self, c):
        num, name, _arrow, body = c
        return ast.Rule(int(num), str(name), body, _join(num, body), _span(num), _span(name))

    def decl(self, c):
        name, sel = c
        return ast.ModuleDecl(str(name), sel, _join(name, sel), _span(name))

    def named(self, c):
        name, _eq, body = c
        return ast.Named(str(name), body, _join(name, body), _span(name))

    def axiom(self, c):
        return ast.Axiom(c[0], c[0].span)

    def directive(self, c):
        kind, rest = c[0], c[1:]
        name = None
        if rest and isinstance(rest[0], Token):
            name, rest = str(rest[0]), rest[1:]
        end = rest[-1] if rest else (c[1] if len(c) > 1 else kind)
        return ast.Directive(str(kind)[1:], name, list(rest), _join(kind, end), _span(kind))

    def dir_item(self, c):
        key, _eq, value = c
        return ast.DirectiveItem(str(key), value, _join(key, value), _span(key))

    def tuple(self, c):
        items = [x for x in c if not isinstance(x, Token)]
        return ast.Tuple(items, _join(c[0], c[-1]))

    # ---- CSG
    def csg_op(self, c):
        left, op, right = c
        return ast.CsgOp(CSG_OPS[str(op)], left, right, _join(left, right), _span(op))

    def transform(self, c):
        name, _l, args, close, operand = c
        return ast.Transform(str(name), args or [], operand, _join(name, operand), _join(name, close))

    def flip(self, c):
        name, operand = c
        return ast.Transform(str(name), [], operand, _join(name, operand), _span(name))

    def calculation(self, c):
        block, operand = c
        assigns, span = block
        return ast.Calc(assigns, operand, (span[0], operand.span[1]), span)

    def calc(self, c):
        return ([x for x in c if isinstance(x, ast.Assign)], _join(c[0], c[-1]))

    def assign(self, c):
        name, _eq, value = c
        return ast.Assign(str(name), value, _join(name, value), _span(name))

    def paint(self, c):
        head, _l, args, close, operand = c
        return ast.Paint(args or [], operand, _join(head, operand), _join(head, close))

    def material(self, c):
        head, _l, name, close, operand = c
        return ast.Material(str(name), operand, _join(head, operand), _join(head, close), _span(name))

    def fractal(self, c):
        name, _l, args, close = c
        return ast.Fractal(str(name), args or [], _join(name, close))

    def ref(self, c):
        return ast.Ref(str(c[0]), _span(c[0]))

    def group(self, c):
        # Parentheses only group; the span widens to include them for carets.
        inner = c[1]
        inner.span = _join(c[0], c[2])
        return inner

    # ---- arithmetic
    def args(self, c):
        return list(c)

    def binary(self, c):
        left, op, right = c
        return ast.Binary(ARITH_OPS.get(str(op), str(op)), left, right, _join(left, right))

    def unary(self, c):
        op, operand = c
        return ast.Unary(ARITH_OPS.get(str(op), str(op)), operand, _join(op, operand))

    def number(self, c):
        return ast.Num(float(c[0]), _span(c[0]))

    def var(self, c):
        return ast.Var(str(c[0]), _span(c[0]))

    def call(self, c):
        name, _l, args, close = c
        return ast.Call(str(name), args or [], _join(name, close), _span(name))


@functools.lru_cache(maxsize=1)
def _lark() -> tuple[Lark, LineJoiner]:
    joiner = LineJoiner()
    grammar = (Path(__file__).with_name("pcsg.lark")).read_text(encoding="utf-8")
    parser = Lark(grammar, parser="lalr", lexer="contextual", postlex=joiner,
                  transformer=_ToAst(), maybe_placeholders=True, cache=True)
    return parser, joiner


def parse(text: str, file: str = "<string>") -> tuple[ast.Program, Source]:
    """Parse PCSG text; raises PcsgError with every macro error, or with the syntax errors
    (the first, and those of the statements after it: see `_syntax_errors`)."""
    source, errors = preprocess(line_ends(text), file)
    if errors:
        raise PcsgError(errors)
    parser, joiner = _lark()
    joiner.owned, joiner.text = owned_names(source.expanded), source.expanded
    try:
        program = parser.parse(source.expanded)
    except UnexpectedInput as e:
        raise PcsgError(source.explaining() + _syntax_errors(e, source, parser, joiner)) \
            from None
    return program, source


def parse_file(path: str | Path) -> tuple[ast.Program, Source]:
    return parse(read_source_text(path), str(path))


# ---- syntax errors that say what was expected, in the notation's words ----

_FRIENDLY = {
    "NAME": "a name", "NUMBER": "a number", "INT": "a rule number", "_NL": "end of line",
    "$END": "end of file", "ARROW": "'→'", "EQUAL": "'='", "LPAR": "'('", "RPAR": "')'",
    "LBRACE": "'{'", "RBRACE": "'}'", "UNION": "'∪'", "INTER": "'∩'", "DIFF": "'\\'",
    "TRANSFORM": "a transformation", "FLIP": "a flip", "FRACTAL": "a fractal primitive",
    "PAINT": "'paint'",
    "MATERIAL": "'material'", "DIRECTIVE": "a directive", "COLON": "':'", "COMMA": "','",
    "SEMICOLON": "';'", "CMP": "a comparison", "PLUS": "'+'", "MINUS": "'-'", "STAR": "'*'",
    "SLASH": "'/'", "PERCENT": "'%'", "CARET": "'^'", "BANG": "'!'", "NOT": "'not'",
    "OR": "'||'", "AND": "'&&'",
}
_OPERAND = {"NAME", "LPAR", "TRANSFORM", "FLIP", "FRACTAL", "PAINT", "MATERIAL", "LBRACE"}
_RESERVED_TOKENS = {"TRANSFORM": "a transformation", "FLIP": "a transformation",
                    "FRACTAL": "a primitive",
                    "PAINT": "the paint operator", "MATERIAL": "the material operator",
                    "NOT": "an operator"}


def _expected(names) -> str:
    names = set(names)
    parts = []
    if _OPERAND <= names:
        parts.append("an operand (a name, '(', a transformation, '{' or paint/material)")
        names -= _OPERAND
    elif {"NUMBER", "NAME", "LPAR", "MINUS"} <= names:
        parts.append("an arithmetic expression")
        names -= {"NUMBER", "NAME", "LPAR", "MINUS", "PLUS", "BANG", "NOT"}
    names -= {"_NL"} if ("$END" in names or parts) else set()
    parts += sorted(_FRIENDLY.get(n, n) for n in names)
    if len(parts) > 6:
        parts = parts[:6] + ["..."]
    return ", ".join(parts)


def _describe(tok: Token) -> str:
    if tok.type == "$END":
        return "end of file"
    if tok.type == "_NL":
        return "end of line"
    return f"'{tok.value}'"


MAX_SYNTAX_ERRORS = 10
RECOVER_CHARS = 250_000       # text past an error parsed again, at most (a parse per error)
# what a line that joins the next ends with (postlex.LineJoiner), and open brackets
# (not '/': a comment's last line, read alone, ends with it)
_JOINING_ENDS = ("∪", "|", "∩", "&", "\\", "∖", "→", "->", "=", "(", ",", "{",
                 "+", "-", "*", "%", "^", "<", ">", "!")
_JOINING_WORD = re.compile(r"(?<![A-Za-z0-9_])(and|or|not)\Z")
_STATEMENT_HEAD = re.compile(r"[0-9]+[ \t]*:[ \t]*[A-Za-z_][A-Za-z0-9_]*[ \t]*(→|->)"
                             r"|#(camera|light|sky|material)\b")
# comments (skipped whole), brackets and line ends
_BRACKETS = re.compile(r"//[^\n]*|/\*.*?(?:\*/|\Z)|[(){}\n]", re.S)


def _syntax_errors(first: UnexpectedInput, source: Source, parser, joiner) -> list[Diagnostic]:
    """The first syntax error, and those of the statements after it. LALR stops at its
    first error; a file with three slips would take three runs of `check`. The parse
    resumes at the next line that starts a statement (see `_resume_at`) with everything
    before it blanked, so that positions stay put; a statement cut in two by a wrong
    guess could only add an error, and where the guess is unsure no guess is made."""
    text = source.expanded
    found = [_syntax_error(first, source, joiner)]
    e = first
    while len(found) <= MAX_SYNTAX_ERRORS:      # one more: whether any follow
        at = _error_offset(e)
        resume = None if at is None else _resume_at(text, at, _open_at(e, joiner))
        if resume is None or len(text) - resume > RECOVER_CHARS:
            break
        rest = joiner.text = _blanked(text, resume)
        try:
            parser.parse(rest)
            break
        except UnexpectedInput as again:
            e = again
            found.append(_syntax_error(e, source, joiner, rest))
    if len(found) > MAX_SYNTAX_ERRORS:
        found = found[:MAX_SYNTAX_ERRORS]
        found[-1].notes.append((None, f"the report stops at {MAX_SYNTAX_ERRORS} syntax "
                                      f"errors; more follow"))
    return found


def _error_offset(e: UnexpectedInput):
    """Where the text after the error starts (the joiner has counted the token's own
    bracket), or None at the file's end, after which nothing is left."""
    if isinstance(e, UnexpectedCharacters):
        return e.pos_in_stream
    if isinstance(e, UnexpectedEOF) or e.token.type == "$END":
        return None
    # a line end's token takes the newline and the next line's indentation with it
    return e.token.start_pos if e.token.type == "_NL" else e.token.end_pos


def _open_at(e: UnexpectedInput, joiner: LineJoiner) -> int:
    """The brackets open after the error's token: a closer the contextual lexer refused
    (`{c = c - }`) never reached the joiner, which still counts its bracket open."""
    depth = len(joiner.open_brackets)
    tok = getattr(e, "token", None)
    if tok is not None and tok.type in ("RPAR", "RBRACE") and depth and \
            (joiner.last is None or joiner.last.start_pos < tok.start_pos):
        depth -= 1
    return depth


def _resume_at(text: str, at: int, open_brackets: int):
    """The start of the first line after `at` that surely starts a statement: one that
    starts with a rule's head or a directive (neither can stand inside another statement),
    or one where the brackets open at the error are closed, with in its first column a
    character a statement starts with (not a continuation's indentation, nor a closing
    bracket), outside a comment, after a line that does not end with an operator, arrow,
    '=' or open bracket that would join the two."""
    depth = open_brackets
    for m in _BRACKETS.finditer(text, at):
        if m.group() == "\n":
            line = m.end()
            if _STATEMENT_HEAD.match(text, line):
                return line
            ch = text[line:line + 1]
            if depth <= 0 and ch and (ch.isalnum() or ch in "_{(#") and \
                    not _joins_next(text, line):
                return line
        elif m.group() in "({":
            depth += 1
        elif m.group() in ")}":
            depth -= 1
    return None


def _joins_next(text: str, line: int) -> bool:
    """Whether the last line with code before `line` ends so that it joins the next."""
    end = line - 1
    while end > 0:
        start = text.rfind("\n", 0, end) + 1
        code = code_of(text[start:end]).rstrip()
        if code:
            return code.endswith(_JOINING_ENDS) or bool(_JOINING_WORD.search(code))
        end = start - 1
    return False


def _blanked(text: str, upto: int) -> str:
    head = text[:upto]
    return "".join(c if c in "\r\n" else " " for c in head) + text[upto:]


def _syntax_error(e: UnexpectedInput, source: Source, joiner: LineJoiner,
                  text: str | None = None) -> Diagnostic:
    text = source.expanded if text is None else text
    notes = []
    if isinstance(e, UnexpectedCharacters):
        pos = e.pos_in_stream
        ch = text[pos] if pos < len(text) else ""
        if ch == "#" and (uses := source.macro_uses(pos + 1)):
            # `#define light 1` made `#light` '#1' (the macro's warning stands beside)
            return Diagnostic("error", f"no directive: its word here is macro "
                                       f"'{uses[-1][0]}''s text (a #define replaces "
                                       f"directives' words too: give the macro another name)",
                              (pos, pos + 1), source, code="syntax")
        said = unknown_directive(text, pos)
        if said:
            return Diagnostic("error", said[0], said[1], source, code="syntax")
        if text.startswith("/*", pos):
            msg = "comment opened with '/*' is never closed"
        elif ch == "[" or ch == "]":
            msg = f"unexpected '{ch}': square brackets are not part of the notation"
        elif said := lookalike(ch):
            msg = said
        elif ch == "#":
            msg = HASH_COMMENT
        else:
            msg = f"unexpected character {ch!r}"
        return Diagnostic("error", msg, (pos, pos + 1), source, code="syntax")
    if isinstance(e, UnexpectedEOF) or (isinstance(e, UnexpectedToken) and e.token.type == "$END"):
        pos = len(text)
        expected = getattr(e, "expected", None) or getattr(e, "accepts", None) or set()
        msg = "unexpected end of file"
        if joiner.open_brackets:
            b = joiner.open_brackets[-1]
            msg += f": '{b.value}' is never closed"
            pos = b.start_pos       # the error stands at the bracket: no note to say so
        elif expected:
            msg += f", expected {_expected(expected)}"
        return Diagnostic("error", msg, (pos, pos + 1), source, notes=notes, code="syntax")
    tok = e.token
    span = (tok.start_pos, max(tok.end_pos, tok.start_pos + 1))
    expected = e.accepts or e.expected
    word = _word_before(text, tok.start_pos)
    if tok.value == "/" and text.startswith("/*", tok.start_pos):
        msg = "comment opened with '/*' is never closed"
    elif owned := _owned_call(text, tok.end_pos, joiner.owned):
        msg = (f"'{owned[0]}' is this file's own module or named expression, which takes no "
               f"arguments: where a file defines '{owned[0]}', the fractal of that name is "
               f"not available")
        span = owned[1]
    elif tok.type in _RESERVED_TOKENS and ("NAME" in expected or _next_is_eq(text, tok)):
        msg = f"'{tok.value}' is a reserved name ({_RESERVED_TOKENS[tok.type]})"
    elif tok.type == "EQUAL" and word and word[0] in RESERVED and word[0] not in FREE:
        msg = f"'{word[0]}' is a reserved name ({RESERVED[word[0]]}) and cannot be defined"
        span = word[1]
    elif tok.type == "NUMBER" and tok.value.startswith(".") and "COLON" in expected:
        msg = "rule numbers are whole numbers"
        span = (text.rfind("\n", 0, tok.start_pos) + 1, tok.end_pos)
    elif tok.type in ("UNION", "INTER", "DIFF") and _starts_line(text, tok):
        msg = (f"a line cannot start with '{tok.value}': to continue the line before, end that "
               f"line with the operator instead")
    elif said := (unknown_directive(text, tok.start_pos)
                  or directive_continued(text, tok.start_pos)
                  or token_slips(text, tok.type, tok.value, tok.start_pos, expected,
                                 _in_block(joiner), bool(joiner.open_brackets))
                  or (tok.type == "ARROW" and rule_without_number(text, tok.start_pos))
                  # '->' where no arrow may stand lexes as '-' and '>'
                  or (tok.value == ">" and text[tok.start_pos - 1:tok.start_pos] == "-"
                      and rule_without_number(text, tok.start_pos - 1))
                  or (not _in_block(joiner) and unknown_call(text, tok.start_pos))
                  or (not joiner.open_brackets and logical_for_csg(text, tok.value,
                                                                   tok.start_pos, expected))
                  or missing_operator(text, tok.type, tok.value, tok.start_pos, expected)
                  or csg_for_logical(tok.type, tok.value, tok.start_pos, expected)
                  or rule_as_selection(text, tok.start_pos)):
        msg, span = said
    elif tok.type == "EQUAL" and (said := assignment_for_comparison(
            expected, text, tok.start_pos, bool(joiner.open_brackets))):
        msg = said
    elif tok.type == "_NL" and not tok.value:
        # the end postlex gives a file's last statement: where the file stops, not at its
        # last token (`1: S → ` ends the file after the arrow)
        msg = f"unexpected end of file, expected {_expected(expected)}"
        span = (tok.end_pos, tok.end_pos + 1)
    elif tok.type == "_NL" and joiner.open_brackets:
        msg = f"unexpected end of line, expected {_expected(expected)}"
    else:
        msg = f"unexpected {_describe(tok)}, expected {_expected(expected)}"
    notes += (_open_in_macro(source, joiner, tok.start_pos)
              or _operator_from_macro(source, text, tok.start_pos)
              or _open_before(text, joiner, tok, expected))
    return Diagnostic("error", msg + _macro_below(source, tok, word), span, source, notes=notes,
                      code="syntax")


def _macro_below(source: Source, tok: Token, word) -> str:
    """A macro used above its #define stays a plain name there; where it stands for a
    prefix (`{c = c - 1}`, `move(1, 0, 0)`), the parse stops at what follows it, and the
    error says so: ', a macro defined below ...' for the token or the word before it."""
    for name, at in ([(tok.value, tok.start_pos)] if tok.type == "NAME" else []) + \
            ([word] if word else []):
        at = at if isinstance(at, int) else at[0]
        if said := source.defined_below(name, at):
            return f" ('{name}': {said[2:-1]})"
    return ""


def _owned_call(text: str, pos: int, owned: frozenset):
    """(name, span) of a fractal's name the file owns (postlex.owned_names) written before
    its arguments on the line of the error, up to `pos`; None if none."""
    if not owned:
        return None
    line = text.rfind("\n", 0, pos) + 1
    found = None
    for m in re.finditer(r"\b(mandelbulb|julia)[ \t]*\(", text[line:pos]):
        if m.group(1) in owned:
            found = m.group(1), (line + m.start(1), line + m.end(1))
    return found


def _in_block(joiner: LineJoiner) -> bool:
    """Inside a calculation block, where names are parameters and functions: a slip
    there is a missing separator more often than a transformation."""
    return any(b.type == "LBRACE" for b in joiner.open_brackets)


def _open_before(text: str, joiner: LineJoiner, tok: Token, expected) -> list:
    """A note at the bracket still open from an earlier line, where the error starts a
    line: a ')' left out of a rule stopped the parse at the next statement, with nothing
    pointing back. (Within a group that closes later, lines join too.)"""
    if not joiner.open_brackets:
        return []
    b = joiner.open_brackets[-1]
    if "\n" not in text[b.start_pos:tok.start_pos]:
        # `{c = 1 S`: the closer this line lacks, said where no later one closes it
        closer = {"LBRACE": "RBRACE", "LPAR": "RPAR"}.get(b.type)
        if closer in expected and not _closed_later(text, tok.start_pos):
            return [((b.start_pos, b.end_pos), f"the '{b.value}' opened here is not closed")]
        return []
    line = text.rfind("\n", 0, tok.start_pos) + 1
    if b.type == "LBRACE":
        # a block's lines are assignments: a '}' left out read the next statement as one
        # ("expected '='", or a rule's head), whether or not the error starts its line
        if "EQUAL" not in expected and not _STATEMENT_HEAD.match(text, line):
            return []
        return [((b.start_pos, b.end_pos), "in the calculation block opened here, whose "
                                           "lines are assignments until its '}'")]
    if not _starts_line(text, tok) or _closed_later(text, tok.start_pos):
        return []       # a bracket closed further on: the slip is between (an operator)
    return [((b.start_pos, b.end_pos), f"the '{b.value}' opened here is not closed")]


def _closed_later(text: str, pos: int) -> bool:
    """Whether the bracket open at `pos` closes before the next rule head or directive."""
    depth = 1
    for m in _BRACKETS.finditer(text, pos):
        g = m.group()
        if g == "\n" and _STATEMENT_HEAD.match(text, m.end()):
            return False
        if g in "({":
            depth += 1
        elif g in ")}":
            depth -= 1
            if depth == 0:
                return True
    return False


def _open_in_macro(source: Source, joiner: LineJoiner, pos: int) -> list:
    """A note where the innermost bracket still open at `pos` was opened by a macro's
    text that `pos` is not in: `#define X move(1,0,0` then `X sphere` stopped at
    'sphere', with nothing pointing at the macro."""
    if not joiner.open_brackets:
        return []
    b = joiner.open_brackets[-1]
    uses = source.macro_uses(b.start_pos)
    if not uses or source.macro_uses(pos)[-1:] == uses[-1:]:
        return []
    name, _use, defined = uses[0]
    return [((b.start_pos, b.end_pos), f"the '{b.value}' that macro '{name}' (defined at "
                                       f"{source.location(defined)}) opens is still open here")]


def _operator_from_macro(source: Source, text: str, pos: int) -> list:
    """A note where the CSG operator just before `pos` ends a macro's text that `pos` is
    not in: `#define D sphere \\` (a '\\' at the end of a line is the difference, never a
    continuation) then `D ∪ cone` stopped at '∪', with nothing pointing at the macro."""
    before = text[:pos].rstrip(" \t")
    if not before or before[-1] not in "∪|∩&\\∖":
        return []
    at = len(before) - 1
    uses = source.macro_uses(at)
    if not uses or source.macro_uses(pos)[-1:] == uses[-1:]:
        return []
    name, _use, defined = uses[0]
    return [((at, at + 1), f"the '{before[-1]}' before it ends the text of macro '{name}' "
                           f"(defined at {source.location(defined)})")]


def _word_before(text: str, pos: int):
    m = re.search(r"([A-Za-z_][A-Za-z0-9_]*)[ \t]*$", text[max(0, pos - 200):pos])
    if m is None:
        return None
    base = max(0, pos - 200)
    return m.group(1), (base + m.start(1), base + m.end(1))


def _starts_line(text: str, tok: Token) -> bool:
    before = text[:tok.start_pos].rstrip(" \t")
    return not before or before.endswith("\n")


def _next_is_eq(text: str, tok: Token) -> bool:
    rest = text[tok.end_pos:tok.end_pos + 200].lstrip(" \t")
    return rest.startswith("=") and not rest.startswith("==")
