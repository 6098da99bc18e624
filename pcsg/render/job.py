"""`pcsg render`: one .pcsg file to one PNG, with the options of the command line."""
from __future__ import annotations

import copy
import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..compiler import compile_file, compile_text
from ..graph.model import Graph
from ..graph import boxcache
from ..trace.nodes import (EV_INTERVALS, EV_NONFINITE, EV_SELECTION, EV_SINGULAR, EV_STACK,
                           EV_VISITS, no_events)
from ..scene import FARTHEST, MAX_AO_SAMPLES, MIN_FOV, camera_degenerate
from ..limits import (BOUNDS_BUDGET, INTERVAL_ROWS, MAX_DEPTH, MAX_INSTANCES, MAX_SAMPLES,
                      bounces_problem, cli_option, shadow_samples_problem, size_problem,
                      walk_limits_problem)
from ..memory import freeing_blocks
from ..timings import Timings
from ..tracer import Hits, Traced
from . import kernelcache
from .camera import CameraError, make_camera
from .image import Frame, Progress, render_frame, write_depth, write_png
from .shade import make_lighting

RUNTIME_ERRORS = (EV_SELECTION, EV_NONFINITE, EV_SINGULAR, EV_STACK, EV_INTERVALS, EV_VISITS)

MAX_PIXELS = 64_000_000
BYTES_PER_PIXEL = 120        # frame buffers and per-batch ray arrays, measured roughly


@dataclass
class Options:
    size: tuple[int, int] = (640, 480)
    samples: int = 1
    adaptive: bool = True
    overrides: dict = field(default_factory=dict)
    eye: tuple | None = None
    at: tuple | None = None
    up: tuple | None = None
    fov: float | None = None
    light: tuple | None = None      # one point light here instead of the file's or the default
    alpha: bool = False
    depth: Path | None = None
    max_depth: int | None = None     # None: Traced's default (as deep as a derivation that ends)
    shadows: bool = True
    shadow_samples: int = 8
    bounces: int = 3
    ao: int | None = None           # ambient occlusion rays; None: the file's #occlusion
    ao_distance: float | None = None
    quiet: bool = False
    reference: bool = False
    strict: bool = False            # runtime errors in the grammar fail the render
    timeout: float | None = None    # seconds per file; past it nothing is written
    stack_depth: int | None = None  # None: Traced's default
    interval_rows: int = INTERVAL_ROWS
    max_instances: int = MAX_INSTANCES
    bounds_budget: int = BOUNDS_BUDGET   # node visits of the bounding walk


class RenderFailed(Exception):
    """A render that stopped without writing anything: --timeout, --strict with
    runtime errors in the grammar, or a camera that cannot be placed."""


def check_options(o: Options) -> str | None:
    """A clear message for options that cannot work, before anything is compiled."""
    if problem := size_problem(o.size):
        return problem
    w, h = o.size
    if w * h > MAX_PIXELS:
        need = w * h * BYTES_PER_PIXEL / 2 ** 30
        return (f"--size {w}x{h} is {w * h:,} pixels (about {need:.0f} GiB of memory); "
                f"pcsg renders up to {MAX_PIXELS:,}")
    if not 1 <= o.samples <= MAX_SAMPLES:
        return f"--samples {o.samples}: use 1 to {MAX_SAMPLES}"
    if o.timeout is not None and not o.timeout > 0:
        return f"--timeout {o.timeout}: give a positive number of seconds"
    if problem := shadow_samples_problem(o.shadow_samples):
        return problem
    if problem := bounces_problem(o.bounces):
        return problem
    if o.ao is not None and not 0 <= o.ao <= MAX_AO_SAMPLES:
        return f"--ao {o.ao}: use 0 (off) to {MAX_AO_SAMPLES} rays"
    if o.ao_distance is not None and not 0 < o.ao_distance < math.inf:
        return f"--ao-distance {o.ao_distance}: give a positive finite distance"
    if problem := walk_limits_problem(o.max_depth, o.stack_depth, o.interval_rows,
                                      o.max_instances, o.bounds_budget):
        return problem
    return view_problem(o.eye, o.at, o.up, o.fov, o.light)


def view_problem(eye, at, up, fov, light) -> str | None:
    """--eye, --at, --up, --fov and --light that cannot work (render's and export's)."""
    if light is not None and not all(math.isfinite(v) for v in light):
        return f"--light {_given(light)}: give a point with finite coordinates"
    for name, v in (("--eye", eye), ("--at", at), ("--up", up)):
        if v is not None and not all(math.isfinite(x) for x in v):
            # the render failed on it with exit 1, where --eye = --at was a usage error
            return f"{name} {_given(v)}: give finite coordinates"
    if eye is not None and at is not None and tuple(eye) == tuple(at):
        return f"--eye and --at are the same point {_given(eye)}: the camera looks nowhere"
    if up is not None and not any(up):
        return "--up 0,0,0 is no direction: give one such as 0,0,1"
    # without --up the file's #camera may give one: only the distance is the options' alone
    what = camera_degenerate(eye, at, up or (0, 0, 1)) if None not in (eye, at) else None
    what = None if up is None and what == "parallel" else what
    if what == "parallel":
        return f"--up {_given(up)} is parallel to the view from --eye to --at: give another up"
    if what == "far":
        return f"--eye {_given(eye)} is too far from --at {_given(at)} (at most {FARTHEST:g})"
    if fov is not None and not MIN_FOV <= fov < 180:
        return (f"--fov {fov:g}: the vertical field of view is from {MIN_FOV:g} to under 180 "
                f"degrees")
    return None


def _given(v) -> str:
    """A vector as the command line writes it: 1,nan,2."""
    return ",".join(f"{x:g}" for x in v)


def check_deadline(deadline: float | None, timeout: float | None, during: str = ""):
    if deadline is not None and time.perf_counter() > deadline:
        raise RenderFailed(f"stopped by --timeout {timeout:g} s{during}; nothing written")


@dataclass
class Scene:
    """A compiled, bounded file ready to render; a cluster worker keeps it across tasks."""
    graph: Graph
    traced: Traced
    notes: list[str]            # compile and bounds warnings

    def report(self, events, strict: bool) -> tuple[list[str], list[str]]:
        """(notes, errors) after a render with these runtime events (None: not known);
        errors only with --strict: runtime errors in the grammar fail the file."""
        static = [x.format(show_source=False) for x in self.traced.warnings
                  if x not in self.graph.warnings]
        errors = []
        if strict:
            errors = static + ([] if events is None else
                               self.traced.describe_events(events, RUNTIME_ERRORS,
                                                           cli_option))
        notes = [] if events is None else self.traced.describe_events(events,
                                                                      option=cli_option)
        return notes, errors


def traced_for(graph: Graph, opts: Options, poll=None) -> Traced:
    """The graph bounded and flattened with the options' limits (poll: Traced's
    bounds_poll)."""
    return Traced(graph, opts.max_depth, opts.stack_depth, opts.interval_rows,
                  opts.max_instances, opts.bounds_budget, bounds_poll=poll)


def bounds_poll(label: str, opts: Options, deadline: float | None):
    """A bounding walk's poll for render_file: its progress line on a terminal (the
    terrain at 12 walks for 5 s), and --timeout, which may pass during the walk."""
    progress = Progress(f"{label} bounds", 1, not opts.quiet, unit="node visits")

    def poll(visits: int, expected: int | None):
        check_deadline(deadline, opts.timeout, " in the bounding walk")
        if expected:
            progress.total = expected
            progress.update(min(visits, expected - 1), visits)
    return poll, progress


def prepare_scene(graph: Graph, opts: Options, poll=None) -> Scene:
    notes = [w.format(show_source=False) for w in graph.warnings]
    traced = traced_for(graph, opts, poll)
    notes += [w.format(show_source=False) for w in traced.warnings
              if w not in graph.warnings]
    occluded = opts.ao if opts.ao is not None else graph.scene.occlusion.get("samples", 0)
    if opts.ao_distance is not None and not occluded:
        notes.append("warning: --ao-distance does nothing without ambient occlusion "
                     "samples (--ao N, or #occlusion samples=N in the file)")
    return Scene(graph, traced, notes)


def render_scene(scene: Scene, label: str, opts: Options, deadline: float | None = None,
                 rows: tuple[int, int] | None = None) -> tuple[Frame, np.ndarray | None]:
    """The frame (or its rows y0..y1) and the runtime events of this render alone."""
    if not opts.reference:
        kernelcache.load()                  # not on the render's clock (once a process)
    traced = copy.copy(scene.traced)        # its own events, however often the scene is used
    traced.events = no_events(len(traced.graph.nodes))
    target = _ReferenceTarget(traced, lambda: check_deadline(deadline, opts.timeout)) \
        if opts.reference else traced
    w, h = opts.size
    if opts.reference and not opts.quiet and (said := target.slow_notice(label, w, h)):
        print(said, file=sys.stderr, flush=True)
    try:
        camera = make_camera(traced, w / h, opts.eye, opts.at, opts.up, opts.fov)
        camera.basis()
    except CameraError as e:
        raise RenderFailed(str(e)) from None
    light = make_lighting(traced, camera, opts.shadows, opts.shadow_samples, opts.bounces,
                          opts.ao, opts.ao_distance, opts.light)
    y0, y1 = rows or (0, h)
    progress = Progress(label, w * (y1 - y0), not opts.quiet)
    check_deadline(deadline, opts.timeout)
    frame = render_frame(target, camera, light, w, h, opts.samples, opts.adaptive, progress,
                         lambda: check_deadline(deadline, opts.timeout), rows, opts.alpha)
    return frame, getattr(target, "events", None)


def nothing_met(label, met: bool, events=None) -> list[str]:
    """The note for a picture of sky and nothing else, which rendered without a word: a
    system whose every instance is empty, or a camera turned away; or rays stopped by a
    walk limit (`events`: the render's), which the notes above it name (it said "empty
    or out of the camera's view" of an object that was neither)."""
    if met:
        return []
    if events is not None and events[[EV_VISITS, EV_STACK, EV_INTERVALS]].any():
        return [f"{label}: warning: no ray met the object before a walk limit stopped it "
                f"(above): what lies past the limit is not drawn"]
    return [f"{label}: warning: no ray met the object: it is empty or out of the camera's "
            f"view (`pcsg stats` counts its primitives)"]


def strict_failure(errors: list[str]) -> RenderFailed:
    """The runtime faults, which a render warns of, are errors under --strict: said so."""
    said = [e.replace(": warning: ", ": error: ", 1) for e in errors]
    # a ray stopped by --max-instances or a full stack is no error in the grammar
    return RenderFailed("--strict: runtime errors in the grammar or limits of the walk, "
                        "nothing written:\n  "
                        + "\n  ".join(said))


def summary_line(out: Path, opts: Options, seconds: float, rays: int,
                 compiled: bool = False) -> str:
    """compiled: the render compiled the tracing kernels first (a first run: its time and
    rays/s are those of the compile, three minutes, not of the render)."""
    w, h = opts.size
    rate = rays / max(seconds, 1e-9)
    return (f"{out}: {w}x{h}, {seconds:.2f} s, {rate / 1e6:.2f} M rays/s"
            f"{', reference tracer' if opts.reference else ''}"
            f"{', compiling the kernels included' if compiled else ''}")


def render_file(path: Path, out: Path, opts: Options, timings: Timings | None = None,
                text: str | None = None, tell=None) -> tuple[str, list[str]]:
    """Render `path` to `out` (written atomically); returns the summary line and notes,
    and fills `timings` with its phases (--timings). Raises RenderFailed, having written
    nothing, past --timeout or, with --strict, when instances were empty because of
    runtime errors. `text`, where given, is the file's, read before (a pipe's is gone).
    `tell(note)`, where given, takes the compile's and the bounds' notes before the render
    starts, and they are not returned: "nothing is bounded, so every ray walks all the
    instances it meets (slow)" came after minutes of a silent render (QA)."""
    clock = timings or Timings()
    deadline = None if opts.timeout is None else time.perf_counter() + opts.timeout
    compiling = not opts.reference and not kernelcache.cached()
    notice = kernelcache.compile_notice(opts.quiet) if compiling else None
    if notice:
        print(notice, file=sys.stderr, flush=True)
    with clock.phase("compile", "parse, checks"):
        graph = compile_file(path, opts.overrides) if text is None else \
            compile_text(text, str(path), opts.overrides)
    poll, progress = bounds_poll(Path(path).name, opts, deadline)
    kept = boxcache.hits
    with clock.phase("bounds", "hyper-bounding boxes, instance table"), freeing_blocks():
        try:
            scene = prepare_scene(graph, opts, poll)
        finally:
            progress.close()
    static = scene.notes
    if tell is not None:
        for note in static:
            tell(note)
        static = []
    if boxcache.hits > kept:
        clock.annotate("bounds", f"read from {boxcache.folder()}, kept by an earlier "
                                 f"render (PCSG_BOUNDS_CACHE=0: walk again)")
    if not opts.reference:
        with clock.phase("kernels", "the shading kernels' load from numba's cache"):
            kernelcache.load()
    with clock.phase("render"):
        frame, events = render_scene(scene, Path(path).name, opts, deadline)
    clock.annotate("render", f"{frame.rays / 1e6:.2f} M rays, "
                             f"{frame.rays / max(frame.seconds, 1e-9) / 1e6:.2f} M rays/s")
    notes, errors = scene.report(events, opts.strict)
    if errors:
        raise strict_failure(errors)
    notes += nothing_met(path, frame.coverage.any(), events)
    with clock.phase("PNG", "encode, write" + (", depth" if opts.depth is not None else "")):
        write_png(out, frame, opts.alpha)
        if opts.depth is not None:
            write_depth(opts.depth, frame)
    return summary_line(out, opts, frame.seconds, frame.rays, compiling), static + notes


# a pixel's visits of one expanded node, with its shadow rays and oversampling: the
# Sierpinski tetrahedron at 6 (5,461 nodes) took 354 s at 80x60 (QA), 1.35e-5
REFERENCE_PIXEL_SECONDS = 1e-5


class _ReferenceTarget:
    """`--reference`: the same picture from the brute-force expansion (small orders)."""

    rows_per_batch = 1          # render_frame's batches: a progress line for each row
    refine_batch = 64           # and for each 64 pixels oversampled

    def __init__(self, traced: Traced, poll):
        """Cut where the tracer's walk stops (--max-depth), as the tracer is: without the
        cut a graftal's expansion ran to 10 000 levels and failed after seconds."""
        from ..graph.cut import cut_of
        from ..trace.reference import Reference
        cut = cut_of(traced)
        if cut.graftal and traced.asked_depth >= MAX_DEPTH:
            name = traced.graph.nodes[cut.endless_node()].name
            raise RenderFailed(f"--reference: '{name}' has no rule that ends, so "
                               f"its expansion never does: give --max-depth N (a small N) to "
                               f"end it where the tracer does at that depth")
        self.ref = Reference(traced.graph, cut=cut)
        self.poll = poll

    def slow_notice(self, label: str, w: int, h: int) -> str | None:
        """Said before a reference render that takes minutes: its Python walk visits every
        node of the expansion for each ray (REFERENCE_PIXEL_SECONDS a pixel and node; QA:
        the default Sierpinski at 80x60 ran 6 minutes without a word)."""
        minutes = REFERENCE_PIXEL_SECONDS * len(self.ref.nodes) * w * h / 60
        if minutes < 1:
            return None
        return (f"{label}: --reference traces the expansion's {len(self.ref.leaves):,} "
                f"primitives one by one for every ray, in Python: at {w}x{h} about "
                f"{minutes:.0f} minutes (a smaller --size or order is quicker)")

    def trace(self, origins, directions, tmin=1e-9, tmax=math.inf, any_hit=False, lod=0.0,
              cone=0.0):
        r = self.ref.trace(origins, directions, tmin=tmin, tmax=tmax, exits=True,
                           poll=self.poll)
        normal = np.where(r["hit"][:, None], r["normal"], 0.0)
        return Hits(r["t"], normal, r["paint"], r["material"], r["hit"], what=r["what"])

