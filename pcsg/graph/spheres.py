"""Bounding spheres of graftals (Bekaert & Willems §3.2), by the same memoised walk as
the hyper boxes (graph/bounds.py), with balls in place of corner points.

A bound is a list of balls (k, 4), centre and radius; a point is a ball of radius 0, so
a primitive's corner points map exactly, and an affine map w takes a ball B(c, r) into
B(w(c), s r), s the largest singular value of w's linear part. Each re-entered state
of an endless system is bounded by one ball. Two facts of Hutchinson's kind make the
balls safe: balls that hold the states' attractors give, after one round of the maps
(and condensation sets), balls that hold them too; and balls that one round takes into
themselves hold the attractors. So the rounds start from the balls around the box
walk's final hulls, which hold the attractors, and every round's balls hold them; each
state keeps its smallest. Where the rounds converge (a round maps the balls into
themselves), the spheres nest: every copy's sphere lies inside its parent's.
"""
from __future__ import annotations

import functools
import math
from collections import defaultdict

import numpy as np

from ..language.names import FRACTAL_PRIMITIVES
from ..trace.primitives import object_box
from .bounds import _corners, _Walker
from .model import SELECT, Graph

NO_BALLS = np.zeros((0, 4))
UNBOUNDED = np.array([[0.0, 0.0, 0.0, np.inf]])
MAX_BALLS = 128         # balls kept per instance before they are merged into one (cheaply)
ROUNDS = 200            # Hutchinson rounds at most
# the work spheres may take, so that a system with many states keeps its boxes alone
MAX_STATES = 8          # re-entered states
STATE_ROUNDS = 400      # rounds times re-entered states
MAX_INSTANCES = 256     # S-node instances gathered into the nodes' spheres
IDLE_ROUNDS = 8         # rounds without a smaller ball before the rounds stop
STILL = 1e-7            # relative change of a round below which the balls have converged
NEST_SLACK = 1e-5       # relative growth allowed to make converged balls nest


def as_balls(bound: np.ndarray) -> np.ndarray:
    """A box walk's bound, corner points (k, 3) or a box (6,), as balls."""
    if bound.ndim == 1:
        if bound[0] > bound[3]:
            return NO_BALLS
        if not np.all(np.isfinite(bound)):
            return UNBOUNDED
        bound = _corners(bound)
    return np.hstack([bound, np.zeros((len(bound), 1))])


def reach(balls: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """For each centre (m, 3), the radius of the ball about it that holds every ball."""
    d = np.linalg.norm(centre[:, None, :] - balls[None, :, :3], axis=2)
    return (d + balls[None, :, 3]).max(axis=1)


def quick_ball(balls: np.ndarray) -> np.ndarray:
    """A ball holding every ball of a non-empty list, about the centre of their box: cheap
    and not the smallest (enclose is the careful one)."""
    if not np.all(np.isfinite(balls)):
        return UNBOUNDED[0].copy()
    lo = (balls[:, :3] - balls[:, 3:]).min(axis=0)
    hi = (balls[:, :3] + balls[:, 3:]).max(axis=0)
    centre = (lo + hi) / 2
    return np.append(centre, reach(balls, centre[None])[0])


def enclose(balls: np.ndarray, near: np.ndarray | None = None) -> np.ndarray | None:
    """One ball (4,) that holds every ball of the list: the centre near the smallest such
    ball's (from `near`, a ball close to it, if given), the radius then exact for that
    centre, so the ball holds them whatever the search found. None for no balls; radius
    inf if unbounded."""
    if len(balls) == 0:
        return None
    if not np.all(np.isfinite(balls)):
        return UNBOUNDED[0].copy()
    if len(balls) == 1:
        return balls[0].copy()
    lo = (balls[:, :3] - balls[:, 3:]).min(axis=0)
    hi = (balls[:, :3] + balls[:, 3:]).max(axis=0)
    size = (hi - lo).max()
    if not size > 1e-150 * (1.0 + np.abs(lo).max() + np.abs(hi).max()):
        return quick_ball(balls)        # (nearly) one point: the sharpness would overflow
    centre = (lo + hi) / 2 if near is None else near[:3].copy()
    # the radius function max_j |x - c_j| + r_j is convex but has kinks; its smooth
    # stand-in, a log-sum-exp at sharpness t, is minimised by Newton's method as t grows
    # (each minimum starts the next); at the last t it is within log(k) / t of the max
    from ..trace.enclose import centre_search
    t = 4.0 if near is None else WARM            # in units of 1 / size
    centre = centre_search(np.ascontiguousarray(balls, dtype=np.float64),
                           np.ascontiguousarray(centre, dtype=np.float64), t, SHARPEST,
                           float(size))
    return np.append(centre, reach(balls, centre[None])[0])


SHARPEST = 1e10         # the last sharpness, in units of 1 / size: radius within 1e-9
WARM = 1e3              # the first sharpness from a nearby centre (the last round's)


@functools.cache
def geodesic():
    """The 42 vertices of an icosahedron with each face cut in four, on the unit sphere,
    and the radius of the largest ball about the centre inside their hull: its faces'
    smallest distance from the centre."""
    p = (1 + math.sqrt(5)) / 2
    v = np.array([c for a in (-1, 1) for b in (-p, p)
                  for c in ((0, a, b), (a, b, 0), (b, 0, a))], dtype=float)
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    edge = min(np.linalg.norm(v[0] - v[j]) for j in range(1, 12))
    near = lambda i, j: abs(np.linalg.norm(v[i] - v[j]) - edge) < 1e-9
    faces = [(i, j, k) for i in range(12) for j in range(i + 1, 12) for k in range(j + 1, 12)
             if near(i, j) and near(j, k) and near(i, k)]
    points, fine = list(v), []
    for i, j, k in faces:
        a, b, c = v[i], v[j], v[k]
        ab, bc, ca = ((x + y) / np.linalg.norm(x + y) for x, y in ((a, b), (b, c), (c, a)))
        points += [ab, bc, ca]
        fine += [(a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca)]
    inner = min(abs(np.dot(np.cross(b - a, c - a), a)) / np.linalg.norm(np.cross(b - a, c - a))
                for a, b, c in fine)
    points = np.unique(np.round(points, 12), axis=0)
    points.flags.writeable = False          # one array for every call
    return points, inner * (1 - 1e-12)


def ball_points(ball: np.ndarray) -> np.ndarray:
    """42 points whose hull holds the ball: how a sphere enters the box walk, so that
    the boxes above a graftal bounded by a sphere hold that sphere (7 % over its radius
    at most, where a box about it would give up to 73 %)."""
    # made on first use, not at import: with the numpy module np.unique imports, 12 ms of
    # every start, and few files bound by spheres
    points, inradius = geodesic()
    return ball[:3] + points * (ball[3] / inradius)


class _BallWalker(_Walker):
    """The box walk's traversal with balls (see the module docstring)."""

    nothing = NO_BALLS

    def __init__(self, graph: Graph, any_rule: bool = False):
        super().__init__(graph, any_rule)
        self.seed = NO_BALLS

    @staticmethod
    def leaf(name: str, args) -> np.ndarray:
        if name == "sphere":
            return np.array([[0.0, 0.0, 0.0, 1.0]])
        box = object_box(name, args)
        if name in FRACTAL_PRIMITIVES:      # its box is that of its bounding ball
            return np.array([[0.0, 0.0, 0.0, box[3]]])
        return as_balls(box)

    @staticmethod
    def transform(m: np.ndarray, b: np.ndarray) -> np.ndarray:
        if not np.all(np.isfinite(m)):
            return NO_BALLS
        lin = m[:3, :3]
        # the largest singular value, a hair over so that its rounding cannot shrink a ball
        s = np.linalg.norm(lin, 2) * (1 + 1e-12)
        out = np.empty_like(b)
        out[:, :3] = b[:, :3] @ lin.T + m[:3, 3]
        out[:, 3] = np.where(np.isfinite(b[:, 3]), b[:, 3] * s, np.inf)
        return out

    @staticmethod
    def unite(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        out = np.concatenate([a, b])
        return out if len(out) <= MAX_BALLS else quick_ball(out)[None]

    @staticmethod
    def intersect(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        if len(a) == 0 or len(b) == 0:
            return NO_BALLS
        return a if quick_ball(a)[3] <= quick_ball(b)[3] else b   # either holds it

    def record(self, i: int, b: np.ndarray) -> None:
        pass            # spheres are gathered per S-node from the memo at the end

    def round(self, balls: dict) -> dict | None:
        """One walk with each re-entered state bounded by its ball: the states' new ball
        lists, or None if it re-entered a state that has no ball (nothing is known)."""
        self.estimate = {k: b[None] for k, b in balls.items()}
        self.reset()
        state, h = self.d.initial()
        self.box(self.g.root, state, h, 0)
        if not self.reentered <= balls.keys():
            return None
        return {k: self.memo[k] for k in self.reentered}


def state_balls(w: _BallWalker, hulls: dict):
    """Re-entered state key -> a ball (4,) that holds its attractor, and whether one round
    maps the balls into themselves (the spheres nest); None if a state has no finite
    ball. `hulls` are the box walk's final bounds of the states (bounds._memoised)."""
    if len(hulls) > MAX_STATES:
        return None
    balls = {k: enclose(as_balls(v)) for k, v in hulls.items()}
    if any(b is None or not np.isfinite(b[3]) for b in balls.values()):
        return None
    best = dict(balls)
    idle = 0
    for _ in range(min(ROUNDS, STATE_ROUNDS // max(1, len(balls)))):
        out = w.round(balls)
        if out is None or out.keys() != balls.keys():
            break
        new = {k: enclose(v, balls[k]) for k, v in out.items()}
        if any(b is None or not np.isfinite(b[3]) for b in new.values()):
            break
        smaller = [k for k, b in new.items() if b[3] < best[k][3]]
        for k in smaller:
            best[k] = new[k]
        still = all(np.abs(new[k] - balls[k]).max() <= STILL * new[k][3] for k in new)
        balls = new
        idle = 0 if smaller else idle + 1
        if still or idle >= IDLE_ROUNDS:
            break
    return _nested(w, best)


def _nested(w: _BallWalker, balls: dict):
    """The balls grown by rounding's worth (NEST_SLACK at most) until one round maps
    them into themselves, with True; else as they were, with False."""
    trial = {k: b.copy() for k, b in balls.items()}
    for _ in range(20):
        out = w.round(trial)
        if out is None or out.keys() != trial.keys():
            break
        excess = {k: (reach(v, trial[k][None, :3])[0] if len(v) else -np.inf) - trial[k][3]
                  for k, v in out.items()}
        if all(e <= 0 for e in excess.values()):
            return trial, True
        for k, e in excess.items():
            trial[k][3] += max(e, 0.0) * 2
        if any(trial[k][3] > balls[k][3] * (1 + NEST_SLACK) for k in trial):
            break
    return balls, False


def node_spheres(graph: Graph, hulls: dict, any_rule: bool = False):
    """(n, 4) spheres per node, each holding every instance of its S-node (radius -1 for
    other nodes and for S-nodes with no finite ball), and whether they nest (see
    state_balls); None when the states have no finite balls. any_rule: walked as the
    hulls were (bounds.ANY_RULE)."""
    w = _BallWalker(graph, any_rule)
    found = state_balls(w, hulls)
    if found is None:
        return None
    balls, nested = found
    if w.round(balls) is None:
        return None
    if sum(graph.nodes[key[0]].kind == SELECT for key in w.memo) > MAX_INSTANCES:
        return None
    per_node = defaultdict(list)
    for key, b in w.memo.items():
        if graph.nodes[key[0]].kind == SELECT:
            ball = balls[key] if key in balls else enclose(b)
            if ball is not None:
                per_node[key[0]].append(ball)
    out = np.tile([0.0, 0.0, 0.0, -1.0], (len(graph.nodes), 1))
    for i, found_balls in per_node.items():
        ball = enclose(np.array(found_balls))
        if np.isfinite(ball[3]):
            out[i] = ball
    return out, nested
