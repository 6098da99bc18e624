"""Static checks: definite assignment over the cyclic graph, termination and contraction."""
import numpy as np
import pytest

from pcsg.compiler import compile_file, compile_text
from pcsg.graph.bounds import bound
from pcsg.graph.checks import derivation_faults
from pcsg.graph.stats import count_by_primitive
from pcsg.graph.volumes import graftal_nodes

from .conftest import FIG3A_AS_PRINTED, GRAMMARS, SIERPINSKI, errors_of


def warnings_of(text):
    return compile_text(text, "t.pcsg").warnings


class TestDefiniteAssignment:
    def test_assigned_on_every_path(self):
        compile_text("{c = 1} S ∪ {c = 2} S\nS if(c > 0, 2, 1)\n1: S → sphere\n2: S → {c = c-1} S")

    def test_assigned_on_some_paths_only(self):
        errs = errors_of("{c = 1} S ∪ S\nS if(c > 0, 2, 1)\n1: S → sphere\n2: S → {c = c-1} S")
        assert [(e.location.line, e.location.column, e.code) for e in errs] == \
            [(2, 6, "unassigned"), (4, 13, "unassigned")]

    def test_assignment_inside_the_cycle_does_not_count_for_the_first_visit(self):
        # S is first reached without d; the cycle assigns it, but too late
        errs = errors_of("{c = 2} S\nS if(c > 0, 2, 1)\n1: S → move(d, 0, 0) sphere\n"
                         "2: S → {c = c-1; d = 1} S")
        assert errs[0].message.startswith("parameter 'd' may be read before it is assigned")
        assert (errs[0].location.line, errs[0].location.column) == (3, 13)

    def test_a_paint_reads_the_blocks_above_it_not_below(self):
        # the axiom's constants were folded into the paint from the block below it: no
        # error, and a render and expand used c = 1
        errs = errors_of("paint(c, 1, 0) {c = 1} sphere\n")
        assert [(e.location.line, e.location.column, e.code) for e in errs] == [(1, 7, "unassigned")]
        graph = compile_text("{c = 0.2} paint(c, 1, 0) {d = 1} paint(d, 0, 0) sphere\n")
        paints = [n for n in graph.nodes if n.kind_name == "paint"]
        assert sorted(graph.exprs.constant(n.exprs[0]) for n in paints) == [0.2, 1.0]

    def test_shared_named_expression_needs_it_on_all_uses(self):
        compile_text("{r = 1} A ∪ {r = 2} move(1,0,0) A\nA = uscale(r) sphere")
        errs = errors_of("{r = 1} A ∪ move(1,0,0) A\nA = uscale(r) sphere")
        assert errs[0].location.line == 2

    def test_unreachable_modules_are_not_checked_but_reported(self):
        w = warnings_of("{p = 1} sphere\n1: T → uscale(q) sphere ∪ {q = 1} sphere")
        assert [x.code for x in w] == ["unused"]


class TestTermination:
    def test_a_cycle_through_a_module_whose_selection_changes_ends(self):
        # S → T → S, where T's block counts down what S reads: T was warned of as a graftal
        text = ("{c = 3} S\nS if(c > 0, 2, 1)\n1: S → sphere\n"
                "2: S → move(1,0,0) uscale(0.5) T\n1: T → {c = c - 1} S\n")
        assert [w for w in warnings_of(text) if w.code == "endless"] == []
        # without the countdown, S is the one warned of, once
        w = [w for w in warnings_of(text.replace("{c = c - 1} ", "")) if w.code == "endless"]
        assert [x.message.split(" can")[0] for x in w] == ["'S'"]

    def test_a_cycle_that_grows_in_some_direction_is_reported(self):
        # it shrinks in y and z, so "shrinks in no direction" passed it; its bounds reach
        # 1e12 in x and the picture framed to them showed nothing
        w = warnings_of("{c = 1} S\nS if(c > 0, 2, 1)\n1: S → sphere\n"
                        "2: S → {c = c + 1} (sphere ∪ move(2, 0, 0) scale(1.5, 0.5, 0.5) S)\n")
        assert [x.code for x in w] == ["non-contracting"]
        assert "grow it in some direction (by 25.6 over the 8 cycles followed)" in w[0].message
        assert w[0].message.endswith("its derivation does not end within 1,000 levels from "
                                     "here")
        # the terrain's scale(0.5, 0.5, 1) keeps z and grows nothing: not reported
        assert warnings_of("S\nS if(pixels > 2, 2, 1)\n1: S → sphere\n"
                           "2: S → sphere ∪ move(2, 0, 0) scale(0.5, 0.5, 1) S\n") == []

    def test_a_cycle_the_derivation_never_takes_round_is_not_reported(self):
        # B is reached only where n is spent: its rule 2 never runs (stats counts 4)
        assert warnings_of("{n = 3} A\nA if(n > 0, 2, 1)\n1: A → B\n2: A → {n = n - 1} "
                           "move(0, 0, 2) A ∪ cube\nB if(n > 0, 2, 1)\n1: B → sphere\n"
                           "2: B → cube ∪ move(1, 0, 0) B\n") == []

    def test_a_count_running_away_on_a_shrinking_cycle_is_said_by_check(self, capsys,
                                                                        tmp_path):
        # the level of detail ends its picture, but the derivation never ends: check said ok
        from pcsg.cli import main
        src = tmp_path / "t.pcsg"
        src.write_text("{i = 0} R\nR if(i < 8, 2, 1)\n1: R → cube\n"
                       "2: R → cube ∪ {i = i - 1} move(2, 0, 0) uscale(0.8) R\n", encoding="utf-8")
        assert main(["check", "--werror", str(src)]) == 1
        assert ("warning: the derivation goes deeper than 1000 levels: 'R' is still being "
                "rewritten there (i = -1000): a count running away from its end?") in \
            capsys.readouterr().err

    def test_a_derivation_that_ends_past_what_a_render_follows_is_said_by_check(
            self, capsys, tmp_path):
        """A chain of 5,000 levels ends, but a render cuts it at 64 and says so: check said
        ok (only a count past 10,000 levels was warned of), where the README says it warns
        past 1,000 (QA). The render's words, with its depth."""
        from pcsg.cli import main
        src = tmp_path / "t.pcsg"
        chain = ("S if(c > 0, 2, 1)\n1: S → sphere\n"
                 "2: S → {c = c - 1} (cube ∪ uscale(0.9) move(1, 0, 0) S)\n")
        src.write_text("{c = 5000} S\n" + chain, encoding="utf-8")
        assert main(["check", "--werror", str(src)]) == 1
        assert ("t.pcsg:2:1: warning: the derivation ends 5,000 levels down, deeper than the "
                "1,000 a render follows without --max-depth: it is cut at 64; --max-depth "
                "5001 draws it whole") in capsys.readouterr().err
        src.write_text("{c = 999} S\n" + chain, encoding="utf-8")
        assert main(["check", "--werror", str(src)]) == 0

    def test_a_module_between_that_counts_down_ends_the_cycle(self):
        # T counts n down on the way round: SEG, reading a constant flag, was "endless"
        assert [x for x in warnings_of(
            "{n = 5; thick = 1} T\nT if(n > 0, 2, 1)\nSEG if(thick > 0, 1, 2)\n"
            "1: T → sphere\n2: T → {n = n - 1} SEG\n1: SEG → cylinder ∪ move(0, 0, 1) "
            "uscale(0.7) T\n2: SEG → cone ∪ move(0, 0, 1) uscale(0.7) T\n")
            if x.code == "endless"] == []

    def test_a_graftal_through_a_random_choice_is_counted_not_warned_of(self):
        # every choice of S returns to T, whose selection reads nothing: a graftal, which
        # the render refines to pixel size (its maps contract); check counts it
        graph = compile_text("S\nS if(rand() < 0.5, 1, 2)\n1: S → T\n2: S → cube ∪ T\n"
                             "1: T → sphere ∪ move(2, 0, 0) uscale(0.5) S\n", "t.pcsg")
        assert graph.warnings == [] and derivation_faults(graph) == ([], [])
        assert [graph.nodes[s].name for s in graftal_nodes(graph)] == ["S", "T"]

    def test_a_module_between_does_not_hide_a_cycle_that_never_changes_what_s_reads(self):
        # T counts d down and returns to S, which reads c, never changed: S is endless
        w = warnings_of("{c = 3; d = 2} S\nS if(c > 0, 2, 1)\n1: S → sphere\n"
                        "2: S → {d = 20000} T\nT if(d > 0, 2, 1)\n1: T → uscale(0.5) S\n"
                        "2: T → {d = d - 1} uscale(0.9) T\n")
        assert [x.message.split(" can")[0] for x in w if x.code == "endless"] == ["'S'"]
        # two modules that call each other, each reading a constant: both are said
        w = warnings_of("{c = 3; d = 2} S\nS if(c > 0, 2, 1)\n1: S → sphere\n"
                        "2: S → uscale(0.5) T\nT if(d > 0, 2, 1)\n1: T → cube\n"
                        "2: T → move(1, 0, 0) S\n")
        assert sorted(x.message.split(" can")[0] for x in w if x.code == "endless") == \
            ["'S'", "'T'"]

    def test_a_cycle_through_a_rule_never_selected_is_no_cycle(self):
        w = warnings_of("{c = 2} S\nS 1\n1: S → sphere\n2: S → {c = c - 1} S\n")
        assert [x.code for x in w] == ["unselected"]

    def test_fig3a_as_printed_never_terminates(self):
        w = [x for x in warnings_of(FIG3A_AS_PRINTED) if x.code == "endless"]
        assert len(w) == 1
        assert w[0].message.startswith("'S' can call itself here without changing c")
        assert (w[0].location.line, w[0].location.column) == (5, 44)
        assert len(w[0].notes) == 2          # the other two branches

    def test_fig3a_with_parentheses_is_clean(self):
        assert warnings_of(SIERPINSKI) == []

    def test_a_graftal_is_no_warning_where_its_maps_contract(self):
        # a module of one rule that calls itself is written as a graftal (the samples
        # failed `check --werror`); one whose maps shrink nothing is warned of, in check
        # and render alike, as the render can neither bound it nor end it
        assert warnings_of("S\n1: S → sphere ∪ move(2,0,0) uscale(0.5) S") == []
        text = "S\nS 1\n1: S → move(1, 0, 0) S ∪ move(0, 0, 1) uscale(0.5) S\n"
        graph = compile_text(text, "g.pcsg")
        [w] = derivation_faults(graph)[1]
        assert w.code == "non-contracting" and "'S' is a graftal" in w.message
        assert "no primitive stands on its cycles either, so `render` draws nothing" in \
            w.message
        assert [p.message for p in bound(graph)[2]] == [w.message]
        # not a graftal, but a state that recurs without end through such maps: named, with
        # a contracting graftal beside it (the first version raised an IndexError for the
        # one, and blamed the graftal beside it for the other)
        for head in ("{c = 1} H\n", "{c = 1} (G ∪ move(3, 0, 0) H)\n"
                     "1: G → cube ∪ uscale(0.5) (move(1, 0, 0) G ∪ move(-1, 0, 0) G)\n"):
            graph = compile_text(head + "H if(c > 0, 2, 1)\n1: H → cube\n"
                                 "2: H → move(1, 0, 0) H ∪ rotz(90) H\n", "h.pcsg")
            # (the warning comes before the walk of its instances, whose budget it spares:
            # the default one took 10 s of each)
            [w] = [p for p in bound(graph, budget=10_000)[2] if p.code == "non-contracting"]
            assert w.message.startswith("'H' calls itself without end")
        # the one whose own maps do not contract, not one above it that grows with it
        for both in ("A\n1: A → cube ∪ uscale(0.3) S ∪ uscale(0.5) move(2, 0, 0) A\n"
                     "1: S → move(1, 0, 0) S ∪ uscale(0.5) S\n",
                     "S ∪ A\n1: S → move(1, 0, 0) S ∪ uscale(0.5) S\n"
                     "1: A → cube ∪ uscale(0.3) S ∪ uscale(0.5) move(2, 0, 0) A\n"):
            [w] = derivation_faults(compile_text(both, "g.pcsg"))[1]
            assert w.message.startswith("'S' is a graftal")
        # rotz(90) scale(1.5, 0.5, 0.5) stretches x into y, and contracts over two cycles:
        # its attractor, a line on the z axis, is bounded (the growth of its box was not)
        graph = compile_text(text.replace("move(1, 0, 0)", "rotz(90) scale(1.5, 0.5, 0.5)"),
                             "g.pcsg")
        assert derivation_faults(graph) == ([], [])
        boxes, method = bound(graph)[:2]
        assert method == "memoised"
        np.testing.assert_allclose(boxes[graph.root], [0, 0, 0, 0, 0, 2], atol=1e-8)

    @pytest.mark.parametrize("axiom", ["S", "S ∪ move(3, 0, 0) cube"])
    @pytest.mark.parametrize("rule", ["S ∪ move(1, 0, 0) S", "S", "S ∪ uscale(0.5) S"])
    def test_a_graftal_without_primitives_whose_maps_do_not_contract_is_empty(self, axiom,
                                                                               rule):
        """It has no attractor: nothing to draw, and nothing to bound. Walked instance by
        instance, every ray entered --max-instances instances of the first (68 s at
        160x120) to draw nothing; the others keep any ball, and the ball was drawn at
        the depth limit as if it held an attractor (`S → S ∪ rotz(90) S` is bounded by
        the point both maps keep, and draws nothing). Now its box is empty, and the rest
        is bounded as usual."""
        from pcsg.graph.cut import cut_of
        from pcsg.trace.reference import Reference
        from pcsg.tracer import Traced
        graph = compile_text(f"{axiom}\nS 1\n1: S → {rule}\n", "v.pcsg")
        [w] = derivation_faults(graph)[1]
        assert "so `render` draws nothing of it" in w.message
        traced = Traced(graph, max_depth=3)
        assert traced.bounds_method == "memoised"
        assert w.message in [p.message for p in traced.warnings]
        s = graph.modules["S"]
        assert traced.boxes[s, 0] > traced.boxes[s, 3]          # empty
        origins = np.array([[x, 0.0, -5.0] for x in (-0.5, 0.0, 0.5, 1.5, 2.5, 3.0, 3.5)])
        directions = np.tile([0.0, 0.0, 1.0], (len(origins), 1))
        hits = traced.trace(origins, directions)
        ref = Reference(traced.graph, cut=cut_of(traced)).trace(origins, directions)
        cube = [axiom != "S" and x >= 2.5 for x in origins[:, 0]]
        assert hits.hit.tolist() == ref["hit"].tolist() == cube
        assert not traced.describe_events(hits.events)      # no walk cut short

    def test_a_graftal_whose_maps_keep_a_ball_keeps_its_primitives(self):
        # with a primitive on its cycle it is drawn as far as the depth limit goes
        from pcsg.tracer import Traced
        traced = Traced(compile_text("S\nS 1\n1: S → S ∪ sphere\n", "p.pcsg"), max_depth=3)
        hits = traced.trace(np.array([[0.0, 0.0, -5.0]]), np.array([[0.0, 0.0, 1.0]]))
        assert hits.hit[0] and traced.bounds_method == "memoised"

    def test_a_cycle_that_skips_the_block_suggests_grouping(self):
        w = [x for x in warnings_of(FIG3A_AS_PRINTED) if x.code == "endless"]
        assert "group operands with parentheses" in w[0].message

    def test_random_selection_is_not_reported(self):
        assert warnings_of("S\nS if(rand() < 0.5, 1, 2)\n1: S → sphere\n"
                           "2: S → sphere ∪ move(2,0,0) uscale(0.5) S") == []


class TestContraction:
    def test_non_contracting_cycle_is_reported(self):
        # ended by the level of detail, which never comes: its instances keep their size
        w = warnings_of("S\nS if(pixels > 2, 2, 1)\n1: S → sphere\n"
                        "2: S → sphere ∪ {n = 1} move(2,0,0) S")
        assert [x.code for x in w] == ["non-contracting"]
        assert (w[0].location.line, w[0].location.column) == (4, 37)

    @pytest.mark.parametrize("body, column", [("S", 8), ("(S)", 8), ("move(1,0,0) S", 20),
                                              ("{d = 1} S", 16)])
    def test_a_rule_that_is_only_its_module_is_reported_at_the_call(self, body, column):
        # a bare `S` put the warning under the whole rule, at its number
        w = [x for x in warnings_of(f"{{c = 1}} S\nS if(c > 0, 1, 2)\n1: S → {body}\n"
                                    f"2: S → cube\n") if x.code == "non-contracting"]
        assert [(x.location.line, x.location.column) for x in w] == [(3, column)]

    @pytest.mark.parametrize("text", [
        # a count that runs the wrong way, or that a second condition keeps going
        "{i = 0} R\nR if(i < 8, 2, 1)\n1: R → sphere\n2: R → sphere ∪ {i = i - 1} move(2,0,0) R\n",
        "{i = 0; j = 1} R\nR if(i < 8 || j > 0, 2, 1)\n1: R → sphere\n"
        "2: R → sphere ∪ {i = i + 1} move(2,0,0) R\n",
    ])
    def test_a_count_that_never_ends_is_reported(self, text):
        # exempting every module that reads a counted parameter silenced these
        assert [x.code for x in warnings_of(text)] == ["non-contracting"]

    def test_a_few_non_contracting_rounds_are_fine(self):
        # the tree's leaf segments: a rotation, repeated `segments` times
        assert warnings_of("{n = 2} S\nS if(n > 0, 2, 1)\n1: S → sphere\n"
                           "2: S → sphere ∪ {n = n-1} move(0,0,1) rotz(-90) S") == []

    def test_growth_is_reported(self):
        # the level of detail would end it, but its instances only grow
        w = warnings_of("S\nS if(pixels > 2, 2, 1)\n1: S → sphere\n"
                        "2: S → sphere ∪ move(2,0,0) uscale(1.1) S")
        assert [x.code for x in w] == ["non-contracting"]

    @pytest.mark.parametrize("cycle", ["move(2, 0, 0)", "move(2,0,0) uscale(1.1)", ""])
    def test_a_count_ends_what_boxes_could_not(self, cycle):
        # a row of boxes counted to its end: "bounding boxes and the level of detail
        # cannot stop it", though the count does (a row of 8 and more was warned of)
        assert warnings_of("{i = 0} R\nR if(i < 100, 2, 1)\n1: R → sphere\n"
                           f"2: R → sphere ∪ {{i = i + 1}} {cycle} R\n") == []
        # through a module between, which has no count of its own
        assert warnings_of("{i = 0} S\nS if(i < 20, 2, 1)\n1: S → sphere\n"
                           f"2: S → sphere ∪ {{i = i + 1}} {cycle} T\n1: T → cube ∪ S\n") == []

    def test_a_long_row_is_followed_to_its_end_once(self, monkeypatch):
        # each instance below the first that ends ends too: a row of 800 followed its
        # rest from every one it probed, and its check took 7.8 s
        from pcsg.graph import checks
        calls = []
        real = checks._ends_from
        monkeypatch.setattr(checks, "_ends_from", lambda *a: calls.append(a) or real(*a))
        assert warnings_of("{n = 800} R\nR if(n > 0, 2, 1)\n1: R → sphere\n"
                           "2: R → sphere ∪ {n = n - 1} move(2, 0, 0) R\n") == []
        assert len(calls) == 1

    def test_a_cycle_that_shrinks_along_some_axes_is_not_reported(self):
        assert warnings_of("{n = 100} S\nS if(n > 0, 2, 1)\n1: S → sphere\n"
                           "2: S → sphere ∪ {n = n-1} move(2,0,0) scale(0.5,0.5,1) S") == []

    def test_a_cycle_that_shrinks_along_no_axis_but_some_direction_is_not_reported(self):
        # scale after a turn: every axis keeps a length of 1 or more (1.12, 1.12, 1), and
        # the map still halves one direction; its least singular value (an SVD) says so.
        # It grows one direction 1.5 times a cycle, but over eight it shrinks x and y and
        # keeps z, as the terrain does
        assert warnings_of("S\nS if(pixels > 2, 2, 1)\n1: S → sphere\n"
                           "2: S → sphere ∪ move(2,0,0) scale(0.5,1.5,1) rotz(45) S") == []
        w = warnings_of("S\nS if(pixels > 2, 2, 1)\n1: S → sphere\n"
                        "2: S → sphere ∪ move(2,0,0) scale(1.1,1.5,1) rotz(45) S")
        assert [x.code for x in w] == ["non-contracting"] and "scales it by 1 or more" in w[0].message

    @pytest.mark.parametrize("head", ["rotz(90) scale(1.5, 0.5, 0.5)",
                                      "rotz(30) scale(1.5, 0.5, 0.5)",
                                      "matrix(0.5, 1, 0, 0,  0, 0.5, 0, 0,  0, 0, 0.5, 0)"])
    def test_a_cycle_that_grows_one_step_and_shrinks_over_a_few_is_not_reported(self, head):
        # a turn with an uneven scale, or a shear: 1.5 (1.21) in one direction per cycle,
        # and every direction shrinks over two
        assert warnings_of("S\nS if(pixels > 2, 2, 1)\n1: S → cube\n"
                           f"2: S → cube ∪ move(2, 0, 0) {head} S\n") == []

    def test_the_terrain_is_clean_at_every_order(self):
        # its cycles halve x and y and keep z: it was reported at cnt 12 and not at 8 to
        # 11, as deep as the probe's walk happened to go
        for cnt in (8, 12, 16):
            result = compile_file(GRAMMARS / "carpenter_terrain.pcsg", overrides={"cnt": cnt})
            assert result.warnings == [], cnt

    def test_contracting_cycle_is_clean(self):
        assert warnings_of("{n = 100} S\nS if(n > 0, 2, 1)\n1: S → sphere\n"
                           "2: S → sphere ∪ {n = n-1} move(2,0,0) uscale(0.9) S") == []


class TestUnusedDefinitions:
    """Definitions nothing reads: a misspelt use leaves its definition unread, and a
    leftover is dead text the reader has to skip."""

    def placed(self, text):
        return [(w.location.line, w.location.column, w.code, w.message)
                for w in warnings_of(text)]

    def test_named_expression_never_read(self):
        assert self.placed("leaf = sphere\nhelper = cube\nleaf\n") == \
            [(2, 1, "unused", "named expression 'helper' is never used")]

    def test_named_expression_read_only_by_another_counts_as_read(self):
        assert self.placed("a = sphere\nb = move(1,0,0) a\nb\n") == []

    def test_macro_never_expanded(self):
        text = "#define BIG uscale(2)\n#define UNUSED move(1,0,0)\nBIG sphere\n"
        assert self.placed(text) == [(2, 9, "unused", "macro 'UNUSED' is never used")]

    def test_macro_read_only_by_an_unused_macro_is_unused_too(self):
        text = "#define A uscale(2)\n#define B A sphere\nsphere\n"
        assert [w[3] for w in self.placed(text)] == ["macro 'A' is never used",
                                                     "macro 'B' is never used"]

    def test_macro_read_in_a_comment_only_is_unused(self):
        assert [w[3] for w in self.placed("#define A uscale(2)\n// A\nsphere\n")] == \
            ["macro 'A' is never used"]

    def test_macro_that_renames_a_reserved_word(self):
        # legal: the text is replaced before names mean anything; said, since every
        # later 'sphere' silently becomes a cube
        w = self.placed("#define sphere cube\nsphere\n")
        assert w == [(1, 9, "reserved", "macro 'sphere' replaces a primitive of that name: "
                                         "every 'sphere' below stands for this text")]

    def test_the_samples_define_nothing_unused(self):
        for path in GRAMMARS.glob("*.pcsg"):
            assert not [w for w in compile_file(path).warnings if w.code in ("unused", "reserved")
                        and "module" not in w.message], path


def test_a_read_unassigned_points_at_a_block_that_took_one_operand():
    # `{x = 0; y = 0} ground ∪ ROW`: the block binds to the ground, and the errors said
    # nothing of why
    errs = errors_of("{x = 0; y = 0} move(0, 0, -1) plane ∪ ROW\nROW if(x < 3, 2, 1)\n"
                     "1: ROW → sphere\n2: ROW → move(x, y, 0) cube ∪ {x = x + 1} ROW\n")
    notes = {text for e in errs for _, text in e.notes}
    assert "'x' is assigned here for this operand only: a block applies to the operand " \
           "after it; '{...} (A ∪ B)' gives it to both" in notes
    spans = {e.source.locate(span[0]).line for e in errs for span, _ in e.notes}
    assert spans == {1}             # the first value, not the update of rule 2
    # a block that is another module's own, not an operand the read's module is beside
    errs = errors_of("A ∪ B\n1: A → {x = 0} move(x, 0, 0) sphere ∪ cube\n"
                     "1: B → move(x, 0, 0) cube\n")
    assert errs and all(e.notes == [] for e in errs)


def test_following_the_derivation_leaves_invalid_selections_to_check():
    # the endless and contraction checks follow the derivation (every compile): a
    # selection naming rule 3 of 2 on the way made the compile fail (found by hypothesis)
    text = ("{n = 1; a = 0.5} (A ∪ B ∪ A)\nA if(n > 0, 1 + floor(a * 4), 1)\n1: A → sphere\n"
            "2: A → sphere\nB 1\n1: B → B\n")
    assert {w.code for w in warnings_of(text)} == {"non-contracting"}
    # check, which follows the derivation for its errors, says it
    errors, _ = derivation_faults(compile_text(text, "t.pcsg"))
    assert [e.code for e in errors] == ["selection"]


def test_a_module_and_a_parameter_of_one_name_is_a_warning():
    # notation §2 forbids only reserved names: the module where an operand stands, the
    # parameter in arithmetic
    graph = compile_text("{N = 1} N\nN if(N > 0, 2, 1)\n1: N → sphere\n"
                         "2: N → {N = N - 1} (cube ∪ move(2.5, 0, 0) N)\n", "n.pcsg")
    [w] = graph.warnings
    assert "'N' is both a module and a parameter" in w.message and w.span[0] == 1
    assert count_by_primitive(graph) == {"cube": 1, "sphere": 1}


def test_the_memoised_bounds_ask_the_poll_as_they_go():
    """bound()'s poll (--timeout, and the Ctrl-C check) was asked by the walk of every
    instance only: the memoised walks of a deep chain ran for a minute past --timeout."""
    from pcsg.graph import bounds
    graph = compile_text("{c = 3000} S\nS if(c > 0, 2, 1)\n1: S → sphere\n"
                         "2: S → {c = c-1} (uscale(0.999) S ∪ move(1,0,0) uscale(0.5) sphere)\n")
    asked = []
    found = bounds.bound(graph, 4000, poll=lambda visits, expected: asked.append(visits))
    assert found[1] == bounds.MEMOISED and len(asked) >= 2

    class Stop(Exception):
        pass

    def stop(visits, expected):
        raise Stop
    with pytest.raises(Stop):
        bounds.bound(graph, 4000, poll=stop)


def test_a_flat_operand_is_noted_where_it_is_used_only_if_that_is_elsewhere():
    """`cube ∪ plane ∩ tri1` followed its error at 1:16 with "1:16: note: 'tri1' used
    here", the same place again."""
    from pcsg.language.errors import PcsgError
    with pytest.raises(PcsgError) as e:
        compile_text("cube ∪ plane ∩ tri1\n", "t.pcsg")
    (d,) = e.value.diagnostics
    assert (d.location.line, d.location.column) == (1, 16) and d.notes == []
    with pytest.raises(PcsgError) as e:
        compile_text("E ∩ cube\nE = tri2 ∪ tri1\n", "t.pcsg")
    (d,) = e.value.diagnostics
    assert [n[1] for n in d.notes] == ["'tri1' used here"]
