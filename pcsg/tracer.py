"""`pcsg.load(path, **overrides).trace(origins, directions)`: the graph tracer
for Python users, and what the renderer builds on."""
from __future__ import annotations

import math
import os
import re
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from .collector import collector_paused
from .compiler import compile_file, compile_text
from .graph.flat import NORMAL_DECAY, flatten_graph
from .graph.regroup import regroup
from .graph.solidglass import glass_unions_as_solids
from .graph.states import StateTable
from .graph.volumes import bounding_volumes
from .graph.model import DIFFERENCE, INTERSECTION, KIND_NAMES, SELECT, UNION, Graph
from .trace.jit import threads
from .trace.kernel import CHUNK, trace_rays
from .trace.instance_table import tracer_rows
from .trace.pad import pad_boxes
from .trace.nodes import (EV_DEPTH, EV_INTERVALS, EV_LOD, EV_NONFINITE, EV_SELECTION,
                          EV_SINGULAR, EV_STACK, EV_VISITS, N_EVENTS, add_events,
                          no_events)
from .limits import (BOUNDS_BUDGET, INTERVAL_ROWS, MAX_INSTANCES, MAX_STACK_DEPTH,
                     api_argument, real_number, walk_limits_problem)
from .trace.walk import R_HIT, R_MAT, R_N, R_PAINT, R_T, R_WIDTH

BATCH = 1 << 16             # rays per kernel call: bounds the per-chunk event arrays


@dataclass(eq=False)      # of arrays: == was "the truth value of an array is ambiguous"
class Hits:
    """What `Traced.trace` found for each ray (views of one array)."""
    t: np.ndarray               # (N,) the hit at origin + t * direction (a distance where the
                                #   direction is a unit vector); inf where missed
    normal: np.ndarray          # (N, 3) unit world normal (zeros where missed)
    paint: np.ndarray           # (N, 3) the colour in force at the hit: the innermost
                                #   paint(r,g,b) or material with a color=; nan if none
    material: np.ndarray        # (N,) index into Traced.material_names, -1 if none
    hit: np.ndarray             # (N,) bool
    events: np.ndarray = field(repr=False, default=None)   # trace.nodes.no_events layout
    # (N,) what was hit (trace.walk.HIT_SOLID, HIT_SHEET, HIT_SHELL; 0 missed), or None:
    # solids throughout
    what: np.ndarray | None = field(repr=False, default=None)


def _rays(values, what: str) -> np.ndarray:
    """(N, 3) float64, C-contiguous: a (3, 2) array was read as two rays of garbage."""
    if np.ma.is_masked(values):
        # np.asarray drops the mask: the masked rays were traced from their hidden values
        raise ValueError(f"{what} has masked entries: fill them or leave those rays out")
    try:
        a = np.asarray(values)
    except ValueError:
        # rows of different lengths: numpy's "inhomogeneous shape" named no argument
        raise ValueError(f"{what} must be real numbers of shape (N, 3), or (3,) for one "
                         f"ray; got rows of different lengths") from None
    # no rays: [] or (0, 3), not (0, 5) nor (5, 0), which were taken as none
    if a.shape in ((0,), (0, 3)) and a.dtype.kind in "iuf":
        return np.empty((0, 3))
    if a.dtype.kind not in "iuf" or not (a.shape == (3,) or (a.ndim == 2 and a.shape[1] == 3)):
        raise ValueError(f"{what} must be real numbers of shape (N, 3), or (3,) for one ray; "
                         f"got {a.dtype} {a.shape}")
    return np.ascontiguousarray(a.reshape(-1, 3), dtype=np.float64)


def _finite_rays(o: np.ndarray, d: np.ndarray) -> None:
    """A ray with a non-finite coordinate or no direction was traced as a miss."""
    bad = ~np.isfinite(o).all(axis=1)
    if bad.any():
        k = int(np.argmax(bad))
        raise ValueError(f"origins: ray {k} starts at {tuple(o[k].tolist())}: give finite "
                         f"coordinates")
    bad = ~np.isfinite(d).all(axis=1) | ~(d != 0).any(axis=1)
    if bad.any():
        k = int(np.argmax(bad))
        raise ValueError(f"directions: ray {k} has direction {tuple(d[k].tolist())}: give a "
                         f"finite one of non-zero length")


def _pad(boxes: np.ndarray) -> np.ndarray:
    """A copy of the boxes made conservative (trace/pad.py); the instance table's entries
    are padded as they are laid out (instance_table.tracer_rows)."""
    out = boxes.copy()
    pad_boxes(out)
    return out


def _pad_spheres(spheres: np.ndarray) -> np.ndarray:
    """The same hair for spheres (rows with radius -1 have none)."""
    out = spheres.copy()
    has = out[:, 3] >= 0
    out[has, 3] += 1e-9 * (out[has, 3] + np.abs(out[has, :3]).max(axis=1)) + 1e-12
    return out


def operator_nesting(flat) -> int:
    """The most ∪, ∩ and \\ nodes nested in one another between S-nodes (their rules
    start a nest again): the graph's cycles pass through S-nodes, so below one the
    operators form no cycle."""
    kind = flat.kind.tolist()
    start, count, children = flat.child_start.tolist(), flat.child_count.tolist(), \
        flat.children.tolist()
    operators = (UNION, INTERSECTION, DIFFERENCE)
    deepest = [-1] * len(kind)          # -1 not yet, -2 on the way down
    for root in range(len(kind)):
        stack = [root]                  # a loop: a nest may be 100,000 brackets deep
        while stack:
            node = stack[-1]
            below = [] if kind[node] == SELECT else children[start[node]:start[node] + count[node]]
            if deepest[node] == -1:
                deepest[node] = -2
                stack += [c for c in below if deepest[c] == -1]
                continue
            stack.pop()
            if deepest[node] == -2:     # (a cycle without an S-node would count once)
                deepest[node] = (kind[node] in operators) + max(
                    (deepest[c] for c in below if deepest[c] >= 0), default=0)
    return max(deepest, default=0)


class Traced:
    """A compiled, bounded, flattened PCSG object, ready to trace."""

    def __init__(self, graph: Graph, max_depth: int | None = None, stack_depth: int | None = None,
                 interval_rows: int = INTERVAL_ROWS, max_instances: int = MAX_INSTANCES,
                 bounds_budget: int = BOUNDS_BUDGET, average_normals: bool = True,
                 regrouped: bool = True, bounds_poll=None):
        # the command line's checks (render/job.py), as a ValueError: max_instances=-1 made
        # every ray a silent miss
        if problem := walk_limits_problem(max_depth, stack_depth, interval_rows, max_instances,
                                          bounds_budget, api_argument):
            raise ValueError(problem)
        # the collector paused as for the compile (collector.py): regroup's copies of an
        # expanded Sierpinski at 7's 98,000 nodes took 2.1 s with it, 0.5 s without
        with collector_paused():
            self._prepare(graph, max_depth, stack_depth, interval_rows, max_instances,
                          bounds_budget, average_normals, regrouped, bounds_poll)

    def _prepare(self, graph, max_depth, stack_depth, interval_rows, max_instances,
                 bounds_budget, average_normals, regrouped, bounds_poll):
        # the same object with fewer frames per ray (graph/regroup.py), and where it is
        # bounded instance by instance its runs of maps written out as one (graph/fuse.py);
        # False traces the graph as written, for comparisons
        graph = regroup(graph) if regrouped else graph
        # glass of overlapping parts as one solid for the rays inside it (graph/solidglass.py)
        graph = glass_unions_as_solids(graph)
        # bounds_poll(visits, expected): progress and a way to stop a long bounding walk;
        # max_depth None: as deep as the derivation goes where it ends (memoised, within
        # DEEPEST_DEFAULT levels), else MAX_DEPTH (graph/bounds.py, _memoised)
        volumes = bounding_volumes(graph, None if max_depth is None else int(max_depth),
                                   int(bounds_budget), bounds_poll, fuse=regrouped)
        self.graph = graph = volumes.graph
        # less than asked where the instances are too many to bound deeper
        self.max_depth = volumes.depth
        self.bounds_method = volumes.method
        self.asked_depth = volumes.asked
        self.warnings = list(graph.warnings) + volumes.problems
        self.boxes = boxes = volumes.boxes
        # graftal nodes bounded by a sphere rather than a box (graph/volumes.py)
        self.spheres = volumes.spheres
        self.volume_choices = volumes.choices
        table, states = volumes.table, None
        if isinstance(table, StateTable):       # a memoised system's boxes by state
            table, states = (table.keys, table.used, table.boxes), table.slots
        padded = _pad(boxes)
        # padded, cut to the padded node boxes and laid out in place: nothing else keeps it
        rows = None if table is None else tracer_rows(*table, padded)
        spheres = None if self.spheres is None else _pad_spheres(self.spheres)
        # a graftal hit's normal: averaged over the boxes that led to it, else its box's
        self.flat = flatten_graph(graph, padded, rows,
                                  NORMAL_DECAY if average_normals else 0.0, spheres, states,
                                  native_args=self.bounds_method == "every instance")
        self.events = no_events(len(graph.nodes))      # of all traces so far
        kids = int(self.flat.max_children)
        # frames: a union's operands wait on the stack, and so does each operator of a nest
        # (`(a ∩ (b ∩ (c ∩ ...)))`: 300 of them filled the stack, and drew nothing)
        frames = max(min(kids, 16), 2 * operator_nesting(self.flat))
        self.stack_depth = int(stack_depth or min(kids + (self.max_depth + 2) * frames + 32,
                                                  MAX_STACK_DEPTH))
        self.interval_rows = int(interval_rows)
        self.max_instances = int(max_instances)
        # what the kernels get (limits.LIM_*)
        self.limits = np.array([self.stack_depth, self.interval_rows, self.max_instances],
                               dtype=np.int64)

    @property
    def material_names(self) -> list[str]:
        """The file's materials by the number `Hits.material` gives (-1: none)."""
        return self.graph.material_names

    @property
    def bounds(self) -> np.ndarray:
        """The root's hyper-bounding box (xmin, ymin, zmin, xmax, ymax, zmax): a copy, so
        that an edit of it does not move the box the renderer frames."""
        return self.boxes[self.graph.root].copy()

    def trace(self, origins, directions, tmin: float = 1e-9, tmax: float = np.inf,
              any_hit: bool = False, lod: float = 0.0, packets: bool = True,
              cone=0.0) -> Hits:
        """Trace rays o + t d: origins and directions (N, 3), or (3,) for one ray, any
        real dtype. The nearest hit with tmin < t < tmax (t in units of each direction's
        length); a ray that starts inside a solid of an ∩ or \\ reports where it leaves
        it (under a union, the nearest surface of any operand). `lod` is the pixel
        footprint in radians (0: no level of detail); `cone`, a number or one per ray, the
        width a ray starts with (a secondary ray's: the pixel's footprint at the surface it
        leaves; 0 for a camera ray), to which a fractal's surface is marched with lod's
        spread; `any_hit` stops at the first hit found (shadow rays). With `packets`,
        neighbouring rays walk the graph together (trace/packet.py): the same hits, but on
        a surface that two primitives share exactly, either may show. Misses have t = inf
        and hit False."""
        for name, value in (("tmin", tmin), ("tmax", tmax), ("lod", lod)):
            # nan made every ray miss, a negative lod was 0
            number = real_number(value)
            if number is None or number != number or (name == "lod" and not 0 <= number < np.inf):
                raise ValueError(f"{name}={value!r}: give a number" +
                                 (" from 0 (no level of detail)" if name == "lod" else ""))
        for name, value in (("any_hit", any_hit), ("packets", packets)):
            # any_hit="False" was true: a shadow ray's walk, without a word
            if not (isinstance(value, (bool, np.bool_)) or
                    (isinstance(value, (int, np.integer)) and value in (0, 1))):
                raise ValueError(f"{name}={value!r}: give True or False")
        if not float(tmin) < float(tmax):
            # tmax=-1 or tmin=5, tmax=1: an empty span, every ray a miss without a word
            raise ValueError(f"tmin={tmin!r}, tmax={tmax!r}: the hits are sought for tmin < "
                             f"t < tmax, so tmax must be greater than tmin")
        o, d = _rays(origins, "origins"), _rays(directions, "directions")
        if o.shape != d.shape:
            # the shapes given: "origins (1, 3)" was said of a (3,) one
            raise ValueError(f"origins {np.shape(origins)} and directions "
                             f"{np.shape(directions)} differ: give one origin per direction "
                             f"(np.broadcast_to(origin, directions.shape) shares one)")
        _finite_rays(o, d)
        n = len(o)
        try:
            # as the other numbers, not a string nor a bool ('1' and True were taken)
            given = np.asarray(cone)
            cones = np.ascontiguousarray(np.broadcast_to(given.astype(np.float64), (n,))) \
                if given.dtype.kind in "iuf" else None
        except (TypeError, ValueError):
            cones = None
        if cones is None or not (np.all(np.isfinite(cones)) and np.all(cones >= 0)):
            raise ValueError(f"cone={cone!r}: give finite widths from 0, a number or one "
                             f"per ray")
        out = np.empty((n, R_WIDTH))      # the kernel writes every row in full
        events = no_events(len(self.graph.nodes))
        for s in range(0, n, BATCH):
            e = min(n, s + BATCH)
            ev = no_events(len(self.graph.nodes), (e - s + CHUNK - 1) // CHUNK)
            trace_rays(self.flat, o[s:e], d[s:e], cones[s:e], float(tmin), float(tmax),
                       bool(any_hit), float(lod), int(self.max_depth), self.limits, threads(),
                       self._packets(packets), out[s:e], ev)
            add_events(events, ev)
        add_events(self.events, events)
        return Hits(t=out[:, R_T], normal=out[:, R_N:R_N + 3], paint=out[:, R_PAINT:R_PAINT + 3],
                    material=out[:, R_MAT].astype(np.int64), hit=out[:, R_HIT] > 0,
                    events=events, what=out[:, R_HIT].astype(np.int64))

    def _packets(self, wanted: bool) -> bool:
        # graftal normals average the boxes along each ray's own path: no packets there
        return bool(wanted) and self.flat.normal_decay == 0.0

    def describe_events(self, events: np.ndarray, kinds=None, option=api_argument
                        ) -> list[str]:
        """One line per kind of thing that happened, naming where; `kinds`, event numbers
        (trace.nodes.EV_*), limits them. The limits to raise are named as `option` names
        them: `max_depth=` (the command line passes its `--max-depth `)."""
        g = self.graph
        shape = (2 * N_EVENTS, len(g.nodes))
        if not isinstance(events, np.ndarray) or events.shape != shape:
            # np.zeros(3) was "Calling nonzero on 0d arrays", None "not subscriptable"
            got = events.shape if isinstance(events, np.ndarray) else type(events).__name__
            raise ValueError(f"events: give an array a trace counted (Hits.events, or "
                             f"Traced.events), of shape {shape}; got {got}")
        if kinds is not None and not (isinstance(kinds, (list, tuple, set, frozenset)) and
                                      all(k in range(N_EVENTS) for k in kinds)):
            # kinds="depth" was "'in <string>' requires string as left operand"
            raise ValueError(f"kinds={kinds!r}: give event numbers from 0 to {N_EVENTS - 1} "
                             f"(pcsg.trace.nodes.EV_*) in a list, or None for all")
        at = {name: option(name) for name in ("max_depth", "stack_depth", "interval_rows",
                                              "max_instances")}
        bare = {name: said.rstrip(" =") for name, said in at.items()}

        def where(kind):
            nodes = np.nonzero(events[kind])[0]
            names = []
            for i in nodes[np.argsort(-events[kind][nodes])][:3]:
                n = g.nodes[i]
                label = f"'{n.name}'" if n.kind == SELECT else KIND_NAMES[n.kind]
                if n.span is not None:
                    label += f" at {g.source.locate(n.span[0])}"
                # at the depth limit that is the limit's own next level, which read as
                # past it ("--max-depth 1 ... depth up to 2")
                names.append(label if kind == EV_DEPTH else
                             f"{label}, depth up to {events[N_EVENTS + kind, i]}")
            return ", ".join(names), int(events[kind].sum())

        lines = []
        # without a level of detail (the API's lod=0) a graftal at the depth limit is a
        # dust of boxes that rays miss, and a deeper limit is a finer dust
        depth_nodes = np.nonzero(events[EV_DEPTH])[0]
        dust = option is api_argument and bool((self.flat.term_rule[depth_nodes] < 0).any())
        refine = f"; raise {bare['max_depth']} to refine further"
        if dust:
            refine = ("; where no rule ends (a graftal), a trace with lod=0 meets a dust of "
                      "boxes, the finer the deeper: give lod=, a pixel's angle in radians, "
                      "to finish them at pixel size" + refine.replace(";", "; else", 1))
        # a graftal's node has no rule that ends: its instances are their bounding volume
        ends = ("with their terminating rule, or as their bounding volume where none ends"
                if (self.flat.term_rule[self.flat.kind == SELECT] < 0).any() else
                "with their terminating rule")
        # the counts are of rays' visits: one instance met by 400 rays counts 400 (they
        # read as instances: "410 instances were empty" of a file of one)
        texts = {
            EV_LOD: "level of detail: instances smaller than a pixel were finished " + ends
                    + " ({w}; {n:,} ray visits)",
            EV_DEPTH: (f"depth limit: instances at {at['max_depth']}{{d}} were finished "
                       + ends + " ({w}; {n:,} ray visits)" + refine
                       if self.max_depth == self.asked_depth else
                       "depth limit: instances at depth {d}, where the bounds stop, were "
                       "finished " + ends + " ({w}; {n:,} ray visits)"),
            EV_SELECTION: "instances were empty because a selection was not a valid rule "
                          "number ({w}; {n:,} ray visits)",
            EV_SINGULAR: "instances were empty because of a singular transformation ({w}; "
                         "{n:,} ray visits)",
            EV_NONFINITE: "instances were empty because of a non-finite argument ({w}; {n:,} "
                          "ray visits)",
            EV_STACK: "walk stack full {n:,} times ({w}); the rays lost what lay beyond; "
                      f"raise {bare['stack_depth']} (now {{s}})",
            EV_INTERVALS: "interval lists full {n:,} times ({w}): an ∩ or \\ subtree has "
                          f"too many pieces along one ray; raise {bare['interval_rows']} (now "
                          "{r})",
            EV_VISITS: f"{{n:,}} rays stopped after entering {at['max_instances']}{{v:,}} "
                       "instances "
                       "({w}), the rest of their walk taken as empty: a cycle that neither "
                       "ends nor contracts, or instances that overlap deeply (parts that keep "
                       "one size at every level, or sizes carried in parameters: `scale(len, "
                       "len, len)` with `{{len = len * 0.7}}`)? a uscale(0.7) on the "
                       "recursion shrinks an instance's parts and boxes with it; raise "
                       f"{bare['max_instances']} to go on",
        }
        for kind, text in texts.items():
            if kinds is not None and kind not in kinds:
                continue
            w, n = where(kind)
            if n:
                lines.append(text.format(n=n, w=w, d=self.max_depth, s=self.stack_depth,
                                         r=self.interval_rows, v=self.max_instances))
        return lines


def load(path: str | Path, max_depth: int | None = None, stack_depth: int | None = None,
         interval_rows: int = INTERVAL_ROWS, max_instances: int = MAX_INSTANCES,
         bounds_budget: int = BOUNDS_BUDGET, params: dict | None = None,
         **overrides: float) -> Traced:
    """Compile a .pcsg file (raising PcsgError on errors) and prepare it for tracing.
    Keyword arguments override initial parameters, like --set (`params`, a dict, too: for
    parameters named like an argument here, `file` or `max_depth`; a name given both ways
    is refused, as --set given twice); the others are the
    render options of the same names (max_depth None: as --max-depth's default)."""
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"load takes a .pcsg file's path, got {type(path).__name__}")
    path = os.fspath(path)
    if not isinstance(path, str):
        raise TypeError(f"load takes a .pcsg file's path as str, got {type(path).__name__}")
    return _in_api_words(Traced(compile_file(path, _parameters(params, overrides)), max_depth,
                                stack_depth, interval_rows, max_instances, bounds_budget))


def loads(text: str, file: str = "<string>", max_depth: int | None = None,
          stack_depth: int | None = None, interval_rows: int = INTERVAL_ROWS,
          max_instances: int = MAX_INSTANCES, bounds_budget: int = BOUNDS_BUDGET,
          params: dict | None = None, **overrides: float) -> Traced:
    """`load` for PCSG text; `file` names it in error messages."""
    if not isinstance(text, str):
        raise TypeError(f"loads takes a grammar's text as str, got {type(text).__name__}"
                        + (" (decode it first)" if isinstance(text, bytes) else ""))
    if not isinstance(file, (str, os.PathLike)):
        # `loads(text, file=3)` meant a parameter named file: it became the name in errors
        raise TypeError(f"file={file!r}: loads takes the name its errors give the text, as "
                        f"str; a parameter named file goes in params={{'file': ...}}")
    return _in_api_words(Traced(compile_text(text, str(file), _parameters(params, overrides)),
                                max_depth, stack_depth, interval_rows, max_instances,
                                bounds_budget))


# a limit as the command line names it in a warning, with its value or without
_LIMIT_OPTION = re.compile(r"--(max-depth|stack-depth|interval-rows|max-instances|bounds-budget)"
                           r"( (?=[0-9]))?")


def _in_api_words(traced: Traced) -> Traced:
    """Its warnings name the limits as load and loads take them (`max_depth=64`), where
    they said "a smaller --max-depth (16, say)" to a Python caller (QA)."""
    def api(m):
        name = m.group(1).replace("-", "_")
        return api_argument(name) if m.group(2) else name
    traced.warnings = [replace(w, message=_LIMIT_OPTION.sub(api, w.message))
                       for w in traced.warnings]
    return traced


def _parameters(params: dict | None, overrides: dict) -> dict[str, float]:
    """The initial parameters given, as numbers: `c="abc"` failed inside with "could not
    convert string to float", and `c="3"` was taken."""
    if params is not None and not isinstance(params, Mapping):
        raise TypeError(f"params={params!r}: give a dict of parameter names and numbers, such "
                        f"as {{'c': 2}}")
    twice = sorted(set(params or {}) & set(overrides))
    if twice:
        # as `--set c=1 --set c=2` is refused: one of the two values was dropped unsaid
        raise ValueError(f"parameter {twice[0]} is given twice, in params and as a keyword "
                         f"argument: give it once")
    given = {**(params or {}), **overrides}
    out = {}
    for name, value in given.items():
        number = real_number(value)
        if number is None:
            raise TypeError(f"parameter {name}={value!r}: give a number")
        if number != number and value == value:
            raise ValueError(f"parameter {name}={value!r}: too large for a float")
        if not math.isfinite(number):
            # as --set refuses them: no file can write a nan or an inf either
            raise ValueError(f"parameter {name}={value!r}: give a finite number")
        out[name] = number
    return out
