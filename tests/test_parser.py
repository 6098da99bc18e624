"""The notation's syntax (pcsg-notation.md §1-§8): what parses, and into what."""
import math

import numpy as np
import pytest

from pcsg.compiler import compile_text
from pcsg.language import ast, parse
from pcsg.language.unparse import unparse_arith

from .conftest import FIG3A_AS_PRINTED, SIERPINSKI, first_error


def statements(text):
    return parse(text, "t.pcsg")[0].statements


def axiom(text):
    return [s for s in statements(text) if isinstance(s, ast.Axiom)][0].expr


def shape(e):
    """A compact structural print of a CSG AST."""
    if isinstance(e, ast.Ref):
        return e.name
    if isinstance(e, ast.CsgOp):
        return f"{e.op[0].upper()}({shape(e.left)},{shape(e.right)})"
    if isinstance(e, ast.Transform):
        return f"{e.name}[{shape(e.operand)}]"
    if isinstance(e, ast.Calc):
        return f"C{{{','.join(a.name for a in e.assigns)}}}[{shape(e.operand)}]"
    if isinstance(e, ast.Paint):
        return f"paint[{shape(e.operand)}]"
    if isinstance(e, ast.Material):
        return f"material({e.name})[{shape(e.operand)}]"
    raise AssertionError(e)


def value(expr_text, **params):
    """Evaluate an arithmetic expression through parser, compiler and VM."""
    names = list(params)
    block = "; ".join(f"{k} = {v!r}" for k, v in params.items())
    g = compile_text(f"{{{block + ';' if block else ''} zz = {expr_text}}} sphere")
    calc = g.nodes[g.root]
    vals = np.zeros(len(g.params))
    for slot, e in zip(calc.targets, calc.exprs):
        vals[slot] = g.exprs.evaluate(e, vals)
    return vals[g.params["zz"]]


class TestCsgPrecedence:
    def test_difference_binds_tighter_than_intersection_tighter_than_union(self):
        assert shape(axiom("A ∪ B ∩ C \\ D\nA = sphere\nB = cube\nC = cone\nD = cylinder")) \
            == "U(A,I(B,D(C,D)))"

    def test_left_associative(self):
        assert shape(axiom("A \\ B \\ C\nA=sphere\nB=cube\nC=cone")) == "D(D(A,B),C)"
        assert shape(axiom("A ∪ B ∪ C\nA=sphere\nB=cube\nC=cone")) == "U(U(A,B),C)"

    def test_ascii_and_unicode_operators_are_the_same(self):
        u = shape(axiom("sphere ∪ cube ∩ cone ∖ cylinder"))
        a = shape(axiom("sphere | cube & cone \\ cylinder"))
        assert u == a == "U(sphere,I(cube,D(cone,cylinder)))"

    def test_prefix_operators_take_one_operand(self):
        # notation §3: the block decrements c for the first S only
        e = axiom("{c=c-1} move(1,0,0) uscale(0.5) S ∪ move(-1,0,0) uscale(0.5) S\n"
                  "S if(c>0,2,1)\n1: S → sphere\n2: S → sphere")
        assert shape(e) == "U(C{c}[move[uscale[S]]],move[uscale[S]])"

    def test_parentheses_group_for_prefix_operators(self):
        assert shape(axiom("{c=c-1} (A ∪ B)\nA=sphere\nB=cube")) == "C{c}[U(A,B)]"

    def test_paint_and_material_are_prefix(self):
        assert shape(axiom("paint(1,0,0) material(m) sphere ∪ cube\n#material m")) \
            == "U(paint[material(m)[sphere]],cube)"

    def test_all_transformations_parse(self):
        text = ("move(1,2,3) scale(1,2,3) uscale(2) rotx(10) roty(20) rotz(30) rot(45,1,1,0) "
                "zshear(1,2) xshear(1,2) yshear(1,2) flipxy flipxz flipyz mirror(1,0,0) "
                "matrix(1,0,0,0, 0,1,0,0, 0,0,1,0) sphere")
        names = []
        e = axiom(text)
        while isinstance(e, ast.Transform):
            names.append(e.name)
            e = e.operand
        assert names == ["move", "scale", "uscale", "rotx", "roty", "rotz", "rot", "zshear",
                         "xshear", "yshear", "flipxy", "flipxz", "flipyz", "mirror", "matrix"]


class TestLines:
    def test_trailing_operator_joins_lines(self):
        assert shape(axiom("sphere ∪\ncube ∩\n  cone")) == "U(sphere,I(cube,cone))"

    def test_backslash_at_line_end_is_difference_not_continuation(self):
        # Fig. 6 ends a line with '\'
        assert shape(axiom("sphere \\\n cube")) == "D(sphere,cube)"

    def test_open_parenthesis_joins_lines(self):
        assert shape(axiom("move(1,\n 2,\n 3) (sphere\n ∪ cube\n)")) == "move[U(sphere,cube)]"

    def test_arrow_and_equals_join_lines(self):
        st = statements("A =\n  sphere\nS\n1: S →\n  A")
        assert [type(s).__name__ for s in st] == ["Named", "Axiom", "Rule"]

    @pytest.mark.parametrize("op", ["&&", "||", "and", "or", "==", "!=", "<=", ">=", "<", ">",
                                    "+", "-", "*", "/", "%", "^"])
    def test_arithmetic_operator_at_line_end_joins_lines(self, op):
        # '&&' and '==' end with '&' and '=' (§2's letter); no statement ends in any of them
        st = statements(f"{{c = 2}} S\nS c {op}\n  1\n1: S → sphere")
        assert [type(s).__name__ for s in st] == ["Axiom", "ModuleDecl", "Rule"]
        block = axiom(f"{{a = 2 {op}\n 3; b = a}} sphere")
        assert [a.name for a in block.assigns] == ["a", "b"]

    def test_newline_ends_a_statement(self):
        assert first_error("sphere\n∪ cube") == ("2:1: a line cannot start with '∪': to continue "
                                                "the line before, end that line with the "
                                                "operator instead")

    def test_calculation_block_separators(self):
        e = axiom("{a = 1; b = 2, c = 3\n d = 4\n\n} sphere")
        assert [a.name for a in e.assigns] == ["a", "b", "c", "d"]

    def test_a_block_joins_the_lines_between_a_name_and_its_equals(self):
        # §2 joins lines while a '{' is open, §7 separates assignments by newlines: where
        # no assignment can end (after the name it assigns) the lines join
        e = axiom("{a\n=\n1; b\n\n= a, c\n= 2\nd\n= 3} sphere")
        assert [a.name for a in e.assigns] == ["a", "b", "c", "d"]
        assert first_error("{a\n b = 1} sphere").startswith(
            "1:3: unexpected end of line, expected '='")

    def test_block_spanning_lines_inside_parentheses(self):
        e = axiom("rotz(10)({cnt = 1\n} sphere ∪\n {cnt = 2} cube)")
        assert shape(e) == "rotz[U(C{cnt}[sphere],C{cnt}[cube])]"

    def test_comments(self):
        # the operator before a comment still joins the lines (§2: after its comment is removed)
        e = axiom("/* a\n block */ sphere ∪ // line\n /* inline */ cube")
        assert shape(e) == "U(sphere,cube)"
        assert len(statements("sphere // ∪\n")) == 1


class TestArithmetic:
    @pytest.mark.parametrize("text, want", [
        ("1 + 2 * 3", 7), ("(1 + 2) * 3", 9), ("-2^2", -4), ("(-2)^2", 4), ("2^3^2", 512),
        ("2^-1", 0.5), ("7 % 3", 1), ("-7 % 3", 2), ("1 < 2 == 1", 1), ("3 > 2 > 1", 0),
        ("1 || 0 && 0", 1), ("!0 && 1", 1), ("not 1 or 1", 1), ("1 and 0", 0),
        ("12", 12), ("0.5", 0.5), (".5", 0.5), ("1e-3", 0.001), ("2.5E+2", 250),
        ("pi", math.pi), ("if(1 > 2, 10, 20)", 20), ("min(3, 1, 2)", 1), ("max(3, 1)", 3),
        ("abs(-2)", 2), ("sqrt(16)", 4), ("pow(2, 10)", 1024), ("exp(0)", 1), ("ln(1)", 0),
        ("log(exp(2))", 2), ("log10(1000)", 3), ("sin(0)", 0), ("cos(0)", 1), ("tan(0)", 0),
        ("asin(1)", math.pi / 2), ("acos(1)", 0), ("atan(0)", 0), ("atan2(1, 0)", math.pi / 2),
        ("deg(pi)", 180), ("rad(180)", math.pi), ("floor(-1.5)", -2), ("ceil(1.2)", 2),
        ("round(2.5)", 3), ("round(-2.5)", -3), ("clamp(5, 0, 1)", 1),
    ])
    def test_value(self, text, want):
        assert value(text) == pytest.approx(want, rel=1e-12, abs=1e-12)

    def test_parameters_and_ieee(self):
        assert value("x / 0", x=1.0) == math.inf
        assert math.isnan(value("ln(x)", x=-1.0))

    def test_rand_seed_is_deterministic_and_in_range(self):
        a, b = value("rand(42)"), value("rand(x)", x=42.0)
        assert a == b and 0 <= a < 1

    def test_unparse_round_trips_through_the_parser(self):
        for text in ["-(2^2)", "(-2)^2", "2^-1", "a-(b-c)", "a/(b*c)", "!(a && b)",
                     "if(a < b, a, -b) + min(a, b) * 2"]:
            g = compile_text(f"{{a = 1.5; b = -2.25; c = 3; zz = {text}}} sphere")
            expr = g.nodes[g.root].exprs[-1]
            printed = unparse_arith(g.expr_ast[expr])
            assert value(printed, a=1.5, b=-2.25, c=3.0) == value(text, a=1.5, b=-2.25, c=3.0)


class TestStatements:
    def test_fig3a_with_parentheses(self):
        st = statements(SIERPINSKI)
        kinds = [type(s).__name__ for s in st]
        assert kinds == ["Axiom", "ModuleDecl", "Rule", "Rule"]
        rule2 = st[3]
        assert shape(rule2.body) == ("C{c}[U(U(U(move[uscale[S]],move[uscale[S]]),"
                                     "move[uscale[S]]),move[uscale[S]])]")

    def test_fig3a_as_printed_binds_the_block_to_the_first_operand(self):
        rule2 = statements(FIG3A_AS_PRINTED)[3]
        assert shape(rule2.body).startswith("U(U(U(C{c}[move[uscale[S]]],move")

    def test_directives(self):
        st = statements("#camera eye=(3,-4,2) at=(0,0,0.5) up=(0,0,1) fov=40\n"
                        "#light at=(1,2,3) color=(1,1,1) radius=0\n"
                        "#sky horizon=(1,1,1) zenith=(0,0,1)\n"
                        "#material gold color=(1,0.8,0.2) diffuse=0.7 specular=0.3 shininess=40 "
                        "reflect=0 ior=1 transmit=0\nsphere")
        g = compile_text("\n".join(["#camera eye=(3,-4,2) at=(0,0,0.5) up=(0,0,1) fov=40",
                                    "#light at=(1,2,3) color=(1,1,1) radius=0",
                                    "#light at=(-1,2,3) radius=0.5",
                                    "#sky horizon=(1,1,1) zenith=(0,0,1)",
                                    "#material gold color=(1,0.8,0.2) reflect=0.25*2",
                                    "material(gold) sphere"]))
        assert [type(s).__name__ for s in st][:4] == ["Directive"] * 4
        assert g.scene.camera == {"eye": (3, -4, 2), "at": (0, 0, 0.5), "up": (0, 0, 1), "fov": 40}
        assert len(g.scene.lights) == 2 and g.scene.lights[1]["radius"] == 0.5
        assert g.scene.materials["gold"]["reflect"] == 0.5
        assert g.scene.materials["gold"]["diffuse"] == 0.7      # the documented default

    def test_unicode_names_are_rejected_with_a_position(self):
        assert first_error("sphere ∪ würfel").startswith("1:11: unexpected character")
