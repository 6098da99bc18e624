"""The derivation's primitives in chunks of arrays, for writers of the whole expansion
(`pcsg export --pov`): from the compiled walk (trace/leafwalk.py), or from the Python
derivation (flatten.instances, the reference's). Both give the same primitives in the
same order, and the same ∩ and \\ blocks above them."""
from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from ..language.errors import PcsgError
from .cut import VOLUME_NAMES, Cut
from .derive import Deriver, State, too_deep
from .flatten import instances
from .model import PRIMITIVE, Graph
from .stats import MAX_LEVELS

CHUNK = 1 << 16              # primitives per chunk of the compiled walk
CHAIN_BYTES = 1 << 25        # the most a chunk's chains take: fewer primitives where deep
PYTHON_CHUNK = 1 << 10       # per chunk of the Python derivation: 0.1 s of it


@dataclass
class Leaves:
    node: np.ndarray          # (k,) int: the primitive node
    world: np.ndarray         # (k, 3, 4): world from the primitive's object frame
    paint: np.ndarray         # (k, 3): the innermost paint above it, nan where none
    material: np.ndarray      # (k,) int: the innermost material above it (an index
                              # of graph.material_names), -1 where none
    # the CSG operators above each, from the first ∩ or \\ down (the blocks of an export):
    # the Python derivation's paths (Instance.path: every operator), or the compiled
    # walk's chains, (k, w, 3) rows of (instance id, node, operand) and their lengths
    paths: list | None = None
    chain: np.ndarray | None = None
    csg: np.ndarray | None = None
    # per primitive of a cut graftal: the volumes that clip it (Instance.clip), else ()
    clips: list | None = None

    def __len__(self) -> int:
        return len(self.node)


def leaf_names(graph: Graph) -> list[str]:
    """The primitive name of each Leaves.node: the graph's nodes', then the volumes' of
    cut graftal instances (graph/cut.py), which need not be nodes of the graph."""
    return [n.name for n in graph.nodes] + list(VOLUME_NAMES.values())


def leaf_chunks(graph: Graph, compiled: bool = True, cut: Cut | None = None
                ) -> Iterator[Leaves]:
    """Every primitive of the derivation, in derivation order, cut where `cut` says;
    compiled=False: from the Python derivation, which alone writes the volumes of cut
    graftal instances, so a cut through a graftal takes it."""
    if cut is not None and cut.graftal:
        compiled = False
    yield from (_compiled(graph, cut) if compiled else _python(graph, cut))


def _python(graph: Graph, cut: Cut | None) -> Iterator[Leaves]:
    ids = {}
    batch = []
    for inst in instances(graph, cut):
        batch.append(inst)
        if len(batch) == PYTHON_CHUNK:
            yield _batch(graph, batch, ids)
            batch = []
    if batch:
        yield _batch(graph, batch, ids)


def _batch(graph: Graph, batch: list, ids: dict) -> Leaves:
    if not ids:         # a primitive node of each name: what the writers read is its name
        n = len(graph.nodes)
        ids.update({name: n + k for k, name in enumerate(VOLUME_NAMES.values())})
        ids.update({n.name: i for i, n in reversed(list(enumerate(graph.nodes)))
                    if n.kind == PRIMITIVE})
    paint = np.array([b.paint if b.paint is not None else (np.nan,) * 3 for b in batch],
                     dtype=float)
    with np.errstate(invalid="ignore"):
        world = np.array([b.matrix[:3] for b in batch], dtype=float)
    materials = graph.material_names
    return Leaves(np.array([ids[b.primitive] for b in batch]), world, paint,
                  np.array([-1 if b.material is None else materials.index(b.material)
                            for b in batch]), paths=[b.path for b in batch],
                  clips=[b.clip for b in batch])


def _compiled(graph: Graph, cut: Cut | None) -> Iterator[Leaves]:
    from ..trace.leafwalk import (BAD_SELECTION, CHAIN_ROOM, GRAFTAL_CUT, ROOM, SP, STATUS,
                                  TOO_DEEP, walker)
    walk = walker(graph, None if cut is None else cut.depth)
    while True:
        # a chunk's chains are as long as the deepest: 65,536 of 16,384 links were 24 GiB
        k = walk.run(max(1, min(CHUNK, CHAIN_BYTES // walk.path.nbytes)))
        if k:
            csg = walk.out_csg[:k].copy()
            yield Leaves(walk.out_node[:k].copy(), walk.out_world[:k].reshape(k, 3, 4).copy(),
                         walk.out_paint[:k].copy(), walk.out_mat[:k].copy(),
                         chain=walk.out_chain[:k, :csg.max()].copy(), csg=csg)
        status = walk.state[STATUS]
        if status == ROOM:
            walk.grow()
        elif status == CHAIN_ROOM:
            walk.grow_chain()
        elif status in (BAD_SELECTION, TOO_DEEP):
            raise _stopped(graph, walk, status == TOO_DEEP)
        elif status == GRAFTAL_CUT:
            raise AssertionError("a cut graftal instance came to the compiled walk")
        elif walk.state[SP] == 0:
            return


def _stopped(graph: Graph, walk, deep: bool) -> PcsgError:
    """The error the Python derivation raises at the instance the walk stopped on: its
    selection, made again from the instance's parameters and hash, names the rule."""
    from ..trace.leafwalk import NODE, SLOT, SP
    f = walk.state[SP] - 1
    node = int(walk.fr[f, NODE])
    if deep:
        return too_deep(graph, node, MAX_LEVELS)
    values = walk.params[walk.fr[f, SLOT], :len(graph.params)].copy()
    # the parameters assigned so far: every one the walk has a number for
    assigned = sum(1 << slot for slot in np.flatnonzero(~np.isnan(values)).tolist())
    try:
        Deriver(graph).select(node, State(values, assigned), int(walk.hs[f]))
    except PcsgError as e:
        return e
    raise AssertionError("the compiled walk found a selection invalid that Python did not")
