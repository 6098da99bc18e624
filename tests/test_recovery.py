"""Syntax errors after the first: the parse resumes at the next line that surely starts a
statement, so one `check` reports every slip of a file, and never one that a guess at a
statement's start made up."""
import pytest

from pcsg.compiler import compile_text
from pcsg.language.errors import PcsgError
from pcsg.language.parser import MAX_SYNTAX_ERRORS


def reported(text: str) -> list[str]:
    with pytest.raises(PcsgError) as e:
        compile_text(text, "t.pcsg")
    return [f"{d.location.line}:{d.location.column}: {d.message}" for d in e.value.diagnostics]


def test_every_statement_with_a_slip_is_reported():
    text = ("#camera eye=(3,-4,2) at=(0,0,0)\n{c = 3} S\nS if(c > 0, 2, 1)\n"
            "1: S -> sphere - cube\n"
            "2: S -> {c = c-1} (move(1,0,0) uscale(0.5) S ∪\n"
            "        move(-1,0,0 uscale(0.5) S)\n"
            "3: S -> rotate(30) sphere\n"
            "leaf = sphere cube\n")
    assert reported(text) == [
        "4:16: '-' is not a CSG operator: the difference of two operands is written '\\' or '∖'",
        "6:21: unexpected 'uscale', expected ')', ','",
        "7:9: unknown transformation 'rotate'; did you mean 'rot'?",
        "8:15: expected an operator (∪, ∩ or \\) between 'sphere' and 'cube'",
    ]


def test_a_continuation_is_not_taken_for_a_statement():
    # indented, after a line ending in an operator, after an open bracket, in a comment,
    # a closing brace: none of them starts a statement, so none adds an error
    text = ("S\n1: S → sphere sphere ∪\ncube ∪\n  cone\n"
            "2: S → (cube cube\ncone)\n"
            "/* a comment\n1: S → ((\n*/\n"
            "3: S → {a = 1 1\n}\n")
    assert [line.split(":")[0] for line in reported(text)] == ["2", "5", "10"]


def test_a_rule_head_starts_a_statement_even_after_a_bracket_left_open():
    assert reported("S\n1: S → move(1, 0, 0 sphere\n2: S → cube\n3: S → cube cube\n") == [
        "2:21: unexpected 'sphere', expected ')', ','",
        "4:13: expected an operator (∪, ∩ or \\) between 'cube' and 'cube'"]


def test_a_bracket_left_open_ends_the_report_where_no_statement_surely_starts():
    # the rest of the file may be the group's own lines: nothing after it is guessed at
    assert len(reported("x = move(1, 0, 0 sphere\ny = cube cube\nx\n")) == 1
    # at the end of the file nothing is left to parse
    assert len(reported("S\n1: S → cube cube\n2: S → move(1, 0, 0) (sphere\n")) == 2


def test_the_report_stops_at_its_limit():
    text = "S\n" + "".join(f"{k}: S → cube cube\n" for k in range(1, 30))
    assert len(reported(text)) == MAX_SYNTAX_ERRORS
    with pytest.raises(PcsgError) as e:
        compile_text(text, "t.pcsg")
    assert e.value.diagnostics[-1].notes == [
        (None, "the report stops at 10 syntax errors; more follow")]
    # ten of them, and none after: all are shown, with no such note
    exactly = "S\n" + "".join(f"{k}: S → cube cube\n" for k in range(1, 11))
    with pytest.raises(PcsgError) as e:
        compile_text(exactly, "t.pcsg")
    assert len(e.value.diagnostics) == 10 and e.value.diagnostics[-1].notes == []


def test_a_statement_joined_to_the_next_line_is_one_error():
    # the ∪ joins the next rule to this one: its error is the only one
    assert [line[:8] for line in reported("S\n1: S → sphere ∪\n2: S → cube\n3: S → cone\n")] \
        == ["3:1: une"]


def test_the_line_after_an_unexpected_line_end_is_parsed_again():
    # the line end's token took the next line with it, whose slip went unsaid
    assert [line[:5] for line in reported(
        "{c = 3} S\n1: S → rotx(30)\nx = sphere cube\ny = sphere sphere\n")] == \
        ["2:16:", "3:12:", "4:12:"]


def test_no_missing_operator_is_guessed_across_a_line_a_bracket_joined():
    # "expected an operator between 'sphere' and 'y'": the '(' left open is the slip
    assert reported("{c = 3} S\nx = (sphere\ny = cube\n")[0] == \
        "3:1: unexpected 'y', expected ')', '\\', '∩', '∪'"


def test_the_parse_resumes_after_a_closing_bracket_the_lexer_refused():
    # `{c = c - }`: the '}' never reached the line joiner, which counted its block open
    # and resumed only at rule heads, so the named expression's slip went unsaid
    assert [line[:5] for line in reported(
        "S 1\n1: S → {c = c - } cube\nfoo = sphere sphere\n{ c = 1 } S\n")] == ["2:17:", "3:14:"]


def test_notes_for_a_bracket_say_only_what_is_so():
    # a '(' closed on the next line is not "not closed"
    with pytest.raises(PcsgError) as e:
        compile_text("sphere ∪ (cube\n  cone)\n", "t.pcsg")
    assert e.value.diagnostics[0].notes == []
    # a rule's head inside a block left open: the note at the block
    with pytest.raises(PcsgError) as e:
        compile_text("{ c = 3 } S\nS if(c > 0, 2, 1)\n1: S → cube\n2: S → { c = c - 1\n"
                     "3: S → sphere\n", "t.pcsg")
    d = e.value.diagnostics[0]
    assert [(d.source.locate(span[0]).line, text[:31]) for span, text in d.notes] == \
        [(4, "in the calculation block opened")]
