"""The complete derivation as a flat list of transformed primitives: the
deliberately simple reference that the graph tracer is checked against."""
from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from ..language.errors import Diagnostic, PcsgError
from .derive import Deriver, too_deep
from .model import CALC, MATERIAL, OPERATORS, PAINT, PRIMITIVE, SELECT, TRANSFORM, Graph
from .stats import MAX_LEVELS


@dataclass
class Instance:
    primitive: str
    matrix: np.ndarray            # 4x4, world from the primitive's object frame
    paint: tuple | None           # the innermost paint(r, g, b) above it
    material: str | None          # the innermost material(NAME) above it
    path: tuple                   # CSG operators above it: ((node, child number), ...)
    args: tuple = ()              # a fractal's arguments


def leaf_inverse(matrix: np.ndarray) -> np.ndarray | None:
    """The inverse of a leaf's world matrix, or None when the leaf is empty: a singular
    or non-finite matrix (a runtime error in its calculations or transforms) draws nothing.
    The contract of trace/reference.py, which the graph tracer and the export keep."""
    if not np.all(np.isfinite(matrix)):
        return None
    det = np.linalg.det(matrix[:3, :3])
    if det == 0.0 or not np.isfinite(det):
        return None
    inv = np.linalg.inv(matrix)
    return inv if np.all(np.isfinite(inv)) else None


def nonempty(world: np.ndarray) -> np.ndarray:
    """leaf_inverse(m) is not None for each world map of (k, 3, 4) or (k, 4, 4), at once."""
    k = len(world)
    m = np.zeros((k, 4, 4))
    m[:, :3] = world[:, :3]
    m[:, 3, 3] = 1.0
    ok = np.isfinite(m).all(axis=(1, 2))
    with np.errstate(all="ignore"):
        det = np.linalg.det(m[ok, :3, :3])
        fine = (det != 0.0) & np.isfinite(det)
        ok[np.flatnonzero(ok)[~fine]] = False
        inv = np.linalg.inv(m[ok])
    ok[np.flatnonzero(ok)[~np.isfinite(inv).all(axis=(1, 2))]] = False
    return ok


def flatten(graph: Graph, max_primitives: int = 1_000_000) -> list[Instance]:
    """Every primitive of the derivation with its world matrix, in derivation order.
    Raises PcsgError when there are more than max_primitives."""
    out: list[Instance] = []
    for inst in instances(graph):
        out.append(inst)
        if len(out) > max_primitives:
            raise PcsgError([Diagnostic("error", f"the derivation has more than "
                                        f"{max_primitives:,} primitives; the reference "
                                        f"expansion is for small orders", None, graph.source,
                                        code="too-large")])
    return out


def instances(graph: Graph) -> Iterator[Instance]:
    """The primitives of the derivation one by one, in derivation order (left operand
    first), holding only the open branches: the form for streaming exports."""
    d = Deriver(graph)
    nodes = graph.nodes
    state, h = d.initial()
    stack = [(graph.root, state, h, np.eye(4), None, None, (), 0)]
    while stack:
        i, state, h, m, paint, material, path, level = stack.pop()
        n = nodes[i]
        if n.kind == PRIMITIVE:
            yield Instance(n.name, m, paint, material, path, graph.constant_args(i))
            continue
        if n.kind == SELECT:
            if level >= MAX_LEVELS:
                raise too_deep(graph, i, MAX_LEVELS)
            r = d.select(i, state, h)
            stack.append((n.children[r], state, d.edge(h, i, r), m, paint, material, path,
                          level + 1))
            continue
        if n.kind == CALC:
            state = d.calc(i, state, h)
        elif n.kind == TRANSFORM:
            with np.errstate(invalid="ignore", over="ignore"):   # non-finite: empty leaf
                m = m @ d.matrix(i, state, h)
        elif n.kind == PAINT:
            paint = tuple(d.args(i, state, h))
            if not np.isfinite(paint).all():   # an empty leaf, as the tracer makes it
                m = np.full((4, 4), np.nan)
        elif n.kind == MATERIAL:
            material = n.name
        if n.kind in OPERATORS.values():
            for k in reversed(range(len(n.children))):   # reversed: left operand first out
                stack.append((n.children[k], state, d.edge(h, i, k), m, paint, material,
                              path + ((i, k),), level))
        else:
            stack.append((n.children[0], state, h, m, paint, material, path, level))
