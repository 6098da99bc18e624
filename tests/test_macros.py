"""`#define` (notation §2): the replacement is the rest of the line, comments being
spaces as in C."""
import pytest

from pcsg.compiler import compile_text
from pcsg.graph.expand import expand_file
from pcsg.language.errors import PcsgError


def expanded(text: str) -> str:
    return expand_file(compile_text(text, "t.pcsg"), 1).strip().splitlines()[-1]


@pytest.mark.parametrize("define", [
    "#define R /* half */ 0.5",           # a comment before the replacement: it was empty
    "#define R 0.5 /* half */ // and more",
    "#define R /* a comment\n   that goes on */ 0.5",      # closed on the next line, as in C
])
def test_comments_in_a_replacement_are_spaces(define):
    assert expanded(f"{define}\nmove(R, 0, 0) sphere\n") == "move(0.5, 0, 0) sphere"


def test_a_comment_before_the_name_is_a_space():
    # "#define needs a name"
    assert expanded("#define /* radius */ R 0.5\nmove(R, 0, 0) sphere\n") == \
        "move(0.5, 0, 0) sphere"


def test_a_block_after_a_comment_is_the_replacement():
    # the block was taken from the next line instead, and the use said "undefined name 'a'"
    assert expanded("#define B /* set */ {a = 2}\nB move(a, 0, 0) sphere\n") == \
        "{a = 2} (move(2, 0, 0) sphere)"


def test_lines_keep_their_numbers_after_a_comment_over_two_lines():
    with pytest.raises(PcsgError) as e:
        compile_text("#define R /* a\n b */ 0.5\nmove(R, 0, 0) sphere\nfoo\n", "t.pcsg")
    assert [(d.location.line, d.location.column) for d in e.value.diagnostics] == [(4, 1)]


def test_a_comment_never_closed_on_a_define_line_is_said():
    # it took the rest of the file into the macro: "no axiom"
    with pytest.raises(PcsgError) as e:
        compile_text("#define R 0.5 /* unclosed\n{c = R} S\n1: S → uscale(c) sphere\n", "t.pcsg")
    assert [(d.location.line, d.location.column, d.message) for d in e.value.diagnostics] == [
        (1, 15, "comment opened with '/*' is never closed")]


def test_a_macro_with_arguments_is_said_where_it_is_defined():
    # only "expected an operator before 'rotz'" at the use said anything
    with pytest.raises(PcsgError) as e:
        compile_text("#define TURN(a) rotz(a) roty(30)\nTURN(45) sphere\n", "t.pcsg")
    first, then = e.value.diagnostics
    assert (first.severity, first.location.line, first.location.column) == ("warning", 1, 13)
    assert first.message.startswith("macros take no arguments (notation §2)")
    assert then.severity == "error" and then.location.line == 2
    # legal by notation §2, the replacement being the rest of the line: a warning only
    graph = compile_text("#define G(sphere)\nG\n", "t.pcsg")
    assert [w.code for w in graph.warnings] == ["macro-arguments"]
    # a space before the '(' says a replacement that starts with a group is meant
    assert expanded("#define G (sphere ∪ cube)\nG\n") == "sphere ∪ cube"


@pytest.mark.parametrize("text, place", [
    ("#define light paint(1, 1, 0.8)\n#light at=(5, 5, 5)\nlight sphere\n", (2, 2)),
    ("#define up (0, 1, 0)\n#camera eye=(3, 3, 3) at=(0, 0, 0) up=(0, 0, 1)\nsphere\n", (2, 36)),
])
def test_a_macro_that_replaces_a_directive_s_word_is_said(text, place):
    # "unknown directive '#paint'", and nothing of the macro that made it
    with pytest.raises(PcsgError) as e:
        compile_text(text, "t.pcsg")
    said = e.value.diagnostics[0]
    assert said.code == "macro-directive" and (said.location.line, said.location.column) == place
    # a macro as a directive's value is what macros are for
    assert compile_text("#define R 3\n#light at=(5, 5, 5) radius=R\nsphere\n", "t.pcsg").warnings == []


def test_a_directive_word_a_macro_made_no_word_is_said_so():
    # '#1' was "'#' does not start a comment", beside the macro's warning
    with pytest.raises(PcsgError) as e:
        compile_text("#define light 1\n#light at=(1, 1, 1)\nsphere\n", "t.pcsg")
    said = [(d.code, d.location.line, d.location.column, d.message) for d in e.value.diagnostics]
    assert said[0][0] == "macro-directive"
    assert said[1][:3] == ("syntax", 2, 1)
    assert said[1][3].startswith("no directive: its word here is macro 'light''s text")


def test_the_macro_warning_stands_beside_a_compile_error_it_explains():
    # "unknown directive '#lamp'" alone, where a syntax error had the macro's word beside it
    with pytest.raises(PcsgError) as e:
        compile_text("#define light lamp\n#light at=(1, 2, 3)\nsphere\n", "t.pcsg")
    assert [d.code for d in e.value.diagnostics] == ["macro-directive", "directive"]
    # and text after a block replacement on the line after its #define is said too
    graph = compile_text("#define AX\n{c = c - 1} B = cube\n{c = 1} S\nS if(c > 0, 2, 1)\n"
                         "1: S → sphere ∪ B\n2: S → AX uscale(0.5) S\n", "t.pcsg")
    [w] = graph.warnings
    assert w.code == "macro-tail" and (w.location.line, w.location.column) == (2, 13)


def test_expand_writes_no_lines_where_defines_stood():
    # the expanded text keeps them blank, for the line numbers of errors; the file written
    # need not, and the user's own blank line stays
    text = ("// head\n#define C { c = c - 1\n}\n  #define T move(1, 0, 0) // a move\n\n{c = 2} S\n"
            "#define Z cube\nS if(c > 0, 1, 2)\n1: S -> sphere | T C S\n2: S -> Z\n")
    lines = expand_file(compile_text(text, "t.pcsg"), 1).splitlines()
    assert lines[1:] == ["// head", "", "sphere ∪ move(1, 0, 0) {c = 1} S", "S if(c > 0, 1, 2)",
                         "1: S -> sphere | move(1, 0, 0) { c = c - 1", "} S", "2: S -> cube"]
    again = expand_file(compile_text("\n".join(lines) + "\n", "e.pcsg"), 1).splitlines()
    assert again[4] == "sphere ∪ move(1, 0, 0) (sphere ∪ move(1, 0, 0) {c = 0} S)"


def test_a_note_inside_a_macro_says_where_in_the_file_it_stands():
    """An error's own line has its macro chain; a note located at a macro's use said no
    more than the use ("'tri1' used here" on the line `X` is written on)."""
    text = "#define PANEL move(0,0,1)\n#define X (sphere ∩ PANEL tri1)\nX\n"
    with pytest.raises(PcsgError) as e:
        compile_text(text, "t.pcsg")
    lines = e.value.diagnostics[0].format().splitlines()
    assert "t.pcsg:3:1: note: 'tri1' used here (in macro 'X' defined at t.pcsg:2:9, whose " \
        "text has it at line 2, column 27)" in lines
    # a note that names its macro already is left as it is
    with pytest.raises(PcsgError) as e:
        compile_text("#define X move(1,0,0\nX sphere\n", "t.pcsg")
    note = e.value.diagnostics[0].format().splitlines()[-1]
    assert note == "t.pcsg:2:1: note: the '(' that macro 'X' (defined at t.pcsg:1:9) opens " \
        "is still open here"


def test_a_long_chain_of_macros_takes_memory_in_proportion():
    """Each nested use copied the chain of uses around it and the set of macros being
    expanded: 10,000 macros, each naming the one before, took 2.8 GB (7.7 s) to check;
    the chains now share their tails. 5,000 here (tracemalloc makes each allocation slow),
    which took a quarter of that."""
    import tracemalloc
    from pcsg.language.preprocess import preprocess
    from pcsg.recursion import SYNTAX_DEPTH, recursion_limit
    n = 5_000
    text = "\n".join(["#define A0 sphere"] + [f"#define A{i} A{i - 1}" for i in range(1, n)]
                     + [f"A{n - 1}"]) + "\n"
    tracemalloc.start()
    try:
        with recursion_limit(SYNTAX_DEPTH):         # as compile_text parses
            source, errors = preprocess(text, "chain.pcsg")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert not errors and source.expanded.strip().endswith("sphere")
    uses = source.macro_uses(source.expanded.rindex("sphere"))
    assert len(uses) == n and uses[0][0] == "A0" and uses[-1][0] == f"A{n - 1}"
    assert peak < 20e6, f"{peak / 1e6:.0f} MB"


def test_an_operator_that_ends_a_macro_is_named_where_the_parse_stops():
    """`\\` at the end of a line is the difference (notation §2), so this D is `sphere \\`:
    the parse stopped at the '∪' after its use, naming neither D nor its operator. An
    operator of the file's own, not from a macro, gets no such note."""
    with pytest.raises(PcsgError) as e:
        compile_text("#define D sphere \\\n  cube\nD ∪ cone\n", "d.pcsg")
    text = e.value.diagnostics[0].format(show_source=False)
    assert "d.pcsg:3:3: error: unexpected '∪', expected an operand" in text
    assert "d.pcsg:3:1: note: the '\\' before it ends the text of macro 'D' (defined at " \
        "d.pcsg:1:9)" in text
    with pytest.raises(PcsgError) as e:
        compile_text("sphere \\ ∪ cone\n", "d.pcsg")
    assert "note" not in e.value.diagnostics[0].format(show_source=False)


def test_macros_that_expand_too_far_are_reported_at_their_use():
    """Forty macros each naming the one before twice: the error had no line and column."""
    lines = ["#define D0 sphere"] + [f"#define D{k} (D{k - 1} ∪ D{k - 1})" for k in range(1, 41)]
    with pytest.raises(PcsgError) as e:
        compile_text("\n".join(lines + ["cube ∪ D40"]) + "\n", "t.pcsg")
    (d,) = e.value.diagnostics
    assert d.format().splitlines()[0] == (
        "t.pcsg:42:8: error: macro 'D40' expands to more than 20,000 uses or 8,000,000 "
        "characters here; nested macros multiply")
