"""Where a whole derivation stops, as the tracer's walk stops past its depth bound: an
S-node instance deeper than the bound follows its terminating rule (graph/terminating.py),
and one whose node has no rule that ever ends, a graftal's, becomes the bounding volume
that the tracer hits there (trace/walk.py hit_volume): the node's box or sphere, padded as
the tracer pads them, in the instance's frame. For writers of the whole expansion, which
could not otherwise derive a graftal at all: `pcsg export --pov --max-depth N` and the
reference tracer (trace/reference.py) that the tracer's cut is checked against."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .checks import reachable
from .linear import invertible
from .model import SELECT

NO_VOLUME, BOX, SPHERE = 0, 1, 2        # Cut.kind
VOLUME_NAMES = {BOX: "cube", SPHERE: "sphere"}


@dataclass
class Cut:
    """A tracer's cut, per node of its graph (cut_of)."""
    depth: int                  # S-node instances deeper than this are cut
    select: np.ndarray          # (n,) which nodes are S-nodes the derivation reaches
    term: np.ndarray            # (n,) per S-node: the rule that ends soonest, -1 if none
    kind: np.ndarray            # (n,) per node: its volume, NO_VOLUME / BOX / SPHERE
    volume: np.ndarray          # (n, 4, 4): the map of the unit cube [-1, 1]^3 or unit
                                # sphere onto the node's volume, in the node's frame

    @property
    def graftal(self) -> bool:
        """Whether an S-node has no rule that ends: its cut instances are volumes."""
        return bool((self.term[self.select] < 0).any())

    def endless_node(self) -> int:
        """The first S-node the derivation reaches that has no rule that ends (graftal)."""
        return int(np.nonzero(self.select & (self.term < 0))[0][0])

    def leaf(self, node: int, world: np.ndarray) -> tuple[str, np.ndarray] | None:
        """The volume of an instance of `node` with world map `world` (4x4), as the
        primitive of a cut graftal instance: its name and world map; None where the node
        has no finite volume."""
        kind = int(self.kind[node])
        if kind == NO_VOLUME:
            return None
        with np.errstate(invalid="ignore", over="ignore"):
            return VOLUME_NAMES[kind], world @ self.volume[node]

    def clips_of(self, leaves: list, aboves: list) -> list[tuple]:
        """For each leaf ((name, world map) of a cut graftal instance's volume), the
        volumes of its `above` ((name, world map) each) that do not hold it, which the
        tracer clips it by: a graftal's box bounds its attractor, not the boxes of its cut
        instances, and those can poke out of the boxes above. In one batch of linear
        algebra: a cut fern is thousands of leaves, each below a dozen volumes that its
        siblings share (the same objects, so each is converted once)."""
        index: dict[int, int] = {}
        volumes, owner, which = [], [], []
        for j, above in enumerate(aboves):
            for v in above:
                k = index.setdefault(id(v), len(volumes))
                if k == len(volumes):
                    volumes.append(v)
                owner.append(j)
                which.append(k)
        if not owner:
            return [() for _ in leaves]
        owner, which = np.array(owner), np.array(which)
        box = np.array([v[0] == "cube" for v in volumes])[which]
        cube_leaf = np.array([leaf[0] == "cube" for leaf in leaves])[owner]
        with np.errstate(all="ignore"):
            rel = _relative(np.array([v[1] for v in volumes]), which,
                            np.array([leaf[1] for leaf in leaves])[owner])
            a, c = rel[:, :3, :3], rel[:, :3, 3]
            held = np.zeros(len(owner), dtype=bool)
            for in_box, in_cube in ((True, True), (True, False), (False, True), (False, False)):
                sel = (box == in_box) & (cube_leaf == in_cube)
                held[sel] = _holds(in_box, in_cube, a[sel], c[sel])
        out: list[list] = [[] for _ in leaves]
        for j, k, h in zip(owner.tolist(), which.tolist(), held.tolist()):
            if not h:
                out[j].append(volumes[k])
        return [tuple(o) for o in out]


def _holds(box: bool, cube: bool, a: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Whether the unit box (box) or ball holds the unit cube (cube) or ball mapped by
    x -> a x + c, for each (a, c); nan (a singular volume) holds nothing."""
    if box:
        reach = np.abs(a).sum(axis=2) if cube else np.linalg.norm(a, axis=2)
        return (np.abs(c) + reach <= 1.0).all(axis=1)
    if cube:
        points = c[:, None] + _CORNERS @ a.transpose(0, 2, 1)
        return (np.linalg.norm(points, axis=2) <= 1.0).all(axis=1)
    # |a| (Frobenius) bounds the ball's largest radius: at worst a clip that holds it is
    # kept, and changes nothing
    return np.linalg.norm(c, axis=1) + np.sqrt((a * a).sum(axis=(1, 2))) <= 1.0


def _relative(maps: np.ndarray, which: np.ndarray, inner: np.ndarray) -> np.ndarray:
    """maps[which]^-1 inner, pair by pair (solved: the leaves can be far thinner than
    the volumes above them); nan where the map is singular (a singular transform above:
    then the instance is empty too, and the export leaves it out), which holds nothing."""
    rel = np.full(inner.shape, np.nan)
    ok = invertible(maps[:, :3])
    pairs = np.flatnonzero(ok[which])
    try:
        rel[pairs] = np.linalg.solve(maps[which[pairs]], inner[pairs])
    except np.linalg.LinAlgError:      # an exact zero pivot that the 3x3 det missed
        for j in pairs:
            try:
                rel[j] = np.linalg.solve(maps[which[j]], inner[j])
            except np.linalg.LinAlgError:
                pass
    return rel


_CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)


def cut_of(traced) -> Cut:
    """The cut of a Traced object's tracer where its walk stops (traced.max_depth), with
    the tracer's own terminating rules and padded volumes."""
    flat = traced.flat
    n = len(traced.graph.nodes)
    if len(flat.kind) != n:
        raise ValueError("the tracer's nodes are not the graph's")
    kind = np.zeros(n, dtype=np.int64)
    volume = np.zeros((n, 4, 4))
    volume[:, 3, 3] = 1.0
    box = flat.box
    finite = np.isfinite(box).all(axis=1)
    finite[finite] = (box[finite, 3:] > box[finite, :3]).all(axis=1)
    lo, hi = box[finite, :3], box[finite, 3:]
    kind[finite] = BOX
    volume[finite, :3, 3] = (lo + hi) / 2
    for a in range(3):
        volume[finite, a, a] = (hi[:, a] - lo[:, a]) / 2
    if flat.sphere.shape[0]:
        has = flat.sphere[:, 3] > 0
        kind[has] = SPHERE
        volume[has, :3] = 0.0
        volume[has, :3, 3] = flat.sphere[has, :3]
        for a in range(3):
            volume[has, a, a] = flat.sphere[has, 3]
    live = np.array(reachable(traced.graph), dtype=bool)
    return Cut(int(traced.max_depth), live & (flat.kind == SELECT),
               np.asarray(flat.term_rule, dtype=np.int64).copy(), kind, volume)
