"""Work units: a whole image or a band of its rows, rendered from the grammar's text.

The text travels with the task, so workers need no shared file system, only the same
pcsg. Each worker process keeps its compiled scenes (and numba its kernels) across
tasks, so a sweep or a tiled poster compiles a scene once per worker, not per task.
"""
from __future__ import annotations

import hashlib
import threading
import time
from collections import OrderedDict
from dataclasses import dataclass, field, replace

import numpy as np

from ..compiler import compile_text
from ..language.errors import PcsgError
from ..render.image import depth_bytes, pixels, png_bytes
from ..render.job import (Options, RenderFailed, Scene, nothing_met, prepare_scene,
                          render_scene, strict_failure)

SCENES_KEPT = 8         # per worker process: enough for a batch's files in turn


@dataclass(frozen=True)
class Unit:
    source: str                         # the grammar's text
    label: str                          # its path as given, for messages
    opts: Options
    rows: tuple[int, int] | None = None     # a tile: rows y0..y1; None: the whole image


@dataclass
class Outcome:
    seconds: float = 0.0
    rays: int = 0
    png: bytes | None = None            # a whole image, encoded
    depth: bytes | None = None          # its .npy, when opts.depth is set
    pixels: np.ndarray | None = None    # a tile: its rows of PNG samples
    events: np.ndarray | None = None    # a tile: runtime events, merged by the client
    met: bool = False                   # a tile: whether a ray of it met the object
    notes: list[str] = field(default_factory=list)
    error: str | None = None            # what to tell the user; nothing was rendered
    said_where: bool = True             # whether error names its file (else the batch does)


_scenes: OrderedDict = OrderedDict()
_lock = threading.Lock()


def _scene(unit: Unit) -> Scene:
    o = unit.opts
    key = (hashlib.sha256(unit.source.encode()).hexdigest(), unit.label,
           tuple(sorted(o.overrides.items())), o.max_depth, o.stack_depth, o.interval_rows,
           o.max_instances, o.bounds_budget)
    with _lock:
        if key in _scenes:
            _scenes.move_to_end(key)
            return _scenes[key]
    scene = prepare_scene(compile_text(unit.source, unit.label, o.overrides), o)
    with _lock:
        _scenes[key] = scene
        while len(_scenes) > SCENES_KEPT:
            _scenes.popitem(last=False)
    return scene


def render_unit(unit: Unit) -> Outcome:
    """Runs on a worker. Errors in the grammar, --strict and --timeout come back as an
    Outcome with `error` (not an exception, which Dask would retry in vain)."""
    opts = replace(unit.opts, quiet=True)   # a worker has no terminal to draw progress on
    deadline = None if opts.timeout is None else time.perf_counter() + opts.timeout
    try:
        scene = _scene(unit)
        frame, events = render_scene(scene, unit.label, opts, deadline, unit.rows)
        if unit.rows is not None:
            return Outcome(frame.seconds, frame.rays, pixels=pixels(frame, opts.alpha),
                           events=events, met=bool(frame.coverage.any()))
        notes, errors = scene.report(events, opts.strict)
        if errors:
            raise strict_failure(errors)
        depth = None if opts.depth is None else depth_bytes(frame)
        return Outcome(frame.seconds, frame.rays, png=png_bytes(frame, opts.alpha),
                       depth=depth, notes=scene.notes + notes
                       + nothing_met(unit.label, frame.coverage.any(), events))
    except PcsgError as e:
        return Outcome(error="\n".join(d.format() for d in e.diagnostics))
    except RenderFailed as e:
        return Outcome(error=str(e), said_where=False)


def report_unit(unit: Unit, events: np.ndarray | None) -> tuple[list[str], list[str]]:
    """After the last tile: the image's notes and --strict errors from all tiles' events."""
    scene = _scene(unit)
    notes, errors = scene.report(events, unit.opts.strict)
    return scene.notes + notes, errors
