"""Hyper-bounding boxes (Gervautz & Traxler §5): one box per node, in the frame
in which the node receives the ray, enclosing every instance of that node.

Each instance's box is computed bottom-up from its own children with its real
parameter values, so a rotated child is bounded by its transformed primitives'
boxes rather than by a box grown turn after turn (the paper's Fig. 9), and a
node's hyper box is the union of its instances' boxes: exact and conservative.
Instances are memoised on the parameters their geometry can depend on; when a
system has too many distinct states for that (the terrain: every patch has its
own heights), the numba walk in pcsg.trace.boxwalk visits every instance.
"""
from __future__ import annotations

from contextvars import ContextVar

import numpy as np

from ..language.errors import Diagnostic, PcsgError
from ..limits import BOUNDS_BUDGET, DEEPEST_DEFAULT, MAX_DEPTH
from ..language.names import PIXELS
from ..recursion import recursion_limit
from ..trace.primitives import CODES, hull, object_box
from .dependence import StateKey
from .derive import Deriver, State
from .fuse import fuse_runs
from .linear import SINGULAR, map_fault
from .passthrough import fill_boxes, without_passable
from .model import CALC, DIFFERENCE, INTERSECTION, PRIMITIVE, SELECT, TRANSFORM, UNION, Graph
from .states import StateTable, state_table
from .stats import MAX_LEVELS
from .terminating import terminating_rules

EMPTY = np.array([np.inf, np.inf, np.inf, -np.inf, -np.inf, -np.inf])
MAX_STATES = 5_000     # beyond this the compiled walk is faster
PROBE_STATES = 500     # states after which a walk that almost never meets a state twice
                       # (every terrain patch has its own heights) gives up early
PROBE_RANDOM = 100     # the same where states hold values drawn from rand() (StateKey.random):
                       # the terrain's attempt took 14 ms to give up at 500, 5 ms at 100


NOTHING = np.zeros((0, 3))
# the sizes at which a selection that reads `pixels` is asked for its rules: straddling
# any threshold between 1/16 and 16 million pixels, within a factor 1.5
PIXEL_PROBES = (0.0, *(m * 2.0 ** k for k in range(-4, 25) for m in (1.0, 1.5)), np.inf)
SEED = np.zeros((1, 3))         # a point: a graftal's growth starts there
POLL = ContextVar("bounds_poll", default=None)   # bound()'s poll, for the walkers it makes
POLL_EVERY = 1024               # new states between two asks of it
MEMOISED = "memoised"
ANY_RULE = "any rule"           # memoised, with every rule of each selection (_any_rule)


class TooManyStates(Exception):
    pass


class DoesNotContract(TooManyStates):
    """Endless states whose maps take no box into themselves: their attractor is unbounded
    (an IFS with a map that shrinks nothing, `S → move(1, 0, 0) S ∪ ...`). `nodes`: their
    S-nodes."""

    def __init__(self, nodes: list[int]):
        super().__init__(nodes)
        self.nodes = nodes


def voids_of(graph: Graph, endless: list[int]) -> frozenset:
    """The S-nodes `endless` (found DoesNotContract) as a set, where none of them derives
    a primitive: an IFS without a primitive has an attractor only where its maps contract,
    so there is nothing of these to draw. Empty where one of them derives a primitive (a
    row of spheres without end is drawn as far as --max-depth goes)."""
    if any(_derives_primitive(graph, i) for i in endless):
        return frozenset()
    return frozenset(endless)


def _derives_primitive(graph: Graph, i: int) -> bool:
    from .checks import reachable
    return any(below and n.kind == PRIMITIVE for below, n in zip(reachable(graph, i),
                                                                    graph.nodes))


def not_contracting(graph: Graph, found: DoesNotContract, void: bool = False
                    ) -> list[Diagnostic]:
    """The warning for states bound() found DoesNotContract: without bounds the tracer
    can neither cull them nor refine them to pixel size (every ray that meets them
    entered --max-instances instances and drew nothing)."""
    from .checks import reachable
    from .volumes import graftal_nodes
    # the one that grows of itself: a state above it grows with it (A → uscale(0.3) S,
    # where S's own maps do not contract, named A where A came first)
    sinks = [i for i in found.nodes
             if not any(below[j] for below in [reachable(graph, i)]
                        for j in found.nodes if j != i)]
    i = (sinks or found.nodes)[0]
    s = graph.nodes[i]
    what = ("is a graftal (no rule of it ends)" if i in graftal_nodes(graph) else
            "calls itself without end (with the same parameters)")
    return [Diagnostic("warning", f"'{s.name}' {what}, through maps that take no box found "
                       f"into itself (maps that do not shrink it, or shrink it only over many "
                       f"cycles): an IFS has a bounded attractor only where its maps contract, "
                       + ("and no primitive stands on its cycles either, so `render` draws "
                          "nothing of it" if void else
                          "and `render` can neither bound this one nor refine it to pixel "
                          "size"),
                       s.span, graph.source, code="non-contracting")]


def transform_box(m: np.ndarray, box: np.ndarray) -> np.ndarray:
    """The box of the image of `box` under the affine map m (3x4 or 4x4): interval
    arithmetic per axis, exact for boxes; infinite extents stay infinite."""
    if box[0] > box[3]:
        return EMPTY.copy()
    out = np.empty(6)
    for i in range(3):
        lo = hi = m[i, 3]
        for j in range(3):
            a = m[i, j]
            if a > 0:
                lo, hi = lo + a * box[j], hi + a * box[j + 3]
            elif a < 0:
                lo, hi = lo + a * box[j + 3], hi + a * box[j]
        out[i], out[i + 3] = lo, hi
    return out


def union_box(a, b):
    return np.concatenate([np.minimum(a[:3], b[:3]), np.maximum(a[3:], b[3:])])


def intersect_box(a, b):
    out = intersect_rows(a, b)
    return out if np.all(out[:3] <= out[3:]) else EMPTY.copy()


def intersect_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The box (6,), or the boxes (n, 6) row by row, that both a and b hold; an empty
    one as it comes (lo above hi)."""
    return np.concatenate([np.maximum(a[..., :3], b[..., :3]),
                           np.minimum(a[..., 3:], b[..., 3:])], axis=-1)


MAX_POINTS = 256       # corner points kept per instance before they are merged into a box
MAX_ROUNDS = 400       # fixed-point rounds for systems that re-enter the same state


def as_box(b: np.ndarray) -> np.ndarray:
    """A bound is either finite corner points (k, 3) or a box (6,) with infinite sides."""
    if b.ndim == 2:
        if len(b) == 0:
            return EMPTY.copy()
        return np.concatenate([b.min(axis=0), b.max(axis=0)])
    return b


def _corners(box: np.ndarray) -> np.ndarray:
    if box[0] > box[3]:
        return np.zeros((0, 3))
    if not np.isfinite(box).all():
        return box
    lo, hi = box[:3], box[3:]
    return np.array([[(lo, hi)[i][0], (lo, hi)[j][1], (lo, hi)[k][2]]
                     for i in (0, 1) for j in (0, 1) for k in (0, 1)])


def transform_bound(m: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Points map exactly (no growth under rotation: the paper's Fig. 9); boxes with
    infinite sides by interval arithmetic. A non-finite map empties its operand, as in
    the tracer."""
    if not np.isfinite(m).all():    # the method, not np.all: a third of this call's time
        return EMPTY.copy()
    if b.ndim == 2:
        return b @ m[:3, :3].T + m[:3, 3]
    return transform_box(m, b)


def unite_bounds(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    if a.ndim == 2 and b.ndim == 2:
        pts = np.concatenate([a, b])
        return pts if len(pts) <= MAX_POINTS else _corners(as_box(pts))
    return union_box(as_box(a), as_box(b))


class _Walker:
    """One round of the memoised walk; re-entering a state that is still being computed
    (an endless system) takes the previous round's estimate of it."""

    def __init__(self, graph: Graph, any_rule: bool = False):
        """any_rule: every rule of each selection, whatever it picks (ANY_RULE)."""
        self.g = graph
        self.d = Deriver(graph)
        self.any_rule = any_rule
        self.key = StateKey(graph, geometry=True, selections=not any_rule)
        self.probe = PROBE_RANDOM if self.key.random else PROBE_STATES
        self.pixel_selects = [n.kind == SELECT and graph.pixels >= 0 and
                              PIXELS in graph.exprs.reads(n.exprs[0]) for n in graph.nodes]
        self.estimate: dict = {}
        self.seed = NOTHING        # the first estimate of a re-entered state
        # S-node -> the bound every instance of it gives its parents: a graftal whose
        # bounding volume is a sphere is bounded above by that sphere (graph/volumes.py)
        self.volumes: dict = {}
        self.matrices: dict = {}   # T-node memo key -> its matrix, kept across rounds
        self.faults: set = set()   # (kind, T-node) of the maps that emptied an instance
        # where the derivation goes deeper than the tracer's depth bound, the tracer
        # finishes the instances at the bound with their terminating rule
        # (terminating.py): with `finish_too` every S-node's bound holds that rule's
        # geometry as well as the selected one's, at any level (keyed by level, the
        # states of a deep system recurring at many levels were too many to memoise)
        self.finish_too = False
        self.finishing = terminating_rules(graph)
        # S-nodes whose maps do not contract and which derive no primitive (voids_of):
        # bounded as empty, so nothing of them is walked or drawn
        self.voids: frozenset = frozenset()
        # bound()'s poll (--timeout, Ctrl-C's check), asked every POLL_EVERY new states:
        # rounds of 5,000 states each, and tries of several walkers, ran for a minute
        self.poll = POLL.get()
        self.states = 0
        self.reset()

    def reset(self):
        self.memo: dict = {}
        # memo key -> the levels from it to the deepest S-node with a terminating rule
        # under it (None: none), and the deepest such level the round reached: where that
        # reaches the depth bound, the tracer finishes instances there
        self.below: dict = {}
        self.deepest = -1
        self.hits = 0
        self.active: set = set()
        self.reentered: set = set()
        self.boxes = np.tile(EMPTY, (len(self.g.nodes), 1))

    def box(self, i: int, state, h: int, level: int) -> np.ndarray:
        n = self.g.nodes[i]
        if i in self.voids:
            return self.nothing
        if n.kind == PRIMITIVE:
            b = self.leaf(n.name, self.g.constant_args(i))
            self.record(i, b)
            return b
        key = self.key(i, state, h)
        hit = self.memo.get(key)
        if hit is not None:
            self.hits += 1
            if self.below[key] is not None:
                self.deepest = max(self.deepest, level + self.below[key])
            return hit
        if key in self.active:
            self.reentered.add(key)
            return self.volumes.get(i, self.estimate.get(key, self.seed))
        if len(self.memo) >= MAX_STATES or level >= MAX_LEVELS or \
                (len(self.memo) >= self.probe and self.hits < len(self.memo) // 50):
            raise TooManyStates
        self.active.add(key)
        self.states += 1
        if self.poll is not None and self.states % POLL_EVERY == 0:
            self.poll(self.states, None)
        finishes = n.kind == SELECT and self.finishing.get(i, -1) >= 0
        outer, self.deepest = self.deepest, (level if finishes else -1)
        if n.kind == SELECT:
            b = self.nothing
            rules = self.rules(i, state, h)
            if self.finish_too and finishes and self.finishing[i] not in rules:
                rules = [*rules, self.finishing[i]]
            for r in rules:
                b = self.unite(b, self.box(n.children[r], state, self.d.edge(h, i, r),
                                           level + 1))
            b = self.volumes.get(i, b)
        elif n.kind == CALC:
            b = self.box(n.children[0], self.d.calc(i, state, h), h, level)
        elif n.kind == TRANSFORM:
            m = self.matrices.get(key)
            if m is None:       # the key fixes the matrix: rounds need not derive it again
                m = self.d.matrix(i, state, h)
                fault = map_fault(m)
                if fault is not None:
                    self.faults.add((fault, i))
                if fault == SINGULAR:
                    m = EMPTIED         # the tracer empties the instance: so do the bounds
                self.matrices[key] = m
            b = self.transform(m, self.box(n.children[0], state, h, level))
        elif n.kind in (UNION, INTERSECTION, DIFFERENCE):
            parts = [self.box(c, state, self.d.edge(h, i, k), level)
                     for k, c in enumerate(n.children)]
            b = parts[0]
            for p in parts[1:]:
                if n.kind == UNION:
                    b = self.unite(b, p)
                elif n.kind == INTERSECTION:
                    b = self.intersect(b, p)
        else:       # paint, material
            b = self.box(n.children[0], state, h, level)
        self.active.discard(key)
        self.memo[key] = b
        self.below[key] = self.deepest - level if self.deepest >= 0 else None
        self.deepest = max(outer, self.deepest)
        self.record(i, b)
        return b

    # The bound algebra: corner points (k, 3) or boxes (6,). The sphere walker
    # (graph/spheres.py) walks the same instances with balls instead.
    nothing = NOTHING
    unite = staticmethod(unite_bounds)
    transform = staticmethod(transform_bound)

    @staticmethod
    def leaf(name: str, args) -> np.ndarray:
        """A polytope's own corners (a triangle's three, not its box's four), else its
        object box's: they map exactly, so an instance's box is its mapped corners' box."""
        corners = hull(CODES[name])
        return _corners(object_box(name, args)) if corners is None else corners

    @staticmethod
    def intersect(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return _corners(intersect_box(as_box(a), as_box(b)))

    def record(self, i: int, b: np.ndarray) -> None:
        row = self.boxes[i]         # in place: a new box per record was most of its time
        if b.ndim == 2:
            if len(b):
                np.minimum(row[:3], b.min(axis=0), out=row[:3])
                np.maximum(row[3:], b.max(axis=0), out=row[3:])
        else:
            np.minimum(row[:3], b[:3], out=row[:3])
            np.maximum(row[3:], b[3:], out=row[3:])

    def rules(self, i: int, state, h: int) -> list[int]:
        """The rule the selection picks; for one that reads `pixels`, every rule it picks
        at PIXEL_PROBES (the tracer may see the instance at any size); every rule for a
        walk that takes any rule."""
        if self.any_rule:
            return list(range(len(self.g.nodes[i].children)))
        if not self.pixel_selects[i]:
            return [self.d.select(i, state, h)]
        found, error = set(), None
        slot = self.g.pixels
        for v in PIXEL_PROBES:
            probe = State(state.values.copy(), state.assigned)
            probe.values[slot] = v
            try:
                found.add(self.d.select(i, probe, h))
            except PcsgError as e:        # that size gives an empty instance
                error = e
        if not found:
            raise error
        return sorted(found)


def deep_derivation(graph: Graph, deepest: int, span=None) -> Diagnostic:
    """The warning for a derivation that ends `deepest` levels down, past DEEPEST_DEFAULT:
    a render cuts it (render's bounds and `check` say it alike)."""
    return Diagnostic("warning", f"the derivation ends {deepest:,} levels down, deeper than "
                      f"the {DEEPEST_DEFAULT:,} a render follows without --max-depth: it is "
                      f"cut at {MAX_DEPTH}; --max-depth {deepest + 1} draws it whole", span,
                      graph.source, code="deep-derivation")


def _memoised(graph: Graph, faults: set | None = None, max_depth: int | None = None,
              voids: frozenset = frozenset(), any_rule: bool = False, said: list | None = None
              ) -> tuple[tuple[np.ndarray, dict, StateTable | None], int]:
    """_memoised_walk's boxes, and the depth bound they hold: `max_depth`, or with None
    the derivation's own depth where it ends within DEEPEST_DEFAULT levels (else
    MAX_DEPTH); where the derivation reaches that bound, walked again with the
    terminating rules' geometry in every S-node's bound (pcsg.loads(..., max_depth=1) of
    40 halvings of a cube, a line in full, drew nothing where its two cut cubes stand:
    their boxes were the line's). A derivation that ends deeper than DEEPEST_DEFAULT is
    said in `said`."""
    found, deepest, ends = _memoised_walk(graph, faults, False, voids=voids,
                                          any_rule=any_rule)
    if max_depth is None:
        if ends and deepest > DEEPEST_DEFAULT and said is not None:
            # a chain of 3,000 modules drew nothing, its instances at 64 "finished with
            # their terminating rule", which only led on
            said.append(deep_derivation(graph, deepest))
        ends = ends and deepest <= DEEPEST_DEFAULT
        max_depth = max(MAX_DEPTH, deepest + 1) if ends else MAX_DEPTH
    # a state that recurs in a module with a terminating rule (Sierpinski at c=1e16,
    # where c - 1 is c) may never select that rule, but the level of detail finishes its
    # sub-pixel instances with it: without its geometry in the bounds they drew nothing
    finishing, boxes = terminating_rules(graph), found[0]
    untaken = any(finishing.get(k[0], -1) >= 0 and _empty(
        boxes[graph.nodes[k[0]].children[finishing[k[0]]]]) for k in found[1])
    if deepest >= max_depth or untaken:
        (boxes, _, states), _, _ = _memoised_walk(graph, faults, True, voids=voids,
                                                  any_rule=any_rule)
        # no hulls: the bounding spheres of graftals (graph/spheres.py) would be walked
        # from them without the terminating rules, and boxes bound their graftals too
        found = boxes, {}, states
    return found, max_depth


def _memoised_walk(graph: Graph, faults: set | None, finish_too: bool, walker=None,
                   voids: frozenset = frozenset(), any_rule: bool = False):
    """Exact boxes by the memoised walk, iterated to a fixed point over re-entered
    states; TooManyStates when memoising cannot help. A re-entered state that stays
    empty (a graftal: no primitive below its cycle) is bounded as an IFS attractor.
    Also returns the bounds the last round took for the re-entered states (state key ->
    corner points whose hull holds that state's attractor), where bounding spheres
    start (graph/spheres.py), and where no state is re-entered, the boxes by state
    (graph/states.py). `faults` gets (kind, T-node) where a map with non-finite
    arguments (NONFINITE) or a singular one (SINGULAR) emptied an instance. Also returns
    the deepest S-node level the walk reached, and whether the derivation ends (no state
    was re-entered: the boxes by state may still be None, where they would cull no more
    than the node boxes or rand() decides)."""
    w = (walker or _Walker)(graph, any_rule)
    w.finish_too = finish_too
    w.voids = voids
    if faults is not None:
        w.faults = faults

    def round_():
        w.reset()
        state, h = w.d.initial()
        w.box(graph.root, state, h, 0)
        return {k: w.memo[k] for k in w.reentered}

    for _ in range(MAX_ROUNDS):
        new = round_()
        if not new:
            return ((w.boxes, {}, state_table(graph, w.memo, w.key, w.finishing)),
                    w.deepest, True)
        if all(k in w.estimate and _same(as_box(new[k]), as_box(w.estimate[k])) for k in new):
            if any(_empty(as_box(v)) for v in new.values()):
                return (*_attractor_boxes(w, round_), None), w.deepest, False
            return (w.boxes, {k: w.estimate[k] for k in new}, None), w.deepest, False
        w.estimate.update(new)
    # Rounds that do not settle though the maps contract: corner points merged into a box
    # past MAX_POINTS went round five estimates without end (two maps, one with a
    # rotz(40)), and boxes turned by a map that shrinks less than it widens a box
    # (uscale(0.72) rotz(45)) grow without end; walked instance by instance, such systems
    # took 40 s at 64x48 and lost branches to --max-instances (QA). The attractor's bound
    # does not need them to settle: balls the maps take into themselves, holding what the
    # cycles draw, and rounds of hulls from there.
    # Maps that do not contract find no such balls, and no boxes that hold: those go on
    # as before (the rules taken all at once, or the instance walk).
    try:
        return (*_attractor_boxes(w, round_), None), w.deepest, False
    except DoesNotContract:
        raise TooManyStates from None


class _FiniteWalker(_Walker):
    """The memoised walk with every unbounded operand of a union left out: the object
    without its ground plane, which the default camera frames (finite_root)."""

    @staticmethod
    def unite(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        if not np.isfinite(b).all():
            return a
        return b if not np.isfinite(a).all() else unite_bounds(a, b)


def finite_root(graph: Graph) -> np.ndarray | None:
    """The box of what the axiom derives, without the unbounded operands of its unions (a
    ground plane): the object's own box, which a module's hyper box below the axiom's
    block is not (it holds every instance of the module). None where the memoised walk
    cannot bound the system (too many states), where an unbounded operand stands under ∩
    or \\ (`(plane ∪ sphere) ∩ cube` is the cube's slab, not the sphere), or where no
    finite part is left but a point (planes at every level of a graftal)."""
    from .checks import reachable
    for i, n in enumerate(graph.nodes):
        if n.kind in (INTERSECTION, DIFFERENCE):
            below = reachable(graph, i)
            if any(below[j] and m.kind == PRIMITIVE and not np.isfinite(
                    object_box(m.name, graph.constant_args(j))).all()
                   for j, m in enumerate(graph.nodes)):
                return None
    try:
        with recursion_limit(20 * MAX_LEVELS):
            (boxes, _, _), _, _ = _memoised_walk(graph, None, False, _FiniteWalker)
    except (TooManyStates, PcsgError):
        return None
    box = boxes[graph.root]
    if not (np.isfinite(box).all() and box[0] <= box[3]) or \
            np.all(box[3:] - box[:3] <= 1e-9 * (1 + np.abs(box).max())):
        return None
    return box


def _attractor_boxes(w: _Walker, round_) -> tuple[np.ndarray, dict]:
    """Boxes of a system whose cycles carry no primitive, by Hutchinson's theorem: a
    set that the system's maps take into itself holds the attractor. Such a set is a
    ball about each re-entered state, doubled until one round of the maps keeps the balls
    inside themselves; where doubling finds none (a cycle whose maps' singular values
    multiply to 1 or more, though the cycle's own map contracts), each state's box grows
    from a point (and a hair each round) until a round from the boxes stays inside them.
    From there, each further round still holds the attractor and shrinks the boxes
    towards it."""
    w.seed = SEED
    w.estimate = {}
    first = {k: as_box(v) for k, v in round_().items()}
    held = _invariant_balls(w.g, first, w.any_rule)
    if held is not None:
        found = _tighten(w, round_, held, None)
        if found is not None:
            _contracting(w.g, held, found[1])
            return found
    est: dict = {}
    for _ in range(MAX_ROUNDS):
        w.estimate = est
        new = {k: as_box(v) for k, v in round_().items()}
        outside = [k for k, b in new.items() if not (k in est and _inside(b, as_box(est[k])))]
        if est and not outside:
            break
        est = {k: _corners(_widen(union_box(as_box(est.get(k, SEED)), b), GROWTH))
               for k, b in new.items()}
    else:
        # named by the states still outside their estimates: those that grow without end
        raise DoesNotContract(sorted({k[0] for k in outside}))
    return _tighten(w, round_, {k: _corners(b) for k, b in new.items()}, w.boxes.copy(), est)


def _contracting(graph: Graph, held: dict, after: dict) -> None:
    """Raises DoesNotContract for the states without a primitive that the first round
    from the balls that hold them did not shrink at all (`S → S`, `S → S ∪ uscale(0.5) S`):
    their maps keep any ball, so no attractor is singled out, and the ball was drawn at
    the depth limit as if it were one. A state with a primitive keeps its bounds (the
    ball holds what it draws)."""
    kept = {k[0] for k, hull in after.items()
            if k in held and _same(as_box(hull), as_box(held[k]), 1e-9)}
    void = [i for i in sorted(kept) if not _derives_primitive(graph, i)]
    if void:
        raise DoesNotContract(void)


def _invariant_balls(graph: Graph, first: dict, any_rule: bool) -> dict | None:
    """Corner points of the box about a ball per re-entered state, the balls such that
    one round of the maps (graph/spheres.py's ball walk) takes them into themselves:
    they hold the attractors. About the centres of the first round's boxes, the radius
    doubled from their size; None if no radius up to 2^60 times that will do."""
    from .spheres import _BallWalker, reach
    walker = _BallWalker(graph, any_rule)
    boxes = [b for b in first.values() if b[0] <= b[3]]
    if len(boxes) != len(first) or not np.all(np.isfinite(boxes)):
        return None
    centres = {k: (b[:3] + b[3:]) / 2 for k, b in first.items()}
    radius = max(float(np.abs(b).max()) for b in boxes) + 1.0
    for _ in range(60):
        balls = {k: np.append(c, radius) for k, c in centres.items()}
        out = walker.round(balls)
        if out is None or out.keys() != balls.keys():
            return None
        if all(len(v) == 0 or reach(v, balls[k][None, :3])[0] <= radius
               for k, v in out.items()):
            return {k: _corners(np.concatenate([c - radius, c + radius]))
                    for k, c in centres.items()}
        radius *= 2
    return None


def _tighten(w: _Walker, round_, hulls: dict, boxes: np.ndarray | None,
             used: dict | None = None) -> tuple[np.ndarray, dict] | None:
    """From hulls that hold the re-entered states' attractors, the boxes each node keeps
    and the hulls of the last round used; None if the first round meets a state the
    hulls do not bound (with no boxes given).
    Each estimate's convex hull holds its attractor; the maps are affine, so a round's
    corner points span hulls that hold it too, and these hulls (not their boxes) shrink
    towards the attractor, past what boxes turned by the maps could reach. Every round's
    boxes hold what they bound, so each node keeps the intersection of its boxes: the
    rounds themselves need not settle (the fern's hulls, cut back to their boxes'
    corners where they gather too many points, pass that slack around its three states
    without end, and a node's box of the last round was up to a third wider)."""
    for _ in range(TIGHTEN_ROUNDS):
        w.estimate = hulls
        tighter = round_()
        if not all(k in hulls for k in tighter):
            break           # a state the hulls do not bound: keep the rounds before
        used = hulls
        shrunk = w.boxes.copy() if boxes is None else intersect_rows(boxes, w.boxes)
        if boxes is not None and _same(shrunk, boxes, 1e-9):
            boxes = shrunk
            break
        boxes, hulls = shrunk, tighter
    return None if boxes is None else (boxes, used)


GROWTH = 1e-9           # relative widening per growing round: makes containment strict
TIGHTEN_ROUNDS = 200


EMPTIED = np.full((4, 4), np.nan)   # a singular map's stand-in: every walker empties by it
EMPTIED.flags.writeable = False
FAULTS = (("the arguments of this transformation are not finite", "non-finite-map"),
           ("this transformation is singular (a zero scale) or too large to invert",
            "singular-map"))


def fault_warnings(graph: Graph, walked: Graph, faults, counted: bool) -> list[Diagnostic]:
    """Warnings at the T-nodes of `walked` (the graph a walk took) whose maps emptied
    instances: (kind, count, node) each, the count of instances where `counted`. Such an
    instance's box is empty too, so no ray reaches it to report a runtime error: the
    walk that met it does, once for its T-node (notation §4)."""
    from .checks import constant_map_warning
    out = []
    for kind, count, node in faults:
        if (said := constant_map_warning(walked, node)) is not None:
            out.append(said)            # every instance, as check says
            continue
        many = (f"{count:,} instance{'s' if count != 1 else ''}" if counted else
                "some instances")
        what, code = FAULTS[kind]
        verb = "is" if counted and count == 1 else "are"
        out.append(Diagnostic("warning", f"{what} in {many}, which {verb} empty (a runtime "
                              f"error in the grammar)", walked.nodes[node].span,
                              graph.source, code=code))
    return out


def _empty(b: np.ndarray) -> bool:
    return bool(b[0] > b[3])


def _widen(box: np.ndarray, margin: float) -> np.ndarray:
    """The box grown by `margin` of its coordinates' size on each axis. Not by a hair on
    an axis where it is a point: a map that stretches that axis into another (rotz(90)
    scale(1.5, 0.5, 0.5), which contracts over two cycles) took the hair of one round past
    the next round's, and the growth never held the attractor (a line on the z axis)."""
    pad = margin * (np.abs(box[:3]) + np.abs(box[3:]) + (box[3:] - box[:3]))
    return np.concatenate([box[:3] - pad, box[3:] + pad])


def _inside(a: np.ndarray, b: np.ndarray) -> bool:
    return bool(_empty(a) or (np.all(a[:3] >= b[:3]) and np.all(a[3:] <= b[3:])))


def _same(a, b, tol: float = 1e-13) -> bool:
    scale = np.nanmax(np.abs(np.where(np.isfinite(a), a, 0.0))) + 1e-300
    both = np.isfinite(a) & np.isfinite(b)
    return bool(np.array_equal(np.isfinite(a), np.isfinite(b))
                and np.all(np.abs(a[both] - b[both]) <= tol * scale))


def _any_rule(graph: Graph, max_depth: int | None):
    """bound() of a graftal whose instances differ only in what its selections read (a
    rand() or a counter decides the rule): memoised on the parameters its maps read,
    with every rule of each selection taken. Every attractor its selections can pick
    lies in the attractor of all its rules' maps together (Hutchinson), which this
    bounds; walked instance by instance, such a graftal had no bounding volume and was
    drawn as nothing, after every ray entered --max-instances instances. None where
    that walk cannot bound it either (its maps read what differs, or together they do
    not contract): the instance walk is tried then, as before."""
    from .volumes import graftal_nodes
    if not graftal_nodes(graph):
        return None     # a system that ends is bounded as it derives, instance by instance
    return _memoised_bound(graph, max_depth, [], any_rule=True)


def _unboundable_voids(graph: Graph, max_depth: int | None):
    """bound() where not even _any_rule bounds a graftal (what differs from instance to
    instance feeds its maps: `rotz(20 * rand())`): a graftal without a primitive on its
    cycles then has nothing to draw (no bounding volume holds its instances, and a
    graftal is drawn as its volumes), so it is bounded as empty, as one whose maps do not
    contract (voids_of), and said so. Before, every ray entered --max-instances of its
    instances to draw nothing (38 s at 48x36). None where there is no such graftal or the
    rest cannot be memoised either."""
    from .volumes import graftal_nodes
    voids = frozenset(s for s in graftal_nodes(graph) if not _derives_primitive(graph, s))
    if not voids:
        return None
    return _memoised_bound(graph, max_depth, [Diagnostic(
        "warning", f"'{graph.nodes[i].name}' is a graftal (no rule of it ends) whose "
        f"instances differ in their maps (values drawn by rand(), or counted): no bounding "
        f"volume found holds them all, and no primitive stands on its cycles, so `render` "
        f"draws nothing of it; give its maps the same arguments in every instance (a "
        f"rand() may pick the rule)", graph.nodes[i].span, graph.source,
        code="unbounded-graftal") for i in sorted(voids)], voids)


def _memoised_bound(graph: Graph, max_depth: int | None, problems: list,
                    voids: frozenset = frozenset(), any_rule: bool = False,
                    faults: set | None = None):
    """bound()'s result by the memoised walk (`_memoised`'s arguments), `problems`
    before the faults of its maps, or None where that walk cannot bound the system. With
    `any_rule` no fault is said: its instances include some the selections never pick,
    and the tracer's own walk reports the faults of those they do."""
    faults = set() if faults is None else faults
    said: list = []
    try:
        with recursion_limit(20 * MAX_LEVELS):
            (boxes, hulls, states), depth = _memoised(graph, faults, max_depth, voids,
                                                      any_rule, said)
    except (TooManyStates, PcsgError):
        return None
    problems = problems + said
    if not any_rule:
        problems = problems + fault_warnings(graph, graph, [(k, 0, f) for k, f
                                                            in sorted(faults)], counted=False)
    return (boxes, ANY_RULE if any_rule else MEMOISED, problems, states, hulls, depth, graph,
            depth)


def hyper_boxes(graph: Graph, max_depth: int = 64):
    """(n, 6) boxes (xmin, ymin, zmin, xmax, ymax, zmax) per node; which method computed
    them: 'memoised', 'any rule' (ANY_RULE), 'every instance', or 'unbounded' when there
    were too many instances to visit (then no box culls anything: slow, never wrong); and
    the runtime errors met on the way (an invalid selection: that instance is empty)."""
    return bound(graph, max_depth)[:4]


def bound(graph: Graph, max_depth: int | None = MAX_DEPTH, budget: int = BOUNDS_BUDGET,
          poll=None, fuse: bool = False):
    """_bound, with `poll` asked every POLL_EVERY states of the memoised walks too."""
    token = POLL.set(poll)
    try:
        return _bound(graph, max_depth, budget, poll, fuse)
    finally:
        POLL.reset(token)


def _bound(graph: Graph, max_depth: int | None, budget: int, poll, fuse: bool):
    """hyper_boxes, the instance table (for the memoised method a StateTable or
    None: graph/states.py), for the memoised method the re-entered states'
    final bounds (see _memoised; empty otherwise), the derivation depth the boxes
    hold: max_depth (None: as deep as a memoised derivation that ends goes, see
    _memoised, else MAX_DEPTH), or less where the instances are more than `budget`
    node visits can visit (the tracer must then stop refining there; a warning says
    so), the graph they are for, and the depth asked for (None resolved as above). With
    `fuse`, a system bounded instance by instance has its runs of maps written out as one
    first (graph/fuse.py): that graph is the one bounded."""
    problems = []
    faults: set = set()
    too_many = False            # the memoised walk met too many states
    try:
        with recursion_limit(20 * MAX_LEVELS):
            (boxes, hulls, states), max_depth = _memoised(graph, faults, max_depth,
                                                          said=problems)
        problems += fault_warnings(graph, graph, [(k, 0, f) for k, f in sorted(faults)],
                                   counted=False)
        return boxes, MEMOISED, problems, states, hulls, max_depth, graph, max_depth
    except DoesNotContract as found:
        voids = voids_of(graph, found.nodes)
        problems = not_contracting(graph, found, bool(voids))
        # nothing to bound and nothing to draw: walked instance by instance, every ray
        # entered --max-instances instances (a minute at 160x120) and drew nothing
        if voids and (found := _memoised_bound(graph, max_depth, problems, voids,
                                               faults=faults)) is not None:
            return found
    except TooManyStates:
        if (found := _any_rule(graph, max_depth) or _unboundable_voids(graph, max_depth)) \
                is not None:
            return found
        too_many = True
    except PcsgError as e:
        problems = [Diagnostic("warning", d.message + "; that instance is empty", d.span,
                               d.source, d.notes, d.code) for d in e.diagnostics]
    if max_depth is None:
        max_depth = MAX_DEPTH
    from ..trace.boxwalk import walk_boxes
    from ..trace.instance_table import empty_table
    if graph.pixels >= 0:       # the instance walk knows no pixel sizes: no boxes
        # said, as the walk's own "nothing is bounded" is: a render 100 times slower than
        # the same system without `pixels`, without a word (QA)
        problems += [] if not too_many else [Diagnostic(
            "warning", "selections read `pixels`, and this system's instances differ in "
            "what bounds them (maps or selections that read rand() or counters), which only "
            "a walk of every instance bounds, and that walk knows no pixel sizes: nothing is "
            "bounded, so every ray walks all the instances it meets (slow); without `pixels` "
            "in its selections it would be walked and bounded", None, graph.source,
            code="unbounded")]
        n = len(graph.nodes)
        return (np.tile(-EMPTY, (n, 1)), "unbounded", problems, empty_table(), {}, max_depth,
                graph, max_depth)
    if fuse:
        graph = fuse_runs(graph)
    walked, skipped = without_passable(graph)
    found: list = []
    boxes, complete, table, depth = walk_boxes(walked, max_depth, budget, instances=True,
                                               poll=poll, cache=True, faults=found)
    fill_boxes(boxes, skipped)
    problems += fault_warnings(graph, walked, [(k, c, n) for k, (c, n) in enumerate(found[0])
                                               if c], counted=True)
    if not complete and not any(p.code == "non-contracting" for p in problems):
        # no box at all: every ray walks every instance it meets, thousands of times slower
        # (the terrain at --bounds-budget 100 ran for minutes, and said nothing)
        # a system that never ends is walked whole or not at all (walk_boxes): a larger
        # budget does not help it, a depth does (QA: 60 s and more, 3 s at --max-depth 16)
        endless = any(r < 0 for r in terminating_rules(graph).values())
        remedy = (f"; it never ends, and is bounded only walked whole, to --max-depth "
                  f"{max_depth}: a smaller --max-depth (16, say) ends it where its instances "
                  f"can be walked" if endless else "; a larger budget bounds them")
        problems.append(Diagnostic(
            "warning", f"the instances are too many to bound within --bounds-budget "
            f"{budget:,} node visit{'' if budget == 1 else 's'} even a few levels deep: "
            f"nothing is bounded, so every ray walks all the instances it meets "
            f"(slow){remedy}", None, graph.source, code="unbounded"))
    elif depth < max_depth:
        # --max-depth takes 1 and more: at 0 the option to name is the budget alone
        as_with = f", as with --max-depth {depth}" if depth else ""
        problems.append(Diagnostic(
            "warning", f"the instances below derivation depth {depth} are too many to bound "
            f"one by one; refinement stops there{as_with}: deeper instances are finished "
            f"with their terminating rule (--bounds-budget {budget:,} node "
            f"visit{'' if budget == 1 else 's'}; a larger budget bounds deeper, and takes "
            f"longer)", None, graph.source, code="depth-bounded"))
    return (boxes, "every instance" if complete else "unbounded", problems, table, {}, depth,
            graph, max_depth)
