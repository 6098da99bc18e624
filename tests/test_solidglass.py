"""Glass of overlapping parts traced as one solid (graph/solidglass.py): which unions go
under a difference of one operand, and that the rest of the graph stays as it was."""
import pytest

from pcsg.compiler import compile_text
from pcsg.graph.model import DIFFERENCE, UNION
from pcsg.graph.solidglass import MAX_PRIMITIVES, glass_unions_as_solids

GLASS = "#material glass transmit=0.9\n#material steel reflect=0.5\n"


def wrapped(text: str) -> list[str]:
    """What goes under a difference of one operand, as the text of its operands."""
    graph = compile_text(GLASS + text)
    after = glass_unions_as_solids(graph)
    if after is graph:
        return []
    solids = [n for n in after.nodes[len(graph.nodes):] if n.kind == DIFFERENCE]
    assert all(len(n.children) == 1 for n in solids)
    unions = [after.nodes[n.children[0]] for n in solids]
    assert all(u.kind == UNION for u in unions)
    return [graph.source.expanded[u.edge_spans[0][0]:u.edge_spans[-1][1]] for u in unions]


@pytest.mark.parametrize("text, want", [
    # under glass, and glass below it: the outermost union either way
    ("material(glass) (sphere ∪ move(1,0,0) sphere)", ["sphere ∪ move(1,0,0) sphere"]),
    ("material(glass) sphere ∪ material(glass) move(1,0,0) sphere ∪ move(5,0,0) cube",
     ["material(glass) sphere ∪ material(glass) move(1,0,0) sphere ∪ move(5,0,0) cube"]),
    # no glass, or glass that no union makes
    ("material(steel) (sphere ∪ move(1,0,0) sphere)", []),
    ("material(glass) sphere", []),
    # glass operands beside a floor that is a module or a triangle: those operands
    ("material(glass) sphere ∪ F ∪ material(glass) move(1,0,0) sphere\nF 1\n1: F → cube",
     ["material(glass) sphere ∪ F ∪ material(glass) move(1,0,0) sphere"]),
    ("tri1 ∪ material(glass) (sphere ∪ move(1,0,0) sphere)", ["sphere ∪ move(1,0,0) sphere"]),
    # a rand() beside the glass, not below it
    ("material(glass) (sphere ∪ move(1,0,0) sphere) ∪ {a = rand()} move(a,0,5) cube",
     ["sphere ∪ move(1,0,0) sphere"]),
    # traced as intervals already
    ("material(glass) ((sphere ∪ move(1,0,0) sphere) ∩ uscale(3) cube)", []),
])
def test_the_unions_glass_is_made_of_are_wrapped(text, want):
    assert wrapped(text) == want


def test_a_recursive_or_large_or_random_glass_union_is_left_as_it_is():
    recursive = ("{c = 3} material(glass) S\nS if(c > 0, 2, 1)\n1: S → sphere\n"
                 "2: S → {c = c - 1} (sphere ∪ move(1,0,0) uscale(0.5) S)\n")
    assert wrapped(recursive) == []
    # its first rule's union is a fixed tree below the glass: that one is wrapped
    assert wrapped(recursive.replace("1: S → sphere", "1: S → sphere ∪ cube")) == \
        ["sphere ∪ cube"]
    many = " ∪ ".join(f"move({k},0,0) sphere" for k in range(MAX_PRIMITIVES + 1))
    first = many.rsplit(" ∪ ", 1)[0]
    # past MAX_PRIMITIVES, as many operands as it holds
    assert wrapped(f"material(glass) ({many})") == [first]
    assert wrapped(f"material(glass) ({first})") == [first]
    assert wrapped("material(glass) ({a = rand()} move(a,0,0) sphere ∪ sphere)") == []
    # no inside to trace as an interval: glass lets nothing through them
    assert wrapped("material(glass) (julia(0, 0, 0, 0) ∪ sphere)") == []
    assert wrapped("material(glass) (tri1 ∪ sphere)") == []


def test_the_compiled_graph_is_not_changed():
    graph = compile_text(GLASS + "material(glass) (sphere ∪ move(1,0,0) sphere)")
    children = [list(n.children) for n in graph.nodes]
    root = graph.root
    after = glass_unions_as_solids(graph)
    assert after is not graph and after.nodes[root].children != graph.nodes[root].children
    assert [list(n.children) for n in graph.nodes] == children and graph.root == root
