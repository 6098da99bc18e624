"""The complete derivation as a flat list of transformed primitives: the
deliberately simple reference that the graph tracer is checked against."""
from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from ..language.errors import Diagnostic, PcsgError
from .cut import Cut
from .derive import Deriver, too_deep
from .linear import flat, invertible
from .model import CALC, MATERIAL, OPERATORS, PAINT, PRIMITIVE, SELECT, TRANSFORM, Graph
from .stats import MAX_LEVELS


@dataclass
class Instance:
    primitive: str
    matrix: np.ndarray            # 4x4, world from the primitive's object frame
    paint: tuple | None           # the innermost paint(r, g, b) or coloured material above it
    material: str | None          # the innermost material(NAME) above it
    path: tuple                   # CSG operators above it: ((node, child number), ...)
    args: tuple = ()              # a fractal's arguments
    # a cut graftal instance's volume is clipped by the volumes above it that it pokes out
    # of (graph/cut.py): (primitive, matrix) each
    clip: tuple = ()
    volume: bool = False          # a cut graftal instance's volume: a surface, no solid


def leaf_inverse(matrix: np.ndarray) -> np.ndarray | None:
    """The inverse of a leaf's world matrix, or None when the leaf is empty: a singular
    or non-finite matrix (a runtime error in its calculations or transforms) draws nothing.
    The contract of trace/reference.py, which the graph tracer and the export keep."""
    if not invertible(matrix[:3]):
        return None
    inv = np.linalg.inv(matrix)
    return inv if np.all(np.isfinite(inv)) else None


def nonempty(world: np.ndarray) -> np.ndarray:
    """leaf_inverse(m) is not None for each world map of (k, 3, 4) or (k, 4, 4), at once."""
    k = len(world)
    m = np.zeros((k, 4, 4))
    m[:, :3] = world[:, :3]
    m[:, 3, 3] = 1.0
    ok = invertible(m[:, :3])
    with np.errstate(all="ignore"):
        inv = np.linalg.inv(m[ok])
    ok[np.flatnonzero(ok)[~np.isfinite(inv).all(axis=(1, 2))]] = False
    return ok


def flatten(graph: Graph, max_primitives: int = 1_000_000, cut: Cut | None = None,
            faults: list | None = None) -> list[Instance]:
    """Every primitive of the derivation with its world matrix, in derivation order (cut
    where `cut` says). Raises PcsgError when there are more than max_primitives. With a
    `faults` list, an instance whose selection is invalid is empty, as the tracer makes
    it, and its error goes into the list (else it is raised: export, stats)."""
    out: list[Instance] = []
    for inst in instances(graph, cut, faults):
        out.append(inst)
        if len(out) > max_primitives:
            raise PcsgError([Diagnostic("error", f"the derivation has more than "
                                        f"{max_primitives:,} primitives; the reference "
                                        f"expansion is for small orders", None, graph.source,
                                        code="too-large")])
    return out


CLIP_BATCH = 4096       # cut graftal instances whose clips are found at once


def instances(graph: Graph, cut: Cut | None = None, faults: list | None = None
              ) -> Iterator[Instance]:
    """The primitives of the derivation one by one, in derivation order (left operand
    first), holding only the open branches: the form for streaming exports. With a cut
    (graph/cut.py), S-node instances deeper than its depth end as the tracer ends them."""
    held: list[tuple[Instance, tuple | None]] = []
    for inst, above in _derived(graph, cut, faults):
        held.append((inst, above))
        if above is None and len(held) == 1:
            yield held.pop()[0]         # no cut graftal instance waiting: straight through
        elif len(held) >= CLIP_BATCH:
            yield from _clipped(cut, held)
            held = []
    yield from _clipped(cut, held)


def _clipped(cut: Cut | None, held: list) -> Iterator[Instance]:
    if not held:
        return
    leaves = [(inst.primitive, inst.matrix) for inst, above in held if above is not None]
    clips = iter(cut.clips_of(leaves, [above for _, above in held if above is not None]))
    for inst, above in held:
        if above is not None:
            inst.clip = next(clips)
            inst.volume = True
        yield inst


def _derived(graph: Graph, cut: Cut | None, faults: list | None = None
             ) -> Iterator[tuple[Instance, tuple | None]]:
    """instances(), each cut graftal instance with the volumes above it (its clips to be)."""
    d = Deriver(graph)
    nodes = graph.nodes
    clipping = cut is not None and cut.graftal

    def entered(above: tuple, node: int, m: np.ndarray, parent: int = -1) -> tuple:
        # the volumes that a cut graftal instance's is clipped by (Cut.clips_of): the box or
        # sphere of every node above it, in the frame it is entered in, as the tracer's
        # windows narrow; a T-node below a T-node is entered with it, one map (graph/flat.py)
        if not clipping or (parent >= 0 and nodes[parent].kind == TRANSFORM
                            and nodes[node].kind == TRANSFORM):
            return above
        volume = cut.leaf(node, m)
        return above if volume is None else above + (volume,)

    state, h = d.initial()
    stack = [(graph.root, state, h, np.eye(4), None, None, (), 0,
              entered((), graph.root, np.eye(4)))]
    while stack:
        i, state, h, m, paint, material, path, level, above = stack.pop()
        n = nodes[i]
        if n.kind == PRIMITIVE:
            yield Instance(n.name, m, paint, material, path, graph.constant_args(i)), None
            continue
        if n.kind == SELECT:
            if level >= MAX_LEVELS:
                raise too_deep(graph, i, MAX_LEVELS)
            if cut is not None and level + 1 > cut.depth:
                r = int(cut.term[i])
                if r < 0:
                    leaf = cut.leaf(i, m)
                    if leaf is not None:            # above[-1] is its own volume
                        yield Instance(*leaf, paint, material, path), above[:-1]
                    continue
                if level + 1 > 4 * cut.depth + 64:     # a terminating rule that recurses
                    continue
            elif faults is None:
                r = d.select(i, state, h)
            else:
                try:
                    r = d.select(i, state, h)
                except PcsgError as e:
                    faults.extend(e.diagnostics)
                    continue
            c = n.children[r]
            stack.append((c, state, d.edge(h, i, r), m, paint, material, path, level + 1,
                          entered(above, c, m)))
            continue
        if n.kind == CALC:
            state = d.calc(i, state, h)
        elif n.kind == TRANSFORM:
            step = d.matrix(i, state, h)
            # empty (a nan leaf) by the map itself, as the tracer's walks test it: a flat
            # map's product with those below is singular only up to rounding
            with np.errstate(invalid="ignore", over="ignore"):
                m = np.full((4, 4), np.nan) if flat(step) else m @ step
        elif n.kind == PAINT:
            paint = tuple(d.args(i, state, h))
            if not np.isfinite(paint).all():   # an empty leaf, as the tracer makes it
                m = np.full((4, 4), np.nan)
        elif n.kind == MATERIAL:
            material = n.name
            if material in graph.scene.coloured:    # notation §8: the innermost colours
                paint = tuple(graph.scene.materials[material]["color"])
        if n.kind in OPERATORS.values():
            for k in reversed(range(len(n.children))):   # reversed: left operand first out
                c = n.children[k]
                stack.append((c, state, d.edge(h, i, k), m, paint, material,
                              path + ((i, k),), level, entered(above, c, m)))
        else:
            c = n.children[0]
            stack.append((c, state, h, m, paint, material, path, level,
                          entered(above, c, m, i)))
