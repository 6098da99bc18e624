"""Runs of T-nodes written out as one `matrix` T-node, for systems bounded instance by
instance.

A run of T-nodes of which some are computed (the terrain's final `move(0,0,z1)
zshear(z2-z1,z3-z1)`) is one map. The tracer multiplies it out at run time (graph/flat.py
`_compose_chains`, nodes.composed_affine), but the bounding walk visits every instance of
a system bounded one by one, 33 million final triangles of the terrain at order 12, and
that product in its hot loop made it slower. So it is taken once, on the expressions: a
new `matrix(...)` node, whose twelve arguments are the entries of the product written in
the arguments of the run (the terrain's: z2-z1, z3-z1 and z1, the other nine constants),
takes the run's place under every parent that is not a T-node (a T-node above is itself
the head of a longer run). Both walks then evaluate one node's arguments, compiled to
machine code for such systems (trace/native.py), instead of each map's, and the bounding
walk maps a box once. Systems bounded by their states keep their runs (bounds.bound's
`fuse`): their arguments run on the expression machine, where twelve entries, and a
rotation's cosine once per entry, would cost more than the maps' few arguments and the
product in the kernel; their bounds do not visit instances one by one.

The run stays in the graph as written, out of the walks' way: a bad map is reported at
the node of the run that has it (Graph.origins, nodes.culprit). T-nodes add nothing to
an instance's hash, so rand() and the instance table see the same instances. The box of
the new node is the product's image of its child's box, no larger than the box mapped
by each map in turn. A non-finite argument still empties the instance: the entry (0, 0)
adds `a - a` of each argument, which is 0 for a finite one and nan otherwise. Runs whose
arguments draw rand() (which numbers its draws by the argument) and runs through `rot`
or `mirror` (whose axis is normalised first) stay as written; the tracer composes them."""
from __future__ import annotations

import dataclasses
import math

from ..trace import vm
from .model import TRANSFORM, Graph, Node

ZERO, ONE = ('const', 0.0), ('const', 1.0)
# the most operations and operands a run's twelve entries may take, together: the product of
# k general maps grows about threefold with each, and past this the run is composed at run
# time (the terrain's run takes 36)
MOST_TERMS = 400
ROTATIONS = {"rotx": (1.0, 0.0, 0.0), "roty": (0.0, 1.0, 0.0), "rotz": (0.0, 0.0, 1.0)}


def fuse_runs(graph: Graph) -> Graph:
    """The graph with a `matrix` node for each run of two or more T-nodes that can be
    written so and has a computed map, in its place under its parents; the graph itself
    if there is none (or it has been through here)."""
    nodes = graph.nodes
    if graph.origins:
        return graph
    table = None
    fused = list(nodes)
    origins, matrix_of = {}, {}
    for i in range(len(nodes)):
        run = _run(nodes, i)
        if run is None:
            continue
        maps = [_matrix(graph.exprs, nodes[j]) for j in run]
        if any(m is None for m in maps):
            continue
        args = [e for j in run for e in nodes[j].exprs]
        if all(graph.exprs.constant(e) is not None for e in args):
            continue        # constant runs: flat.py composes them into one fixed map
        product = maps[0]
        for m in maps[1:]:
            # measured at each step: the forms share their parts, and counting a long
            # run's entries in full would take as long as they grow
            if sum(_size(f) for f in product) > MOST_TERMS:
                break
            product = _product(product, m)
        product[0] = _add(product[0], _finite_check(graph.exprs, args))
        if sum(_size(f) for f in product) > MOST_TERMS:
            continue
        if table is None:
            table = graph.exprs.copy()
        matrix_of[i] = len(fused)
        origins[len(fused)] = i
        fused.append(Node(TRANSFORM, "matrix", children=list(nodes[run[-1]].children),
                          exprs=[table.add_form(f) for f in product], span=nodes[i].span,
                          edge_spans=list(nodes[run[-1]].edge_spans)))
    if table is None:
        return graph
    for p, node in enumerate(nodes):
        if node.kind != TRANSFORM and any(c in matrix_of for c in node.children):
            fused[p] = dataclasses.replace(
                node, children=[matrix_of.get(c, c) for c in node.children])
    return dataclasses.replace(graph, nodes=fused, exprs=table, origins=origins,
                               root=matrix_of.get(graph.root, graph.root),
                               expr_ast=graph.expr_ast + [None] * (len(table) - len(graph.exprs)))


def _run(nodes, i):
    """The T-nodes from i down while each one's child is a T-node (at least two), or None;
    None for a cycle of T-nodes alone, which no rule makes."""
    if nodes[i].kind != TRANSFORM or nodes[nodes[i].children[0]].kind != TRANSFORM:
        return None
    run = [i]
    while nodes[nodes[run[-1]].children[0]].kind == TRANSFORM:
        nxt = nodes[run[-1]].children[0]
        if nxt in run:
            return None
        run.append(nxt)
    return run


def _matrix(exprs, node):
    """The node's 3x4 map [L | t] as twelve forms, row by row, or None. The forms do
    what trace/transforms.affine does; a rotation's axis is a unit vector already."""
    if any(exprs.uses_rand(e) for e in node.exprs):
        return None
    a = [exprs.form(e) for e in node.exprs]
    m = [ONE if k in (0, 5, 10) else ZERO for k in range(12)]
    name = node.name
    if name == "move":
        m[3], m[7], m[11] = a
    elif name == "scale":
        m[0], m[5], m[10] = a
    elif name == "uscale":
        m[0] = m[5] = m[10] = a[0]
    elif name in ROTATIONS:
        _rotation(m, a[0], *ROTATIONS[name])
    elif name == "zshear":
        m[8], m[9] = a
    elif name == "xshear":
        m[1], m[2] = a
    elif name == "yshear":
        m[4], m[6] = a
    elif name in ("flipxy", "flipxz", "flipyz"):
        for axis in "xyz":
            if axis in name[4:]:
                m[5 * "xyz".index(axis)] = ('const', -1.0)
    elif name == "matrix":
        m = list(a)
    else:
        return None
    return m


def _rotation(m, deg, ax, ay, az):
    """transforms._rotation about a unit axis, its products with 0 and 1 left out."""
    angle = _op(vm.DIV, _op(vm.MUL, deg, ('const', math.pi)), ('const', 180.0))
    c, s = _op(vm.COS, angle), _op(vm.SIN, angle)
    t = _op(vm.SUB, ONE, c)
    axis = [('const', ax), ('const', ay), ('const', az)]
    for i in range(3):
        for j in range(3):
            e = _mul(_mul(t, axis[i]), axis[j])
            if i == j:
                e = _add(e, c)
            else:
                k = 3 - i - j               # the third axis; its sign from (i, j)'s order
                term = _mul(s, axis[k])
                e = _add(e, term) if (j - i) % 3 == 2 else _sub(e, term)
            m[4 * i + j] = e


def _product(a, b):
    """The forms of the map a after b: [La Lb | La tb + ta]."""
    out = []
    for i in range(3):
        for j in range(4):
            e = ZERO
            for k in range(3):
                e = _add(e, _mul(a[4 * i + k], b[4 * k + j]))
            out.append(_add(e, a[4 * i + 3]) if j == 3 else e)
    return out


def _finite_check(exprs, args):
    """0 if every argument is finite, nan otherwise: the sum of their `a - a`."""
    check = ZERO
    for e in args:
        if exprs.constant(e) is None or not math.isfinite(exprs.constant(e)):
            f = exprs.form(e)
            check = _add(check, _op(vm.SUB, f, f))
    return check


def _size(f) -> int:
    """The operations and operands of a form."""
    if f[0] == 'op':
        return 1 + sum(_size(a) for a in f[2])
    if f[0] in ('if', 'and', 'or'):
        return 1 + sum(_size(a) for a in f[1:])
    return 1


def _op(code, *args):
    return ('op', code, args)


def _mul(a, b):
    if a == ZERO or b == ZERO:
        return ZERO         # a non-finite factor is caught by _finite_check
    if a == ONE:
        return b
    return a if b == ONE else _op(vm.MUL, a, b)


def _add(a, b):
    if a == ZERO:
        return b
    return a if b == ZERO else _op(vm.ADD, a, b)


def _sub(a, b):
    return a if b == ZERO else _op(vm.SUB, a, b)
