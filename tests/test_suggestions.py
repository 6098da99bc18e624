"""Diagnostics that say what the mistake most likely was: 'did you mean', the bracket
left open, a warning in the user's terms, and what `check` says that only render said."""
import os

import pytest

from pcsg.cli import main
from pcsg.compiler import compile_text
from pcsg.language.errors import PcsgError
from pcsg.language.suggest import closest

from .test_checks import warnings_of


def diagnostics_of(text: str) -> list:
    """The diagnostics of a file that does not compile."""
    with pytest.raises(PcsgError) as e:
        compile_text(text, "t.pcsg")
    return e.value.diagnostics


def placed(d) -> str:
    return f"{d.location.line}:{d.location.column}: {d.message}"


@pytest.mark.parametrize("name, known, want", [
    ("spher", ["sphere", "cube"], "sphere"),            # a letter left out
    ("Sphere", ["sphere", "cube"], "sphere"),           # case
    ("Cub", ["sphere", "cube"], "cube"),                # case and a letter left out
    ("tetrahedon", ["tetrahedron", "cone"], "tetrahedron"),
    ("fvo", ["eye", "at", "fov"], "fov"),               # two letters swapped
    ("cc", ["c", "d"], "c"),                            # one added
    ("translate", ["move", "scale"], "move"),           # what other CSG tools call it
    ("k", ["c"], None),                                 # one-letter names are all one apart
    ("cube", ["cone", "S"], None),
    ("xyz", ["sphere", "cube"], None),
])
def test_the_closest_known_name(name, known, want):
    assert closest(name, known) == want


@pytest.mark.parametrize("text, message", [
    ("{segments = 3} S\nS if(segmnts > 0, 2, 1)\n1: S → sphere\n2: S → {segments = segments - 1} S\n",
     "undefined name 'segmnts'; did you mean 'segments'?"),
    ("Tree\nTree if(1, 1, 1)\n1: Tree → tree ∪ cube\n", "undefined name 'tree'; did you mean 'Tree'?"),
    ("material(glas) sphere\n#material glass transmit=1\n",
     "unknown material 'glas'; did you mean 'glass'?"),
    ("#camera fvo=30\nsphere\n", "unknown key 'fvo' for #camera; did you mean 'fov'?"),
    ("#camra fov=30\nsphere\n", "unknown directive '#camra'; did you mean '#camera'?"),
    ("move(iff(1, 1, 0), 0, 0) sphere\n", "unknown function 'iff'; did you mean 'if'?"),
])
def test_a_misspelt_name_gets_the_name_it_misspells(text, message):
    found = diagnostics_of(text)
    assert any(d.message.startswith(message) for d in found), [d.message for d in found]


def test_a_bracket_left_open_on_an_earlier_line_is_pointed_at():
    # the parse stops at the next statement, lines below the bracket
    text = ("{c = 1} S\nS if(c > 0, 2, 1)\n1: S → sphere\n2: S → {c = c-1} (move(1,0,0) S ∪\n"
            "  uscale(0.5) S\n\n1: T → cube\n")
    d = diagnostics_of(text)[0]
    assert d.location.line == 7
    (span, note), = d.notes
    assert note == "the '(' opened here is not closed" and text[span[0]] == "("
    assert text.count("\n", 0, span[0]) + 1 == 4


def test_no_axiom_comes_after_the_error_that_took_it():
    # '#camera fov=' joins the next line: the axiom became fov's value
    assert [d.message for d in diagnostics_of("#camera fov=\nsphere\n")] == [
        "'sphere' is a primitive, not a number",
        "no axiom: a file needs one CSG expression to start from, e.g. '{c = 6} S'"]


def test_no_axiom_says_which_line_was_read_as_a_declaration(tmp_path, capsys):
    """`S 1` meant as the axiom declared S with the selection 1, and the error only said
    that there was no axiom."""
    (d,) = diagnostics_of("S 1\n1: S → sphere\nT if(1, 1, 2)\n1: T → S\n2: T → cube\n")
    assert d.message.startswith("no axiom") and d.notes == [
        ((0, 3), "'S 1' is read as the declaration of module 'S' (a name and its selection); "
                 "as the axiom, write a CSG expression alone, e.g. 'S'")]   # not T: 2 rules
    path = tmp_path / "t.pcsg"
    path.write_text("S 1\n1: S → sphere\n", encoding="utf-8")
    assert main(["check", str(path)]) == 1
    assert f"{path}:1:1: note: 'S 1' is read as the declaration" in capsys.readouterr().err


def test_an_endless_cycle_on_a_constant_says_it_is_never_changed():
    # c is folded to 3, so the selection reads no parameter once compiled; the warning
    # called the slip (a decrement left out) a graftal
    w = warnings_of("{c = 3} S\nS if(c > 0, 2, 1)\n1: S → sphere\n"
                    "2: S → move(1,0,0) uscale(0.5) S\n")
    assert [x.message for x in w if x.code == "endless"] == [
        "'S' can call itself here and nothing changes c, which its selection reads (the axiom "
        "sets it once): this cycle never terminates; a block on it such as '{c = c - 1}' "
        "would end it"]


def test_a_parameter_that_is_also_a_named_expression_is_warned_of():
    w = warnings_of("{A = 1} A\nA = sphere\n")
    assert [(x.code, x.message) for x in w] == [
        ("shadowed", "'A' is both a named expression and a parameter")]


@pytest.mark.parametrize("axiom, message", [
    ("scale(1, 0, 1) sphere", "this transformation is singular (a zero scale) or too large "
                              "to invert: it empties its operand"),
    ("uscale(1/0) sphere", "the arguments of this transformation are not finite: it empties "
                           "its operand"),
    ("rot(30, 0, 0, 0) sphere", "the axis or the normal of this transformation is zero: it "
                                "empties its operand"),
    ("paint(0/0, 1, 1) sphere", "the colour of this paint is not finite: it empties its "
                                "operand"),
])
def test_check_warns_of_a_constant_map_that_empties_its_operand(capsys, tmp_path, axiom,
                                                                message):
    # notation §4: reported; check said "ok" and only render's bounding walk said so
    src = tmp_path / "t.pcsg"
    src.write_text(f"{axiom} ∪ move(3, 0, 0) cube\n", encoding="utf-8")
    assert main(["check", str(src)]) == 0
    err = capsys.readouterr().err
    assert f"t.pcsg:1:1: warning: {message}" in err
    assert main(["check", "--werror", str(src)]) == 1
    src.write_text("{s = 0} S\nS 1\n1: S → uscale(s) sphere\n", encoding="utf-8")
    assert main(["check", "-q", str(src)]) == 0          # the axiom's constant folds in
    assert "it empties its operand" in capsys.readouterr().err


@pytest.mark.parametrize("text, where", [
    # a block below the axiom's head: `d` is no constant there, and check said "ok"
    ("{d = 0; a = 10} S ∪ cube\nS 1\n1: S → scale(1, d, 1) sphere\n", (3, 8)),
    ("cube ∪ {d = -1} S\nS 1\n1: S → rotz(30) move(0, 0, ln(d)) sphere\n", (3, 17)),
    # derived: only the third level's instances are empty
    ("{k = 0} S\nS if(k < 3, 2, 1)\n1: S → sphere\n"
     "2: S → {k = k + 1} scale(1, 1, 2 - k) S ∪ move(3, 0, 0) cube\n", (4, 20)),
])
def test_check_warns_of_a_map_that_empties_instances_where_render_does(capsys, tmp_path,
                                                                        text, where):
    # notation §4: reported once; check and render say it at the same place, in the same
    # words ("in some instances": not every instance of the T-node is empty)
    from pcsg.tracer import loads
    src = tmp_path / "t.pcsg"
    src.write_text(text, encoding="utf-8")
    assert main(["check", str(src)]) == 0
    err = capsys.readouterr().err
    said = [line for line in err.splitlines() if "warning:" in line]
    (rendered,) = [w for w in loads(text, "t.pcsg").warnings if w.code.endswith("-map")]
    assert said == [f"{src}:{where[0]}:{where[1]}: warning: {rendered.message}"]
    assert (rendered.location.line, rendered.location.column) == where
    assert "in some instances" in rendered.message


def test_check_says_a_constant_map_once(capsys, tmp_path):
    # the derivation meets it too: "it empties its operand" alone, not also "in some
    # instances"
    src = tmp_path / "t.pcsg"
    src.write_text("uscale(0) sphere ∪ move(3, 0, 0) cube\n", encoding="utf-8")
    assert main(["check", str(src)]) == 0
    said = [line for line in capsys.readouterr().err.splitlines() if "warning:" in line]
    assert said == [f"{src}:1:1: warning: this transformation is singular (a zero scale) or "
                    "too large to invert: it empties its operand"]


@pytest.mark.parametrize("text, want", [
    ("{c = 1} S\nS 1\n1: S → sphere\n2: S → cube\n",
     [(4, "rule 2 of 'S' is never selected: its selection only gives 1")]),
    ("{c = 1} S\nS if(c > 0, 2, 1)\n1: S → sphere\n2: S → {c = c - 1} S\n3: S → cube\n",
     [(5, "rule 3 of 'S' is never selected: its selection only gives 1 or 2")]),
    ("{c = 1} S\nS c + 1\n1: S → sphere\n2: S → cube\n", []),   # --set c=0 picks rule 1
    ("{c = 1} S ∪ {c = 2} S\nS c\n1: S → sphere\n2: S → cube\n", []),
])
def test_a_rule_the_selection_never_names_is_warned_of(text, want):
    got = [(w.location.line, w.message) for w in warnings_of(text) if w.code == "unselected"]
    assert got == want


@pytest.mark.parametrize("paint, want", [
    ("paint(255, 0, 0)", "paint(255, 0, 0): colours are fractions from 0 to 1; above 1"),
    ("paint(-1, 0, 0)", "paint(-1, 0, 0): colours are fractions from 0 to 1: a negative one"),
    ("paint(1, 0.5, 0)", None),
    # both faults said (it said "above 1" only; QA)
    ("paint(2, -1, 0.5)", "paint(2, -1, 0.5): colours are fractions from 0 to 1; above 1 "
                          "shades brighter than the light allows (from bytes 0..255, divide "
                          "by 255); a negative one is drawn as 0"),
    ("{k = 1} paint(k, 0, 2 * k)", "paint(1, 0, 2)"),    # the axiom's constants fold in
])
def test_a_constant_colour_out_of_range_is_warned_of(paint, want):
    got = [w.message for w in warnings_of(f"{paint} sphere\n") if w.code == "paint-range"]
    assert [g[:len(want)] for g in got] == ([want] if want else [])


def test_a_number_past_what_a_double_holds_is_warned_of():
    # it read as inf without a word, where --set c=1e999 is refused (QA)
    w = [(x.location.line, x.location.column, x.message) for x in
         warnings_of("{c = 1e999} S\nS 1\n1: S → move(0, 0, c * 1e-300) sphere\n")
         if x.code == "huge-number"]
    assert w == [(1, 6, "the number 1e999 is too large for a double (at most 1.8e+308): it "
                        "reads as inf")]
    assert not [x for x in warnings_of("{c = 1.7e308} S\nS 1\n1: S → sphere\n")
                if x.code == "huge-number"]


def test_a_number_too_small_for_a_double_is_warned_of():
    # it read as 0 without a word, where 1e999 is warned of and --set refuses both (QA)
    w = [(x.location.line, x.location.column, x.message) for x in
         warnings_of("move(1e-400, 0, 0) scale(1, 0.0e-5, 4.9e-324) sphere\n")
         if x.code == "tiny-number"]
    assert w == [(1, 6, "the number 1e-400 is too small for a double (at least 4.9e-324 in "
                        "size): it reads as 0")]
    # a parameter set to 0 keeps the place of the number it replaces, which is no 0 (QA)
    from pcsg.compiler import compile_text
    graph = compile_text("{r = 1} uscale(r) sphere\n", overrides={"r": 0.0})
    assert not [x for x in graph.warnings if x.code == "tiny-number"]


@pytest.mark.parametrize("text, want", [
    ("#material m color=(1,0,0)\n#material m color=(0,1,0)\nsphere\n",
     (2, "material 'm' is defined twice (first at t.pcsg:1:1)")),
    ("#sky color=(1,1,1)\nsphere\n#sky color=(0,0,0)\n",
     (3, "a second #sky; a file has at most one (first at t.pcsg:1:1)")),
])
def test_a_directive_given_twice_names_the_first(text, want):
    # as a named expression or a macro given twice does (QA)
    from .conftest import errors_of
    assert [(e.location.line, e.message) for e in errors_of(text)] == [want]


@pytest.mark.parametrize("name", ["x.jpg", "x.pcsg", "x", "x.npy"])
def test_an_output_not_named_png_is_a_usage_error(capsys, tmp_path, name):
    # PNG bytes under another image's name, or over a grammar (-o other.pcsg replaced it)
    from .conftest import GRAMMARS
    out = tmp_path / name
    if name == "x.pcsg":
        out.write_text("sphere\n", encoding="utf-8")
    assert main(["render", str(GRAMMARS / "sierpinski.pcsg"), "-o", str(out)]) == 2
    assert f"-o {out}: pcsg writes PNG images; name the file x.png" in capsys.readouterr().err
    assert [p.name for p in tmp_path.iterdir()] == (["x.pcsg"] if name == "x.pcsg" else [])
    assert name != "x.pcsg" or out.read_text(encoding="utf-8") == "sphere\n"


def test_a_value_that_is_not_finite_is_said_as_nan_or_inf(capsys, tmp_path):
    src = tmp_path / "t.pcsg"
    src.write_text("{c = 0/0} S\nS if(c < 1, 1, 2)\n1: S → sphere\n"
                   "2: S → {c = c - 1} uscale(0.5) S\n", encoding="utf-8")
    assert main(["stats", str(src)]) == 0
    assert "(c = nan)" in capsys.readouterr().out


@pytest.mark.parametrize("text, message", [
    ("move(−1, 0, 0) sphere\n", "1:6: unexpected character '−' (U+2212): write '-' instead"),
    ("sphere ⋃ cube\n", "1:8: unexpected character '⋃' (U+22C3): write '∪' or '|' instead"),
    ("{c = 1} S\nS c ? 1 : 2\n1: S → sphere\n2: S → cube\n",
     "2:5: unexpected character '?': the notation has no 'c ? a : b'; write if(c, a, b)"),
    ("café = sphere\ncafé\n",
     "1:4: unexpected character 'é': names are ASCII letters, digits and '_' (notation §1)"),
])
def test_a_lookalike_character_is_named_with_what_to_write(text, message):
    assert placed(diagnostics_of(text)[0]) == message


def test_a_chained_comparison_is_warned_of():
    # (1 < c) < 3 is true whatever c is
    w = warnings_of("{c = 2} S\nS if(1 < c < 3, 2, 1)\n1: S → sphere\n2: S → {c = c - 1} S\n")
    assert [(x.code, x.location.column, x.message) for x in w if x.code == "chained"] == [
        ("chained", 6, "'1 < c < 3' compares (1 < c), 0 or 1, with 3; for both, write "
                       "'1 < c && c < 3'")]
    assert not [x for x in warnings_of("{c = 2} S\nS if(1 < c && c < 3, 2, 1)\n1: S → sphere\n"
                                       "2: S → {c = c - 1} S\n") if x.code == "chained"]
    # brackets say it is meant (the warning quoted it without them); (1) < c < 3 does not
    for text, said in [("(1 < c) < 3", 0), ("((1 < c)) < 3", 0), ("(1) < c < 3", 1),
                       ("(1) < (c) < 3", 1)]:
        w = warnings_of(f"{{c = 2}} S\nS if({text}, 2, 1)\n1: S → sphere\n"
                        "2: S → {c = c - 1} S\n")
        assert len([x for x in w if x.code == "chained"]) == said, text


def test_check_warns_of_a_derivation_that_meets_its_own_state_again(capsys, tmp_path):
    # stats failed on it and check said ok; pixels-ended systems and graftals are fine
    src = tmp_path / "t.pcsg"
    src.write_text("{c = 3/0} S\nS if(c > 0, 2, 1)\n1: S → sphere\n"
                   "2: S → {c = c - 1} uscale(0.5) S\n", encoding="utf-8")
    assert main(["check", str(src)]) == 0
    assert ("2:1: warning: the derivation never ends: 'S' repeats with the same parameters "
            "(c = inf): a render refines it to pixel size where its transformations shrink "
            "it, else to --max-depth") in capsys.readouterr().err
    src.write_text("S\nS if(pixels > 2, 2, 1)\n1: S → sphere\n"
                   "2: S → move(1, 0, 0) uscale(0.5) S ∪ sphere\n", encoding="utf-8")
    assert main(["check", str(src)]) == 0
    assert "never ends" not in capsys.readouterr().err


@pytest.mark.parametrize("text, first", [
    # a group that closes on a later line: no note that it is open
    ("{c = 1} S\nS if(c > 0, 2, 1)\n1: S → sphere\n2: S → {c = c-1} (move(1,0,0) S ∪\n"
     "   move(-1,0,0) S S ∪\n   move(0,1,0) S)\n",
     "5:19: expected an operator (∪, ∩ or \\) between 'S' and 'S'"),
    # a directive without its '=' is no transformation
    ("#sky color (1, 1, 1)\nsphere\n", "1:6: a directive's setting is written NAME=VALUE: "
     "'color=(1, 1, 1)'"),
    # in a calculation block the slip is a separator left out
    ("{a = 1; c = 1 - not (a) b = 2} sphere\n", "1:25: unexpected 'b'"),
    # a flip of a group takes no arguments, but is not given any: an operator is missing
    ("flipxy (sphere ∪ cube) cone\n", "1:24: expected an operator (∪, ∩ or \\) before 'cone'"),
    # '=' outside brackets is no comparison
    ("let seg = sphere\nseg\n", "1:9: unexpected '='"),
    # ASCII arrow, and a '#' comment after a statement
    ("S\nS -> sphere\n", "2:1: a rule starts with its number"),
    ("S\n1: S → sphere # the ball\n", "2:15: '#' does not start a comment"),
    # a rule without its number and arrow reads as a declaration with a selection
    ("{c = 1} T\nT move(1,0,0) sphere\n", "2:1: 'T move(1,0,0)' reads as module 'T' with "
     "the selection move(1,0,0); a rule is written '1: T → move(1,0,0) sphere'"),
    ("{c = 1} T\nT if(c > 0, 2, 1) sphere\n", "2:19: unexpected 'sphere'"),
])
def test_the_slip_hints_hold_back_where_the_slip_is_another(text, first):
    d = diagnostics_of(text)[0]
    assert placed(d).startswith(first)
    if first.startswith("5:19"):
        assert not d.notes


@pytest.mark.parametrize("text, first", [
    # calculations' logical operators between operands: the parse stopped after them
    ("sphere and cube\n", "1:8: 'and' is the logical and of calculations (notation §6); "
     "the intersection of two operands is written '∩' or '&'"),
    ("sphere || cube\n", "1:8: '||' is the logical or of calculations (notation §6); "
     "the union of two operands is written '∪' or '|'"),
    ("S\n1: S → sphere && move(1, 0, 0) cube\n", "2:15: '&&' is the logical and"),
    ("S\n1: S → sphere or cube\n", "2:15: 'or' is the logical or"),
    # and the CSG operators where a calculation's logical one may stand
    ("{c = 1; d = 1} S\nS if(c > 0 & d > 0, 1, 1)\n1: S → sphere\n", "2:12: '&' is the "
     "intersection of two operands; the logical and of calculations is written '&&' or 'and'"),
    ("{c = 1 ∪ 0} sphere\n", "1:8: '∪' is the union of two operands; the logical or of "
     "calculations is written '||' or 'or'"),
    # a flip given a parameter: the bracket read as the operand it flips
    ("{c = 1} flipxy(c) sphere\n", "1:9: 'flipxy' takes no arguments: a '(...)' after it "
     "is the operand it applies to"),
    ("{c = 1} flipyz(c * 2) sphere\n", "1:9: 'flipyz' takes no arguments"),
    ("flipxz() sphere\n", "1:1: 'flipxz' takes no arguments"),
    # a bracket of modules is a group: the operator between them is what is missing
    ("S\n1: S → flipxy (S T)\nT 1\n1: T → cube\n", "2:18: expected an operator"),
    # a primitive with a number after it: no module's declaration, since it is reserved
    ("sphere 1\n", "1:8: 'sphere' is a primitive, a reserved name, so 'sphere ...' declares "
     "no module; as an axiom it needs an operator"),
    # a prefix macro used above its #define: said beside the slip it makes
    ("Y sphere\n#define Y move(1,0,0)\n", "1:3: expected an operator (∪, ∩ or \\) between "
     "'Y' and 'sphere' (a macro defined below, at 2:9"),
])
def test_slips_said_as_themselves(text, first):
    assert placed(diagnostics_of(text)[0]).startswith(first)


def test_logical_operators_inside_calculations_stay_valid():
    compile_text("{c = 1 and 0 || 1} S\nS if(c or 0, 1, 1)\n1: S → sphere\n", "t.pcsg")


def test_an_axiom_slip_leaves_the_module_its_declaration():
    # `S - cube` with two rules: also "has 2 rules but no selection" before
    assert [d.message[:36] for d in diagnostics_of("S - cube\n1: S → sphere\n2: S → cube\n")] \
        == ["'-' is not a CSG operator: the diffe"]
    # a selection reading a module: not a slip
    found = diagnostics_of("S if(c > 0, T, 1)\n1: S → sphere\n2: S → T\n1: T → cube\n")
    assert not any("expected an operator" in d.message for d in found)


@pytest.mark.parametrize("text", [
    "{style = 2} S\nS style\n1: S → sphere\n2: S → cube\n",         # --set style=1 picks 1
    "S\nS 2\n1: S → sphere\n2: S → sphere ∪ move(1,0,0) uscale(0.5) S\n",   # 1 finishes at pixel size
])
def test_rules_that_are_picked_otherwise_are_not_called_unselected(text):
    assert not [w for w in warnings_of(text) if w.code == "unselected"]


def test_a_tiled_picture_of_nothing_says_so(capsys, tmp_path):
    src = tmp_path / "away.pcsg"      # (test_cli.test_a_picture_of_nothing_says_so)
    src.write_text("#camera eye=(0, -5, 0) at=(0, -10, 0)\nsphere\n", encoding="utf-8")
    assert main(["render", str(src), "--size", "40x30", "--tiles", "3",
                 "-o", str(tmp_path / "a.png")]) == 0
    assert "warning: no ray met the object" in capsys.readouterr().err


@pytest.mark.parametrize("text, message", [
    ("X\n#define X sphere\n", "1:1: undefined name 'X' (a macro defined below, at 2:9: a macro "
                              "stands for its text only after its #define)"),
    ("{c = K} sphere\n#define K 2\n", "1:6: undefined name 'K' (a macro defined below, at 2:9"),
    # where a guess was said instead (a box, 'cube'?), or the parse stopped after a prefix
    ("S ∪ BOX\n1: S → sphere\n#define BOX cube\n",
     "1:5: undefined name 'BOX' (a macro defined below, at 3:9"),
    ("{c = 1} S\nS if(c > 0, 2, 1)\n1: S → sphere\n2: S → DEC S\n#define DEC {c = c - 1}\n",
     "4:12: expected an operator (∪, ∩ or \\) between 'DEC' and 'S' ('DEC': a macro defined "
     "below, at 5:9"),
    ("{c = 1} S\nS if(c > 0, 2, 1)\n1: S → sphere\n2: S → {c = c - 1} T S\n"
     "#define T move(1, 0, 0)\n", "4:22: expected an operator (∪, ∩ or \\) between 'T' and 'S' "
                                  "('T': a macro defined below, at 5:9"),
    # a macro that names itself: not below, and not replaced within itself
    ("#define A A ∪ sphere\nA\n",
     "2:1: undefined name 'A' (in the replacement of macro 'A' itself"),
])
def test_a_macro_read_before_its_define_is_said_to_be_below(text, message):
    assert placed(diagnostics_of(text)[0]).startswith(message)


def test_text_after_a_block_replacement_is_said():
    # §2: a replacement that starts with '{' is the block; ' S' stayed the file's axiom,
    # and the error at the use said nothing of it
    said = [placed(d) for d in diagnostics_of("#define AX {c = 2} S\nAX\n")]
    assert said[0].startswith("1:20: 'S' after the block that is macro 'AX''s replacement is "
                              "not part of it")
    assert not warnings_of("#define B {c = c - 1} // a comment\n{c = 1} S\n"
                           "S if(c > 0, 2, 1)\n1: S → sphere\n2: S → B uscale(0.5) S\n")


def test_a_material_that_reflects_and_lets_through_more_than_comes_is_warned_of():
    w = warnings_of("#material m reflect=0.6 transmit=0.8\nmaterial(m) sphere\n")
    assert [(x.code, x.message) for x in w] == [
        ("material", "material 'm': reflect + transmit is 1.4, over 1: it reflects 0.6 and "
                     "more, and lets through what is left")]
    assert not warnings_of("#material m reflect=0.2 transmit=0.8\nmaterial(m) sphere\n")


def test_a_sky_colour_that_both_ends_replace_is_warned_of():
    # notation §8 gives the two forms as alternatives; given together, color was dropped
    w = warnings_of("#sky color=(1, 1, 1) horizon=(1, 0, 0) zenith=(0, 0, 1)\nsphere\n")
    assert [(x.code, placed(x)) for x in w] == [
        ("directive", "1:6: #sky: 'color' colours nothing where 'horizon' and 'zenith' are "
                      "both given (each end is its own key's); leave one out")]
    assert not warnings_of("#sky color=(1, 1, 1) horizon=(1, 0, 0)\nsphere\n")


@pytest.mark.parametrize("text, said", [
    # a constant byte beside computed ones: warned only where all three were constants
    ("{n = 2} S\nS if(n > 0, 2, 1)\n1: S → sphere\n2: S → {n = n - 1} "
     "paint(255, 200 - 3 * n, 120) S\n", "4:20: paint(255, …, 120): colours are fractions"),
    ("#camera eye=(3, 3, 3) look_at=(0, 0, 0)\nsphere\n", "1:23: unknown key 'look_at' for "
                                                         "#camera; did you mean 'at'?"),
    ("move(t, 0, 0) sphere\n", "1:6: undefined name 't' (`pcsg animate` sets t only where "
                               "the axiom assigns it"),
    # a light's position is its `at`; where a light faces is nothing it has
    ("#light position=(1, 2, 3)\nsphere\n", "1:8: unknown key 'position' for #light; did "
                                           "you mean 'at'?"),
    ("#light target=(1, 2, 3)\nsphere\n", "1:8: unknown key 'target' for #light (known:"),
    # it stood at (0, 0, 10) whatever the object and the camera
    ("#light color=(1, 0, 0)\nsphere\n", "1:1: #light needs at=(x,y,z), where the light "
                                         "stands"),
    # abbreviations
    ("#material m refl=0.5\nmaterial(m) sphere\n", "1:13: unknown key 'refl' for #material; "
                                                     "did you mean 'reflect'?"),
    ("#occlusion samples=8 dist=2\nsphere\n", "1:22: unknown key 'dist' for #occlusion; did "
                                               "you mean 'distance'?"),
])
def test_more_slips_said_as_themselves(text, said):
    try:
        found = compile_text(text, "t.pcsg").warnings
    except PcsgError as e:
        found = e.diagnostics
    assert placed(found[0]).startswith(said)


def test_an_output_link_to_a_file_not_named_png_is_refused_and_dev_stdout_is_written(
        capsys, tmp_path):
    import subprocess
    import sys
    from .conftest import GRAMMARS, ROOT
    victim = tmp_path / "victim.pcsg"
    victim.write_text("sphere\n", encoding="utf-8")
    (tmp_path / "link.png").symlink_to(victim)
    sierpinski = str(GRAMMARS / "sierpinski.pcsg")
    assert main(["render", sierpinski, "-o", str(tmp_path / "link.png")]) == 2
    assert "which is no .png" in capsys.readouterr().err
    assert victim.read_text(encoding="utf-8") == "sphere\n"
    # /dev/stdout redirected to a file is that file, a regular one not named .png
    with open(tmp_path / "out.png", "wb") as out:
        p = subprocess.run([sys.executable, "-m", "pcsg", "render", sierpinski, "-o",
                            "/dev/stdout", "--size", "32x24", "-q"], cwd=ROOT, stdout=out,
                           stderr=subprocess.PIPE, timeout=600)
    assert p.returncode == 0, p.stderr
    from PIL import Image
    with Image.open(tmp_path / "out.png") as image:
        image.load()
        assert image.size == (32, 24)


def test_an_output_under_dev_is_no_device_by_its_name(capsys, tmp_path):
    # /dev/shm/other.pcsg, a grammar, was written over as "/dev/" things are
    from pathlib import Path
    from .conftest import GRAMMARS
    shm = Path("/dev/shm")
    if not shm.is_dir():
        pytest.skip("no /dev/shm")
    other = shm / f"pcsg-test-{os.getpid()}.pcsg"
    other.write_text("sphere\n", encoding="utf-8")
    try:
        assert main(["render", str(GRAMMARS / "sierpinski.pcsg"), "-o", str(other)]) == 2
        assert other.read_text(encoding="utf-8") == "sphere\n"
    finally:
        other.unlink()
    capsys.readouterr()


@pytest.mark.parametrize("rules, message", [
    ("1: S → sphere\n2: Ss → {c = c-1} uscale(0.5) S\n",
     "4:1: rules of 'Ss' must be numbered 1..1; rule 2 leaves a gap (missing: 1); "
     "did you mean 'S'?"),
    ("1: S → sphere\n2: S → uscale(0.5) S\n1: Ss → sphere\n2: Ss → {c = c-1} S\n",
     "5:4: module 'Ss' has 2 rules but no selection; declare one, e.g. "
     "'Ss if(..., 2, 1)'; did you mean 'S'?"),
])
def test_a_rule_head_that_misspells_a_module_names_it(rules, message):
    text = "{c = 2} S\nS if(c > 0, 2, 1)\n" + rules
    assert [placed(d) for d in diagnostics_of(text)] == [message]


@pytest.mark.parametrize("text, message", [
    ("{c == 1} sphere\n", "1:4: '==' compares; a calculation block assigns with '='"),
    ("{v = 3 =< 4} sphere\n", "1:8: '=<' is written '<='"),
    ("{v = 1.2.3} sphere\n", "1:6: a number has one decimal point: '1.2.3'"),
    ("{1 = c} sphere\n", "1:2: an assignment sets a parameter: its left side is a name"),
    ("sphere;\n", "1:7: ';' separates the assignments of a calculation block"),
    ("#camera eye (3,-4,2)\nsphere\n",
     "1:9: a directive's setting is written NAME=VALUE: 'eye=(3,-4,2)'"),
    ("#camera fov 40\nsphere\n", "1:9: a directive's setting is written NAME=VALUE: 'fov=40'"),
    # a module's selection is the one unbracketed expression of a line
    ("{c = 1} S\nS c = 0\n1: S → sphere\n2: S → cube\n",
     "2:5: '=' assigns; to compare, write '==' (the line reads as the declaration of module 'S'"),
])
def test_a_slip_of_one_token_is_said_as_what_was_meant(text, message):
    """Where the parser's list of what it would take there was said (QA, session 74)."""
    assert placed(diagnostics_of(text)[0]).startswith(message)


def test_a_bracket_this_line_leaves_open_is_pointed_at_once():
    d = diagnostics_of("{c = 1 S\n")[0]
    assert placed(d).startswith("1:8: unexpected 'S'")
    assert [(note, d.source.location(span[0]).column) for span, note in d.notes] == \
        [("the '{' opened here is not closed", 1)]
    assert not diagnostics_of("{c = 1 S}\n")[0].notes     # closed later: a separator missing
    d = diagnostics_of("X = (sphere ∪ cube\n")[0]
    assert placed(d) == "1:5: unexpected end of file: '(' is never closed" and not d.notes
