"""`pcsg animate`: one grammar to numbered PNG frames and an animated PNG (or GIF).

Frame i of N sets the parameter t = i/(N-1), as --set would, and takes its eye and
look-at point from Bezier control polygons (Hong & Kook's camera paths); the rest of
the camera is where `pcsg render` puts it for the file as written, for every frame, so
that the picture does not reframe itself as the object grows. Frames render in worker
processes; a manifest lets a rerun reuse every frame that is still what it would render.
"""
from __future__ import annotations

import dataclasses
import os
import re
import signal
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..interrupt import (STOPS, TERMINATIONS, Terminated, release_compiler_lock,
                         take_unless_ignored, tell)
from ..language.ast import reads_of
from ..language.errors import PcsgError, labelled
from .job import Options, RenderFailed, render_file, traced_for
from .path import bezier
from ..resume import Manifest, output_key
from ..output import directory_in_the_way, make_directory

TIME = "t"


FRAME_NAME = re.compile(r"frame_[0-9]+\.png")


class BadAnimation(Exception):
    """An animation that cannot be made as asked (a usage error)."""


class CannotFrame(Exception):
    """A camera that cannot look at the file's object (an error in the file's render, as
    render says it: exit 1, not a usage error)."""


@dataclass
class Animation:
    source: Path
    out_dir: Path
    frames: int
    opts: Options                       # what every frame shares
    eye_path: np.ndarray | None = None  # Bezier control points, (k, 3)
    at_path: np.ndarray | None = None
    fps: float = 10.0
    gif: bool = False
    jobs: int | None = None             # None: one per core
    cluster: object = None              # a pcsg.distributed runner: the frames run there
    force: bool = False                 # render every frame, done or not
    threads: int | None = None          # each frame process's; None: the cores shared


@dataclass
class FrameJob:
    index: int
    t: float
    source: Path
    png: Path
    opts: Options
    key: str
    text: str           # the file's, read once: a pipe's second read was empty


def _moves(path) -> bool:
    """Whether a camera path goes anywhere: not None, nor one point however often."""
    return path is not None and any(tuple(p) != tuple(path[0]) for p in path)


def plan(anim: Animation) -> tuple[list[FrameJob], bool]:
    """Every frame's options; and whether the file assigns t (else only the camera moves).
    Raises PcsgError for a file with errors, BadAnimation for a still animation,
    CannotFrame for a camera that cannot look."""
    from ..compiler import compile_file
    from ..language.files import read_source_text
    from .camera import Camera, CameraError, make_camera
    from .shade import default_light
    o = anim.opts
    if TIME in o.overrides:
        raise BadAnimation(f"--set {TIME}: animate sets {TIME} itself, from 0 to 1")
    graph = compile_file(anim.source, o.overrides)
    timed = _assigns_t(anim.source, o.overrides)
    still_camera = not _moves(anim.eye_path) and not _moves(anim.at_path)
    if not timed and still_camera:
        raise BadAnimation(f"{anim.source} assigns no {TIME} in its axiom and no --path or "
                           f"--at-path moves the camera (a path of one point stays there): "
                           f"every frame would be the same")
    if still_camera and not any(reads_of(e, TIME) for e in graph.expr_ast):
        # `{t = 0} sphere` rendered the same frame again and again, without a word
        raise BadAnimation(f"{anim.source} assigns {TIME} in its axiom but reads it nowhere, "
                           f"and no --path or --at-path moves the camera: every frame would "
                           f"be the same")
    traced = traced_for(graph, o)
    w, h = o.size
    try:
        still = make_camera(traced, w / h, o.eye, o.at, o.up, o.fov)
        still.basis()       # default_light asks for it: a CameraError there was internal
    except CameraError as e:
        raise CannotFrame(str(e)) from None
    # the default sun stands where the unmoved camera would put it, in every frame: one
    # that followed the camera path would move the shadows with it
    sun = o.light
    if sun is None and not graph.scene.lights:
        sun = _floats(default_light(still).position)
    text = read_source_text(anim.source)
    digits = max(4, len(str(anim.frames - 1)))
    jobs = []
    for i in range(anim.frames):
        t = i / (anim.frames - 1) if anim.frames > 1 else 0.0
        eye = still.eye if anim.eye_path is None else bezier(anim.eye_path, t)
        at = still.at if anim.at_path is None else bezier(anim.at_path, t)
        try:
            Camera(eye, at, still.up, still.fov).basis()
        except ValueError as e:
            # options alone placed this camera (as render's --eye and --at): a usage error
            given = anim.eye_path is not None and (o.at is not None or anim.at_path is not None)
            raise (BadAnimation if given else CannotFrame)(f"frame {i} (t = {t:g}): {e}") from None
        overrides = {**o.overrides, TIME: t} if timed else o.overrides
        fo = dataclasses.replace(o, overrides=overrides, eye=_floats(eye), at=_floats(at),
                                 up=_floats(still.up), fov=float(still.fov), light=sun,
                                 quiet=True)
        png = anim.out_dir / f"frame_{i:0{digits}d}.png"
        jobs.append(FrameJob(i, t, anim.source, png, fo, output_key(text, fo), text))
    return jobs, timed


def _floats(v) -> tuple[float, float, float]:
    return tuple(float(x) for x in v)


def _assigns_t(source: Path, overrides: dict) -> bool:
    """--set t works only on a t the axiom assigns; compiling with it tells."""
    from ..compiler import compile_file
    try:
        compile_file(source, {**overrides, TIME: 0.0})
    except PcsgError as e:
        if any(d.code == "set" for d in e.diagnostics):
            return False
        raise
    return True


def cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


# ---- one frame, in this process or a worker ----------------------------------------

_busy = False
_interrupted = False


def _init_worker(threads: int):
    """A worker: its share of the cores for the tracer's threads; Ctrl-C (sent to the whole
    process group) stops the frame it renders, which then writes nothing, and the frames
    already queued for it; it never kills an idle worker mid-protocol."""
    import threading
    from concurrent.futures import wait
    from ..interrupt import redeliver_in_finalizers
    from ..trace.jit import _helpers, set_threads
    set_threads(threads)
    # the helper threads the kernels run on, started before the handlers below can
    # raise: an interrupt inside a thread's start() left that thread out of the list
    # concurrent.futures ends at exit, and the worker's exit waited for it for ever
    # (once in 20 under load). A barrier, so that each task takes a thread of its own
    started = threading.Barrier(threads)
    wait([_helpers(threads).submit(started.wait) for _ in range(threads)])
    redeliver_in_finalizers()

    def on_signal(signum, frame):
        global _interrupted
        # SIGTERM and SIGHUP once: sent to the group and passed on by the command too.
        # Ctrl-C every time: a second one is the finalizer hook's redelivery of the first
        again = _interrupted and signum != signal.SIGINT
        _interrupted = True
        if _busy and not again:
            raise KeyboardInterrupt
    signal.signal(signal.SIGINT, on_signal)
    take_unless_ignored(TERMINATIONS, on_signal)        # as the command's own (nohup)
    # held back since the spawn (_run_parallel): what came meanwhile is taken now
    signal.pthread_sigmask(signal.SIG_UNBLOCK, STOPS)


def _render_job(job: FrameJob, in_worker: bool = True):
    """(index, summary, notes, error): errors as text, so that nothing unpicklable crosses
    back from a worker."""
    global _busy
    if _interrupted:
        return job.index, None, [], "interrupted"
    _busy = True
    try:
        summary, notes = render_file(job.source, job.png, job.opts, text=job.text)
        return job.index, summary, notes, None
    except PcsgError as e:
        return job.index, None, [], "\n".join(d.format() for d in e.diagnostics)
    except RenderFailed as e:
        return job.index, None, [], str(e)
    except OSError as e:
        return job.index, None, [], f"{e.strerror or e}" + (f": {e.filename}"
                                                             if e.filename else "")
    except KeyboardInterrupt:
        release_compiler_lock()
        if not in_worker:
            raise
        return job.index, None, [], "interrupted"
    finally:
        _busy = False


# ---- the whole animation -------------------------------------------------------------

class _Reporter:
    def __init__(self, anim: Animation, todo: list[FrameJob], timed: bool, total: int):
        self.anim, self.timed, self.total = anim, timed, total
        self.by_index = {j.index: j for j in todo}
        self.todo = len(todo)
        self.done = total - len(todo)
        self.rendered = 0
        self.failed: list[str] = []
        self.seen: set[str] = set()
        self.start = time.perf_counter()

    def finished(self, manifest: Manifest, result):
        index, summary, notes, error = result
        job = self.by_index[index]
        if error is not None:
            if error != "interrupted":
                print(f"pcsg animate: {job.png.name}: {error}", file=sys.stderr)
            self.failed.append(job.png.name)
            return
        manifest.record(job.png, job.key)
        self.done += 1
        self.rendered += 1
        for note in notes:
            kind = re.sub(r"\d[\d,.]*", "#", note)    # the same note with other counts
            if kind not in self.seen:
                self.seen.add(kind)
                print(labelled(job.png, note), file=sys.stderr)
        if not self.anim.opts.quiet:
            elapsed = time.perf_counter() - self.start
            eta = elapsed / self.rendered * (self.todo - self.rendered)
            print(f"{summary}{f', t = {job.t:.4g}' if self.timed else ''}  "
                  f"[{self.done}/{self.total}, ETA {eta:.0f} s]", flush=True)


def animate(anim: Animation) -> int:
    """Renders what is missing, then the animation; returns the number of failed frames.
    Ctrl-C keeps every finished frame (written whole, and in the manifest)."""
    if anim.out_dir.exists() and not anim.out_dir.is_dir():
        raise BadAnimation(f"-o {anim.out_dir}: {anim.out_dir} is a file, not a directory")
    if FRAME_NAME.fullmatch(f"{anim.source.stem}.png"):
        # frame_0000.pcsg: its animation, frame_0000.png, was written over its first frame,
        # which every later run then rendered again
        raise BadAnimation(f"{anim.source}: its animation would be named "
                           f"{anim.source.stem}.png, as a frame is; rename the file")
    jobs, timed = plan(anim)
    stem = anim.source.stem
    movies = [anim.out_dir / f"{stem}.png"] + ([anim.out_dir / f"{stem}.gif"] if anim.gif else [])
    if (d := directory_in_the_way([j.png for j in jobs] + movies)) is not None:
        raise BadAnimation(f"{d} is a directory, where an image of the animation goes: "
                           f"move it, or give another -o")
    if problem := make_directory(anim.out_dir):
        raise BadAnimation(f"-o {anim.out_dir}: {problem}")
    manifest = Manifest(anim.out_dir)
    gif = {f"{anim.source.stem}.gif"} if anim.gif else set()
    ours = re.compile(rf"{FRAME_NAME.pattern}|{re.escape(anim.source.stem)}\.gif")
    for name in manifest.forget_others({j.png.name for j in jobs} | gif, ours.fullmatch):
        # frames of a longer earlier run, and the GIF of an earlier run where this one
        # writes none (kept till it is written again: a frame may fail)
        (anim.out_dir / name).unlink(missing_ok=True)
    todo = [j for j in jobs if anim.force or not manifest.complete(j.png, j.key)]
    workers = max(1, min(anim.jobs or cores(), len(todo), cores()))
    if anim.jobs and anim.jobs > cores() and anim.cluster is None:   # a note: -q keeps it
        # each worker imports numba and loads the kernels: --jobs 1000 started a process
        # per frame on two cores, 17 s for what 2 took in 2.6
        print(f"pcsg animate: note: --jobs {anim.jobs}: {cores()} cores here, so {workers} worker "
              f"process{'es' if workers > 1 else ''}", file=sys.stderr)
    report = _Reporter(anim, todo, timed, len(jobs))
    if report.done and not anim.opts.quiet:
        print(f"{anim.out_dir}: {report.done} of {len(jobs)} frames are done already; "
              f"rendering {len(todo)}", flush=True)
    if anim.cluster is not None:
        workers = anim.cluster.workers
    try:
        if anim.cluster is not None:
            _run_on_cluster(todo, anim.cluster, manifest, report)
        elif workers == 1:
            for job in todo:
                report.finished(manifest, _render_job(job, in_worker=False))
        else:
            _run_parallel(todo, workers, manifest, report, anim.threads)
    except KeyboardInterrupt:
        tell(f"{anim.out_dir}: interrupted with {report.done} of {len(jobs)} frames done; "
             f"the same command resumes")
        raise
    finally:
        manifest.flush()
    made = ""
    if not report.failed:
        from .movie import write_apng, write_gif
        frames = [j.png for j in jobs]
        write_apng(frames, anim.out_dir / f"{stem}.png", anim.fps)
        made = f"; animation {anim.out_dir / f'{stem}.png'}"
        if anim.gif:
            write_gif(frames, anim.out_dir / f"{stem}.gif", anim.fps)
            # in the manifest, so that a later run without --gif takes it away as it does
            # an earlier run's extra frames (and no GIF the user put there)
            manifest.record(anim.out_dir / f"{stem}.gif", "animation")
            manifest.flush()
            made += f" and {anim.out_dir / f'{stem}.gif'}"
    else:
        # kept, as render keeps a picture it could not replace; but it is not this run's
        earlier = [p for p in (anim.out_dir / f"{anim.source.stem}{e}" for e in (".png", ".gif"))
                   if p.is_file()]
        made = "; no animation written" + (
            f" ({' and '.join(map(str, earlier))} {'is' if len(earlier) == 1 else 'are'} "
            f"an earlier run's)" if earlier else "")
    seconds = time.perf_counter() - report.start
    unit = "worker" if anim.cluster is not None else "job"
    how = f" with {workers} {unit}{'s' if workers > 1 else ''}" if report.rendered else ""
    sun = jobs[0].opts.light
    placed = (f"; the default sun stood at --light={','.join(repr(v) for v in sun)}"
              if sun is not None and anim.opts.light is None else "")
    print(f"{anim.out_dir}: {report.done} of {len(jobs)} frames ({len(jobs) - len(todo)} "
          f"reused, {report.rendered} rendered{how}) in {seconds:.1f} s{made}{placed}"
          + (f"; failed: {', '.join(report.failed)}" if report.failed else ""))
    return len(report.failed)


def _run_on_cluster(todo, runner, manifest, report):
    """Each frame a task on the cluster's workers, its grammar text sent along (no shared
    file system needed); the PNG comes back and is written here as it arrives."""
    from ..output import write_atomic
    from ..distributed.units import Unit, render_unit
    by_png = {job.png: job for job in todo}
    units = [Unit(job.text, str(job.source), job.opts) for job in todo]
    pngs = {id(u): job.png for u, job in zip(units, todo)}
    for unit, outcome, worker, crash in runner.run(render_unit, units):
        job = by_png[pngs[id(unit)]]
        error = crash or outcome.error
        if error is None:
            write_atomic(job.png, outcome.png)
            rate = outcome.rays / max(outcome.seconds, 1e-9)
            summary = (f"{job.png}: {job.opts.size[0]}x{job.opts.size[1]}, "
                       f"{outcome.seconds:.2f} s, {rate / 1e6:.2f} M rays/s on {worker}")
            report.finished(manifest, (job.index, summary, outcome.notes, None))
        else:
            report.finished(manifest, (job.index, None, [], str(error)))


def worker_threads(asked: int | None, workers: int) -> int:
    """A frame process's threads: --threads, at most the cores (each worker of `--threads
    300` started 300, and the animation took 25 s for 2), else its share of the cores."""
    return min(asked, cores()) if asked else max(1, cores() // workers)


def _run_parallel(todo, workers, manifest, report, asked=None):
    import multiprocessing
    threads = worker_threads(asked, workers)
    pool = ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"),
                               initializer=_init_worker, initargs=(threads,))
    with pool:
        # the submits start the workers; a Ctrl-C that reached one before its
        # initializer took it over printed a traceback from Python's start-up, and a
        # SIGTERM passed on to it killed it, which broke the pool (and CPython's clean-up
        # of a broken pool with cancelled futures fails, and the command hung). So the
        # signals are held back across the spawn (the mask is kept across exec) and
        # _init_worker takes them; here they come once the submits are done
        pending = set()
        try:
            signal.pthread_sigmask(signal.SIG_BLOCK, STOPS)
            try:
                for job in todo:
                    pending.add(pool.submit(_render_job, job))
            finally:
                signal.pthread_sigmask(signal.SIG_UNBLOCK, STOPS)
            for f in as_completed(list(pending)):
                pending.discard(f)
                report.finished(manifest, f.result())
        except KeyboardInterrupt as e:
            # frames being rendered stop or finish; either way what they wrote is whole,
            # and finished ones go into the manifest. A Ctrl-C at the terminal reached the
            # workers too; a signal to this process alone (`kill -INT PID`, SIGTERM,
            # SIGHUP) is passed on to them, a SIGINT as SIGTERM, which a worker that had
            # the group's Ctrl-C already takes as the same stop (_init_worker), where a
            # second SIGINT would interrupt it again. Without it, `kill -INT` left the
            # frames being rendered to finish, and the frames queued for the workers
            # (which cancel() cannot take back) to start
            for f in pending:
                f.cancel()
            _signal_workers(pool, e.signum if isinstance(e, Terminated) else signal.SIGTERM)
            for f in pending:
                if f.cancelled():
                    continue
                try:
                    report.finished(manifest, f.result())
                except BrokenProcessPool:       # a worker killed before it took signals
                    pass
            raise


def _signal_workers(pool, signum: int) -> None:
    # the pool keeps its processes by pid in a private mapping; a worker that has gone
    # already is skipped
    for pid in list(getattr(pool, "_processes", None) or {}):
        try:
            os.kill(pid, signum)
        except (ProcessLookupError, PermissionError):
            pass
