"""Every error class has a small bad file in tests/bad/ whose first line says
the expected `line:col: message` (or just a message for whole-file errors)."""
from pathlib import Path

import pytest

from pcsg.compiler import compile_file, compile_text
from pcsg.language.errors import PcsgError

BAD = sorted((Path(__file__).parent / "bad").glob("*.pcsg"))


def expectation(path: Path) -> str:
    first = path.read_text(encoding="utf-8").splitlines()[0]
    assert first.startswith("// expect: "), path
    return first[len("// expect: "):]


@pytest.mark.parametrize("path", BAD, ids=[p.stem for p in BAD])
def test_bad_file_reports_its_error_where_it_is(path):
    want = expectation(path)
    with pytest.raises(PcsgError) as e:
        compile_file(path)
    got = [(f"{d.location.line}:{d.location.column}: " if d.location else "") + d.message
           for d in e.value.diagnostics]
    assert any(g.startswith(want) or (":" not in want.split()[0] and want in g) for g in got), \
        f"{path.name}: wanted {want!r}, got {got!r}"
    # every diagnostic names the file, and the full report quotes the source line
    report = str(e.value)
    assert str(path) in report


def test_the_corpus_covers_every_error_code():
    codes = set()
    for path in BAD:
        try:
            compile_file(path)
        except PcsgError as e:
            codes |= {d.code for d in e.diagnostics}
    assert codes >= {"syntax", "undefined", "undefined-name", "unknown-function", "arity",
                     "reserved", "rule-number", "no-selection", "no-rules", "duplicate", "axiom",
                     "unassigned", "flat-primitive", "named-recursion", "directive", "macro"}


def test_macro_errors_name_use_and_definition():
    e = pytest.raises(PcsgError, compile_file, Path(__file__).parent / "bad" /
                      "macro_error_in_body.pcsg").value
    text = e.diagnostics[0].format()
    assert "macro_error_in_body.pcsg:6:8: error: undefined name 'e'" in text
    assert "note: in macro 'DEC' defined at" in text and ":2:9" in text
    assert "whose text has it at line 2, column 31" in text


@pytest.mark.parametrize("use", ["X sphere", "X sphere)"])
def test_a_bracket_a_macro_leaves_open_is_pointed_at(use):
    # the parse stops after the macro's text, where nothing said that a macro was there
    e = pytest.raises(PcsgError, compile_text, f"#define X move(1, 0, 0\n{use}\n",
                      "t.pcsg").value
    text = e.diagnostics[0].format()
    assert "t.pcsg:2:3: error: unexpected 'sphere'" in text
    assert ("t.pcsg:2:1: note: the '(' that macro 'X' (defined at t.pcsg:1:9) opens is "
            "still open here") in text


def test_a_bracket_opened_outside_any_macro_has_no_macro_note():
    e = pytest.raises(PcsgError, compile_text, "#define X sphere\nmove(1, 0, 0 X\n",
                      "t.pcsg").value
    assert "still open here" not in e.diagnostics[0].format()


def test_the_report_quotes_the_line_with_a_caret_under_the_span():
    e = pytest.raises(PcsgError, compile_text, "{c = 6} S\n1: S → sphere ∪ foo\n", "x.pcsg").value
    lines = e.diagnostics[0].format().splitlines()
    assert lines[0] == "x.pcsg:2:17: error: undefined name 'foo' (not a module, named " \
                       "expression or primitive: sphere, cube, cylinder, cone, tetrahedron, " \
                       "plane, tri1, tri2, mandelbulb, julia)"
    assert lines[1].endswith("1: S → sphere ∪ foo")
    assert lines[2].index("^^^") == lines[1].index("foo")


def test_set_of_an_unknown_parameter():
    e = pytest.raises(PcsgError, compile_text, "{c = 6} sphere", "x.pcsg", {"k": 2}).value
    assert e.diagnostics[0].message == ("cannot set 'k': it is not an initial parameter "
                                        "(initial parameters: c)")


def test_all_errors_of_a_file_are_reported_in_order():
    text = "{c = 6} S\n1: S → foo ∪ bar\nT 1\n"
    e = pytest.raises(PcsgError, compile_text, text, "x.pcsg").value
    where = [(d.location.line, d.location.column) for d in e.diagnostics]
    assert where == sorted(where) and len(where) == 3


def test_the_caret_stands_under_its_token_after_wide_characters():
    # 日本語 takes six columns of a terminal: the caret stood three left of 'cubee'
    e = pytest.raises(PcsgError, compile_text, "/* 日本語 */ sphere ∪ cubee\n", "t.pcsg").value
    line, caret = e.diagnostics[0].format().splitlines()[1:3]
    wide = line.index("/*") + len("/* 日本語 */ sphere ∪ ") + 3     # three cells more
    assert caret.index("^") == wide and caret.count("^") == len("cubee")


def test_a_file_with_old_mac_line_ends_has_its_lines(tmp_path):
    # a lone CR ended no line: the file was one line, its errors at 1:N
    src = tmp_path / "cr.pcsg"
    src.write_bytes("{c = 1} S\rS if(c > 0, 2, 1)\r1: S → sphere\r2: S → {c = c-1} cubee\r"
                    .encode("utf-8"))
    e = pytest.raises(PcsgError, compile_file, src).value
    loc = e.diagnostics[0].location
    assert (loc.line, loc.column) == (4, 18) and "cubee" in e.diagnostics[0].message
    text = src.read_bytes().decode("utf-8")                 # and as a string, loads's way
    loc = pytest.raises(PcsgError, compile_text, text, "t").value.diagnostics[0].location
    assert (loc.line, loc.column) == (4, 18)
    crlf = tmp_path / "crlf.pcsg"                  # and CRLF stays as it was
    crlf.write_bytes(src.read_bytes().replace(b"\r", b"\r\n"))
    e = pytest.raises(PcsgError, compile_file, crlf).value
    loc = e.diagnostics[0].location
    assert (loc.line, loc.column) == (4, 18)
    assert "\r" not in e.diagnostics[0].format()            # the excerpt without its CR


@pytest.mark.parametrize("text, said", [
    # read as a number: they were "undefined name 'N'", though defined
    ("N ∪ move(N, 0, 0) cube\nN = sphere\n",
     ["1:10: 'N' is a named expression, a CSG operand, not a number"]),
    ("{c = 1} S\nS T\n1: S → sphere\n1: T → cube\n",
     ["2:3: 'T' is a module, a CSG operand, not a number"]),
    # a module declared without rules: its declaration says so, its use says nothing more
    # (it said "undefined name 'S'" first, contradicting it)
    ("S\nS 1\n", ["2:1: 'S' is declared as a module but has no rules (write them as "
                  "'1: S → ...')"]),
])
def test_a_name_defined_as_something_else_is_said_as_such(text, said):
    e = pytest.raises(PcsgError, compile_text, text, "t.pcsg")
    assert [f"{d.location.line}:{d.location.column}: {d.message}"
            for d in e.value.diagnostics] == said


def test_an_error_in_a_block_opened_lines_above_points_at_it():
    # a '}' left out: the next statement read as an assignment, "expected '='", and
    # nothing said where the block began
    e = pytest.raises(PcsgError, compile_text, "{c = 1\nS\n1: S → sphere\n", "t.pcsg")
    d = e.value.diagnostics[0]
    assert (d.location.line, d.location.column) == (2, 2)
    assert [(d.source.locate(span[0]).line, text) for span, text in d.notes] == [
        (1, "in the calculation block opened here, whose lines are assignments until its '}'")]
    # a slip inside a block that is closed: no such note
    e = pytest.raises(PcsgError, compile_text, "{c = 1\n d = 2 +* 3 }\nsphere\n", "t.pcsg")
    assert e.value.diagnostics[0].notes == []
