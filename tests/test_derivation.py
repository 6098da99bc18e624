"""stats counts, expand round trips, and the flat reference expansion agree."""
import json

import numpy as np
import pytest

from pcsg.compiler import compile_file, compile_text
from pcsg.graph.expand import REDRAWN, expand_axiom, expand_file
from pcsg.graph.flatten import flatten
from pcsg.graph.stats import count_by_primitive, count_primitives
from pcsg.language.errors import PcsgError

from .conftest import GRAMMARS, SIERPINSKI

SAMPLES = {"sierpinski": {"c": 2}, "sympodial_tree": {"cnt": 3}, "carpenter_terrain": {"cnt": 2}}


def sample(name, **overrides):
    path = GRAMMARS / f"{name}.pcsg"
    if not path.exists():
        pytest.skip(f"{path.name} not written yet")
    return compile_file(path, overrides)


class TestCounts:
    def test_sierpinski_order_6_is_4096_tetrahedra(self):
        assert count_by_primitive(compile_text(SIERPINSKI)) == {"tetrahedron": 4096}
        assert count_by_primitive(sample("sierpinski"))["tetrahedron"] == 4096

    def test_sierpinski_order_16_is_counted_without_expanding(self):
        assert count_by_primitive(sample("sierpinski", c=16))["tetrahedron"] == 4 ** 16

    def test_terrain_order_8_is_131072_triangles(self):
        counts = count_by_primitive(sample("carpenter_terrain", cnt=8))
        assert counts.get("tri1", 0) + counts.get("tri2", 0) == 131072

    @pytest.mark.parametrize("name, overrides", [("sierpinski", {"c": 3}),
                                                 ("sympodial_tree", {"cnt": 5}),
                                                 ("carpenter_terrain", {"cnt": 3})])
    def test_memoised_count_equals_brute_force(self, name, overrides):
        g = sample(name, **overrides)
        assert count_primitives(g) == len(flatten(g))

    def test_endless_derivation_is_reported_not_hung(self):
        g = compile_text("{n = 0} S\nS 2 - (n > 1e300)\n1: S → sphere\n2: S → {n = n + 1} S")
        with pytest.raises(PcsgError) as e:
            count_primitives(g)
        assert e.value.diagnostics[0].message.startswith(
            "the derivation goes deeper than 10000 levels: 'S' is still being rewritten there")

    def test_repeating_state_is_reported(self):
        g = compile_text("{n = 1} S\nS if(n > 0, 2, 1)\n1: S → sphere\n2: S → {n = n} S")
        with pytest.raises(PcsgError) as e:
            count_primitives(g)
        assert "'S' repeats with the same parameters (n = 1)" in e.value.diagnostics[0].message

    def test_selection_out_of_range_names_module_and_values(self):
        g = compile_text("{c = 3} S\nS c\n1: S → sphere\n2: S → cube")
        with pytest.raises(PcsgError) as e:
            count_primitives(g)
        d = e.value.diagnostics[0]
        assert d.message == ("the selection of module 'S' gives 3, which names rule 3, but 'S' "
                             "has rules 1..2 (with c = 3)")
        assert (d.location.line, d.location.column) == (2, 3)      # at the selection
        # one written by a macro names the macro (it pointed at the module, without a note)
        g = compile_text("#define SEL c + 5\n{c = 1} S\nS SEL\n1: S → cube\n2: S → sphere\n")
        with pytest.raises(PcsgError) as e:
            count_primitives(g)
        text = e.value.diagnostics[0].format(show_source=False)
        assert "3:3: error: the selection of module 'S' gives 6" in text
        assert "note: in macro 'SEL' defined at <string>:1:9" in text
        # a rule number too large to read whole is said as a number (it was 301 digits)
        g = compile_text("{c = 1e300} S\nS c\n1: S → sphere\n2: S → cube")
        with pytest.raises(PcsgError) as e:
            count_primitives(g)
        assert e.value.diagnostics[0].message.startswith(
            "the selection of module 'S' gives 1e+300, which names rule 1e+300, but")


class TestExpand:
    def test_one_step_of_sierpinski(self):
        g = compile_text(SIERPINSKI)
        assert expand_axiom(g, 0) == "{c = 6} S"
        assert expand_axiom(g, 1) == " ∪ ".join(
            f"move({x}, {y}, {z}) uscale(0.5) {{c = 5}} S"
            for x, y, z in [("0.5", "0.5", "0.5"), ("-0.5", "-0.5", "0.5"),
                            ("0.5", "-0.5", "-0.5"), ("-0.5", "0.5", "-0.5")])

    @pytest.mark.parametrize("name", SAMPLES)
    @pytest.mark.parametrize("steps", [0, 1, 2, 3])
    def test_expansion_checks_and_derives_the_same_object(self, name, steps):
        g = sample(name, **SAMPLES[name])
        text = expand_file(g, steps)
        g2 = compile_text(text, "expanded.pcsg")
        assert count_by_primitive(g2) == count_by_primitive(g)
        a, b = flatten(g), flatten(g2)
        assert [x.primitive for x in a] == [x.primitive for x in b]
        for x, y in zip(a, b):
            assert np.array_equal(x.matrix, y.matrix)
            assert x.paint == y.paint and x.material == y.material

    @pytest.mark.parametrize("draw, steps, warned", [
        ("rand()", 2, True),            # modules left: their paths start anew
        ("rand()", 20, False),          # every module rewritten: the same primitives
        ("rand(c)", 2, False)])         # a seed's numbers are the seed's alone
    def test_expansion_says_where_rand_draws_other_numbers(self, draw, steps, warned):
        g = compile_text(f"{{c = 4}} S\nS if(c > 0, if({draw} < 0.5, 2, 3), 1)\n"
                         "1: S → cube\n"
                         "2: S → {c = c-1} (move(-1,0,0) uscale(0.5) S ∪\n"
                         "                  move(1,0,0) uscale(0.5) S)\n"
                         "3: S → {c = c-1} move(0,0,1) uscale(0.5) S\n")
        notes = []
        g2 = compile_text(expand_file(g, steps, notes=notes), "expanded.pcsg")
        assert notes == ([REDRAWN] if warned else [])
        if not warned:
            a, b = flatten(g), flatten(g2)
            assert [x.primitive for x in a] == [x.primitive for x in b]
            assert all(np.array_equal(x.matrix, y.matrix) for x, y in zip(a, b))

    def test_complete_expansion_leaves_no_module(self):
        g = sample("sierpinski", c=2)
        axiom = expand_axiom(g, 100)
        assert " S" not in axiom and axiom.count("tetrahedron") == 16

    def test_expansion_keeps_values_exact(self):
        g = compile_text("{a = 0.1 + 0.2} S\n1: S → move(a, 1/3, -0) sphere")
        text = expand_axiom(g, 1)
        assert text == "move(0.30000000000000004, 0.3333333333333333, -0) sphere"


class TestTerrain:
    def test_every_shared_vertex_gets_one_height(self):
        """No cracks: each world xy vertex of the complete derivation has one height."""
        g = sample("carpenter_terrain", cnt=4)
        corners = {"tri1": [(0, 0, 0), (1, 0, 0), (0, 1, 0)],
                   "tri2": [(0, 0, 0), (-1, 0, 0), (0, -1, 0)]}
        heights: dict[tuple, set] = {}
        triangles = [x for x in flatten(g) if x.primitive in corners]
        assert len(triangles) == 2 * 4 ** 4
        for x in triangles:
            for c in corners[x.primitive]:
                p = x.matrix @ np.array([*c, 1.0])
                key = (round(p[0] * 2 ** 10), round(p[1] * 2 ** 10))
                heights.setdefault(key, set()).add(float(p[2]))
        assert len(heights) == (2 ** 4 + 1) ** 2          # the grid of the unit square
        spread = max(max(h) - min(h) for h in heights.values())
        assert spread < 1e-12, f"heights of one vertex differ by {spread}"
        assert len({z for h in heights.values() for z in h}) > 100   # it is not flat


def test_a_module_comes_before_a_named_expression_of_its_name():
    # notation §2: "A name resolves, in this order, to: a module, a named expression, a
    # primitive"; a file with both was an error
    g = compile_text("A\nA = sphere\n1: A → cube\n", "t.pcsg")
    assert count_by_primitive(g) == {"cube": 1}
    (w,) = g.warnings
    assert w.code == "shadowed" and (w.location.line, w.location.column) == (2, 1)
    assert "it names the module, and the named expression is never used" in w.message


@pytest.mark.parametrize("text, why", [
    # counts up forever: valid (notation §9), and stats failed with exit 1
    ("{c = 1} S\nS if(c > 0, 2, 1)\n1: S → sphere\n2: S → {c = c + 1} (sphere ∪ move(2, 0, 0) "
     "uscale(0.5) S)\n", "the derivation goes deeper than 10000 levels: 'S' is still being "
                         "rewritten there (c = 10001)"),
    # finite, but deeper than the count follows: it said "never ends"
    ("{c = 20000} S\nS if(c > 0, 2, 1)\n1: S → sphere\n2: S → {c = c - 1} (sphere ∪ "
     "move(0.001, 0, 0) uscale(0.9) S)\n", "the derivation goes deeper than 10000 levels"),
    ("{c = 1} S\nS if(c > 0, 2, 1)\n1: S → sphere\n2: S → {c = c} uscale(0.5) S\n",
     "the derivation never ends: 'S' repeats with the same parameters (c = 1)"),
])
def test_stats_of_a_derivation_it_cannot_count_says_why(capsys, tmp_path, text, why):
    from pcsg.cli import main
    src = tmp_path / "t.pcsg"
    src.write_text(text, encoding="utf-8")
    assert main(["stats", str(src), "--json"]) == 0
    r = json.loads(capsys.readouterr().out)
    assert r["primitives"] is None and r["not_counted"].startswith(why)
    assert r["endless"] == why.startswith("the derivation never ends")   # deep is not endless


def test_stats_of_too_many_random_instances_says_so_not_that_it_is_deep(capsys, tmp_path,
                                                                        monkeypatch):
    """Every instance of a module whose selection reads rand() is a state of its own: past
    the count's states it said "the derivation goes deeper than 30 levels: 'S' is still
    being rewritten there (c = 0)" of a system that ends at 30 levels."""
    from pcsg.cli import main
    from pcsg.graph import stats
    src = tmp_path / "r.pcsg"
    src.write_text("{c = 30} S\nS if(c > 0 && rand() < 0.95, 2, 1)\n1: S -> cube\n"
                   "2: S -> {c = c - 1} (move(1,0,0) uscale(0.5) S | move(-1,0,0) uscale(0.5) S)\n")
    monkeypatch.setattr(stats, "MAX_STATES", 1000)
    assert main(["stats", str(src), "--json"]) == 0
    r = json.loads(capsys.readouterr().out)
    assert r["primitives"] is None and r["endless"] is False
    assert r["not_counted"] == ("too many different instances to count, more than 1,000; "
                                "rand() makes each instance of 'S' differ")
    assert main(["stats", str(src)]) == 0
    assert capsys.readouterr().out.splitlines()[-1] == (
        "  primitives   not counted: too many different instances to count, more than 1,000; "
        "rand() makes each instance of 'S' differ")
    # at 5 levels it has a few hundred states: counted
    src.write_text(src.read_text().replace("c = 30", "c = 5"))
    assert main(["stats", str(src), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["primitives"] > 1


def test_a_count_too_long_to_write_is_given_by_its_size(capsys):
    """Python writes integers of up to 4,300 digits: Sierpinski at c=9999 (6,020 digits)
    was an internal error in stats and stats --json."""
    from pcsg.cli import main
    assert main(["stats", str(GRAMMARS / "sierpinski.pcsg"), "--set", "c=9999", "--json"]) == 0
    r = json.loads(capsys.readouterr().out)
    assert r["primitives"] is None and r["count_digits"] == 6020 and r["endless"] is False
    assert r["not_counted"].startswith("about 9.95e6019 primitives, a number of 6,020 digits")
    assert main(["stats", str(GRAMMARS / "sierpinski.pcsg"), "--set", "c=9999"]) == 0
    assert "primitives   not written: about 9.95e6019" in capsys.readouterr().out
    assert main(["stats", str(GRAMMARS / "sierpinski.pcsg"), "--set", "c=6000", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["primitives_by_kind"]["tetrahedron"] == 4 ** 6000


def test_the_written_word_keeps_only_what_it_reaches():
    # the modules the word had expanded stayed in the file, "never used": check --werror
    # refused the file expand wrote
    text = ("{c = 2} S\nS if(c > 0, 2, 1)\n1: S → leaf\n2: S → {c = c - 1} (T ∪ move(2, 0, 0) S)\n"
            "1: T → stem\nleaf = sphere\nstem = cube\nspare = cone\n1: U → cone\n")
    full = expand_file(compile_text(text, "t.pcsg"), 10)
    assert [w.message for w in compile_text(full, "w.pcsg").warnings] == []
    assert "1: S" not in full and "1: T" not in full and "leaf =" not in full
    # one step leaves S and T named: they stay, with what their rules read
    one = expand_file(compile_text(text, "t.pcsg"), 1)
    assert [w.message for w in compile_text(one, "w.pcsg").warnings] == []
    assert all(s in one for s in ("1: S", "2: S", "S if(", "1: T", "leaf =", "stem ="))
    assert "spare" not in one and "U →" not in one


@pytest.mark.parametrize("text, steps, written, primitives", [
    # a row (the README's chain of trees) 300 steps deep, and 1,000 nested maps at once:
    # RecursionError from 250 steps, an internal error
    ("{n = 400} ROW\nROW if(n > 0, 2, 1)\n1: ROW → sphere\n"
     "2: ROW → sphere ∪ {n = n - 1} move(2, 0, 0) ROW\n", 300, 300, 401),
    ("S\n1: S → " + "move(1,0,0) (" * 1000 + "sphere" + ")" * 1000 + "\n", 1, 1, 1)])
def test_a_deep_word_is_written(text, steps, written, primitives):
    graph = compile_text(text, "t.pcsg")
    word = expand_file(graph, steps)
    assert count_primitives(compile_text(word, "w.pcsg")) == primitives == \
        count_primitives(graph)
    assert expand_axiom(graph, steps).count("sphere") == written


def test_a_word_that_leaves_graftal_modules_says_its_picture_differs():
    # the fern's written word rendered 628 of 19 200 pixels otherwise, without a word
    from pcsg.graph.expand import GRAFTAL_LEFT
    notes: list[str] = []
    expand_file(compile_file(GRAMMARS / "barnsley_fern.pcsg"), 2, notes=notes)
    assert GRAFTAL_LEFT in notes
    notes.clear()
    expand_file(compile_file(GRAMMARS / "sierpinski.pcsg"), 2, notes=notes)
    assert notes == []


def test_a_statement_left_out_takes_its_comment_along():
    # a comment over two lines after a rule the word no longer reaches: its second line
    # stayed, and the file did not parse
    text = ("{c = 1} S\nS if(c > 0, 2, 1)\n1: S → sphere\n2: S → {c = c - 1} (cube ∪ move(2,0,0) S)\n"
            "1: U → cone /* U is a spare,\n   kept for later */\n")
    word = expand_file(compile_text(text, "t.pcsg"), 1)
    assert "kept for later" not in word and compile_text(word, "w.pcsg").warnings == []


def test_a_file_named_with_a_line_break_is_named_in_one_comment(tmp_path):
    """The header comments of expand and graph wrote the name as it is: a newline in it
    ended the comment, and check refused what expand wrote."""
    from pcsg.graph.dot import to_dot
    src = tmp_path / "nl\nname.pcsg"
    src.write_text((GRAMMARS / "sierpinski.pcsg").read_text(encoding="utf-8"), encoding="utf-8")
    graph = compile_file(src)
    word = expand_file(graph, 1)
    escaped = str(src).replace("\n", "\\n")
    assert word.splitlines()[0] == f"// {escaped} after 1 derivation step"
    assert count_primitives(compile_text(word, "w.pcsg")) == 4 ** 6 + 1   # it raised
    dot = to_dot(graph).splitlines()
    assert dot[0].endswith("nl\\nname.pcsg: cyclic CSG graph (pcsg graph)")
    assert dot[1].startswith("digraph")


@pytest.mark.parametrize("name, params", [("sierpinski.pcsg", {"c": 3}),
                                          ("sympodial_tree.pcsg", {"cnt": 5}),
                                          ("table_tower.pcsg", {}),
                                          ("menger_sponge.pcsg", {"c": 2})])
def test_the_least_length_of_a_word_is_at_most_its_length(name, params):
    from pcsg.graph.expand import least_chars
    graph = compile_file(GRAMMARS / name, params)
    for steps in range(7):
        assert 0 < least_chars(graph, steps) <= len(expand_axiom(graph, steps))


def test_a_word_longer_than_max_chars_by_its_count_is_refused_before_it_is_written(
        monkeypatch):
    """Sierpinski at 12 expanded 12 steps (16.8 million modules left) was refused after
    24 s of writing and 430 MB: its count says so at once."""
    from pcsg.graph import expand
    from pcsg.graph.expand import ExpansionTooLarge

    def never(*args):
        raise AssertionError("the word was written")
    monkeypatch.setattr(expand._Printer, "word", never)
    graph = compile_file(GRAMMARS / "sierpinski.pcsg", {"c": 12})
    with pytest.raises(ExpansionTooLarge, match="longer than 50,000,000 characters"):
        expand_axiom(graph, 12)
    # the most steps expand takes: the count stopped at its own depth limit there, and
    # the word was written for 36 s and 520 MB before it was refused
    graph = compile_text("A\n1: A -> uscale(0.5) (A | move(1,0,0) A)\n")
    with pytest.raises(ExpansionTooLarge, match="longer than 50,000,000 characters"):
        expand_axiom(graph, 10_000)
