"""`pcsg graph`: the cyclic CSG graph in Graphviz dot, drawn like the paper's
Fig. 3b and 5b: S-nodes as diamonds with their rules on the edges, C-nodes with
their assignments, T-nodes with their transformation, cycles as dashed edges."""
from __future__ import annotations

from ..language.source import one_line
from ..language.unparse import unparse_arith
from .checks import reachable
from .model import (CALC, DIFFERENCE, MATERIAL, OPERATOR_SYMBOLS, PAINT, PRIMITIVE, SELECT,
                    TRANSFORM, Graph)

_STYLE = {
    SELECT: 'shape=diamond, style=filled, fillcolor="#f6d36b"',
    CALC: 'shape=box, style="rounded,filled", fillcolor="#cfe3f7"',
    TRANSFORM: 'shape=box, style=filled, fillcolor="#e4e4e4"',
    PRIMITIVE: 'shape=ellipse, style=filled, fillcolor="#c9efc4"',
    PAINT: 'shape=note, style=filled, fillcolor="#f3d9ef"',
    MATERIAL: 'shape=note, style=filled, fillcolor="#f3d9ef"',
}


def _quote(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'


def node_label(graph: Graph, i: int) -> str:
    n = graph.nodes[i]
    text = lambda e: unparse_arith(graph.expr_ast[e])
    if n.kind == SELECT:
        return f"{n.name}\n{text(n.exprs[0])}"
    if n.kind == CALC:
        names = graph.param_names
        return "\n".join(f"{names[s]} = {text(e)}" for s, e in zip(n.targets, n.exprs))
    if n.kind == TRANSFORM:
        return n.name + (f"({', '.join(text(e) for e in n.exprs)})" if n.exprs else "")
    if n.kind == PAINT:
        return f"paint({', '.join(text(e) for e in n.exprs)})"
    if n.kind == MATERIAL:
        return f"material({n.name})"
    if n.kind == PRIMITIVE:
        return n.name + (f"({', '.join(text(e) for e in n.exprs)})" if n.exprs else "")
    return OPERATOR_SYMBOLS[n.kind]


def back_edges(graph: Graph) -> set[tuple[int, int]]:
    """Edges that close a cycle in a depth-first walk from the axiom."""
    state = {}          # 1 on the current path, 2 done
    out = set()
    stack = [(graph.root, 0)]
    while stack:
        i, k = stack.pop()
        if k == 0:
            state[i] = 1
        children = graph.nodes[i].children
        if k < len(children):
            stack.append((i, k + 1))
            c = children[k]
            if state.get(c) == 1:
                out.add((i, k))
            elif c not in state:
                stack.append((c, 0))
        else:
            state[i] = 2
    return out


def to_dot(graph: Graph) -> str:
    live = reachable(graph)
    back = back_edges(graph)
    lines = [f"// {one_line(graph.source.file)}: cyclic CSG graph (pcsg graph)",
             "digraph pcsg {", '  graph [rankdir=TB, fontname="Helvetica"];',
             '  node [fontname="Helvetica", fontsize=11];', '  edge [fontname="Helvetica", fontsize=9];',
             '  axiom [shape=plaintext, label="axiom"];', f"  axiom -> n{graph.root};"]
    for i, n in enumerate(graph.nodes):
        if not live[i]:
            continue
        style = _STYLE.get(n.kind, 'shape=circle, width=0.35, fixedsize=true')
        lines.append(f"  n{i} [label={_quote(node_label(graph, i))}, {style}];")
    for i, n in enumerate(graph.nodes):
        if not live[i]:
            continue
        for k, c in enumerate(n.children):
            attrs = []
            if n.kind == SELECT:
                attrs.append(f'label="{k + 1}"')
            elif n.kind == DIFFERENCE and k > 0:
                attrs.append('label="−"')      # which operand is taken away
            if (i, k) in back:
                attrs.append('style=dashed, constraint=false, color="#a04040"')
            lines.append(f"  n{i} -> n{c}" + (f" [{', '.join(attrs)}]" if attrs else "") + ";")
    lines.append("}")
    return "\n".join(lines) + "\n"
