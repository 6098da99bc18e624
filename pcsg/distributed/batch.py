"""A batch of images over a runner: units submitted, results written as they arrive
(each by temporary file and rename), complete outputs skipped on a restart."""
from __future__ import annotations

import dataclasses
import sys
import time
from collections import Counter
from pathlib import Path

from ..language.errors import PcsgError, labelled
from ..language.files import read_source_text
from ..output import write_atomic
from ..render.job import Options, check_options, nothing_met, strict_failure, summary_line
from .cluster import LOCAL, ClusterUnavailable, LocalRunner, connect, require_dask
from ..resume import Manifest, output_key
from .tiles import MAX_TILED_PIXELS, Assembler, bands
from .units import Outcome, Unit, render_unit, report_unit


@dataclasses.dataclass
class Job:
    label: str              # the .pcsg path as given
    out: Path
    opts: Options           # its overrides included
    name: str = ""          # how a failure is listed (default: the label)


def read_sources(jobs: list[Job]) -> tuple[dict[str, str], list[str]]:
    """Each distinct file's text, read here and sent with its tasks; the unreadable ones
    are reported and failed."""
    sources, failed = {}, []
    for label in dict.fromkeys(j.label for j in jobs):
        try:
            sources[label] = read_source_text(label)
        except PcsgError as e:
            for d in e.diagnostics:
                print(d.format(), file=sys.stderr)
            failed.append(label)
    return sources, failed


class Batch:
    def __init__(self, tiles: int = 1, manifest: bool = False, skip: bool = False,
                 quiet: bool = False, command: str = "render"):
        """manifest: record each output made, so that a restart can skip it (cluster
        batches and sweeps); skip: skip those recorded and intact (unless --force).
        command: the one whose messages these are (a sweep's said "pcsg render")."""
        self.tiles, self.manifest, self.skip, self.quiet = tiles, manifest, skip, quiet
        self.command = command
        self.manifests: dict[Path, Manifest] = {}
        self.per_worker: Counter = Counter()
        self.failed: list[str] = []
        self.failed_jobs: set[int] = set()
        self.skipped = self.done = 0

    def _manifest(self, out: Path) -> Manifest:
        d = out.parent.resolve()
        if d not in self.manifests:
            self.manifests[d] = Manifest(d)
        return self.manifests[d]

    def plan(self, jobs: list[Job]) -> list[Unit]:
        """The units still to render: unreadable files fail here, complete outputs are
        skipped (before any cluster is started for them)."""
        sources, unreadable = read_sources(jobs)
        units, self.by_unit = [], {}
        for job in jobs:
            if job.label in unreadable:
                self._fail(job, None)
                continue
            if self.manifest and (problem := self._manifest(job.out).problem):
                # found now, not after every image is rendered
                self._fail(job, self._said(job, problem))
                continue
            key = output_key(sources[job.label], job.opts)
            if self.skip and self._manifest(job.out).complete(job.out, key):
                self.skipped += 1
                continue
            rows = bands(job.opts.size[1], self.tiles) if self.tiles > 1 else [None]
            for r in rows:
                unit = Unit(sources[job.label], job.label, job.opts, r)
                units.append(unit)
                self.by_unit[id(unit)] = (job, key, len(rows))
        return units

    def run(self, runner, units: list[Unit]):
        """Render the planned units, writing each output as soon as it is complete."""
        self.runner = runner
        assemblers: dict[int, Assembler] = {}
        total = len(units)
        # the bands of an image that failed are not rendered where the runner asks for
        # them one by one (here): with --tiles 4 --timeout, bands 3 and 4 were, and said
        # so after "nothing written"
        wanted = (u for u in units if id(self.by_unit[id(u)][0]) not in self.failed_jobs)
        try:
            for n, (unit, outcome, worker, exc) in enumerate(runner.run(render_unit, wanted), 1):
                job, key, tiles = self.by_unit[id(unit)]
                if worker is not None:
                    self.per_worker[worker] += 1
                what = (job.name or job.label) + (f" rows {unit.rows[0]}-{unit.rows[1] - 1}"
                                                  if unit.rows else "")
                if unit.rows is not None or worker != LOCAL:
                    # a whole image made here has its summary line; this would say it twice
                    self._progress(n, total, what, outcome, worker)
                if exc is not None:
                    outcome = Outcome(error=f"pcsg {self.command}: {what}: failed on the "
                                            f"cluster: {type(exc).__name__}: {exc}")
                try:
                    if unit.rows is None:
                        self._whole(job, key, outcome)
                    else:
                        self._tile(job, key, unit, outcome, tiles, assemblers)
                except OSError as e:        # this output cannot be written; the others can
                    a = assemblers.get(id(job))
                    if a is not None and a.image is not None:
                        a.discard()
                    self._fail(job, self._said(job, f"{e.strerror or e}"
                                               + (f": {e.filename}" if e.filename else "")))
        finally:
            for a in assemblers.values():
                if a.image is not None:
                    a.discard()
            for manifest in self.manifests.values():
                manifest.flush()

    def _progress(self, n, total, what, outcome, worker):
        if self.quiet:
            return
        took = f", {outcome.seconds:.2f} s" if outcome is not None and outcome.seconds else ""
        print(f"[{n}/{total}] {what} on {worker or 'a lost worker'}{took}",
              file=sys.stderr)

    def _said(self, job: Job, text: str) -> str:
        """A message about one job: the command, the file, and the image where a sweep
        makes several of one file."""
        image = f" ({job.name})" if job.name and job.name != job.label else ""
        return f"pcsg {self.command}: {job.label}{image}: {text}"

    def _error(self, job: Job, outcome: Outcome) -> str:
        return outcome.error if outcome.said_where else self._said(job, outcome.error)

    def _fail(self, job: Job, message: str | None):
        """Reported once per job, however many of its bands fail."""
        if id(job) in self.failed_jobs:
            return
        if message:
            print(message, file=sys.stderr)
        self.failed_jobs.add(id(job))
        self.failed.append(job.name or job.label)

    def _whole(self, job: Job, key: str, outcome: Outcome):
        if outcome.error is not None:
            return self._fail(job, self._error(job, outcome))
        write_atomic(job.out, outcome.png)
        if job.opts.depth is not None:
            write_atomic(job.opts.depth, outcome.depth)
        self._finished(job, key, outcome.notes, outcome.seconds, outcome.rays, "")

    def _tile(self, job, key, unit, outcome, tiles, assemblers):
        slot = id(job)
        if slot not in assemblers and slot not in self.failed_jobs:
            w, h = job.opts.size
            assemblers[slot] = Assembler(job.out, w, h, 4 if job.opts.alpha else 3, tiles)
        a = assemblers.get(slot)
        if outcome.error is not None:
            if a is not None and a.image is not None:
                a.discard()
            return self._fail(job, self._error(job, outcome))
        if a is None or a.image is None:
            return                          # an earlier band failed: nothing is written
        if not a.add(unit.rows, outcome.pixels, outcome.seconds, outcome.rays, outcome.events,
                     outcome.met):
            return
        notes, errors = self.runner.call(report_unit, unit, a.events)
        notes += nothing_met(job.label, a.met, a.events)
        if errors:
            a.discard()
            return self._fail(job, self._said(job, str(strict_failure(errors))))
        a.write()
        self._finished(job, key, notes, a.seconds, a.rays, f", {tiles} tiles")

    def _finished(self, job: Job, key: str, notes, seconds: float, rays: int, extra: str):
        if self.manifest and job.opts.depth is None:
            self._manifest(job.out).record(job.out, key)
        # a sweep's notes name the image too (each of its images said the file's name alone)
        where = job.label if not job.name or job.name == job.label else \
            f"{job.label} ({job.name})"
        for note in notes:
            print(note if note.startswith(f"{job.label}:") else labelled(where, note),
                  file=sys.stderr)
        print(summary_line(job.out, job.opts, seconds, rays) + extra)
        self.done += 1

    def summary(self, count: int, start: float, what: str = "files") -> str:
        line = f"rendered {self.done} of {count} {what} in {time.perf_counter() - start:.1f} s"
        if self.skipped:
            line += f"; skipped {self.skipped} already complete (--force renders them again)"
        if self.failed:
            line += f"; failed: {', '.join(self.failed)}"
        return line

    def worker_line(self) -> str | None:
        if not self.per_worker or set(self.per_worker) == {LOCAL}:
            return None
        return "tasks per worker: " + ", ".join(f"{w} {n}" for w, n in
                                                sorted(self.per_worker.items()))


def check_tiles(opts, tiles: int) -> str | None:
    """A tiled image may be larger than one render's limit: a worker holds one band."""
    w, h = opts.size
    if w * h > MAX_TILED_PIXELS:
        return (f"--size {w}x{h}: a tiled image is assembled in memory, 4 bytes a pixel; "
                f"pcsg assembles up to {MAX_TILED_PIXELS // 1_000_000} million pixels")
    problem = check_options(dataclasses.replace(opts, size=(w, -(-h // tiles))))
    return problem and f"{problem} (in one band of --tiles {tiles}; give more tiles)"


def run_jobs(jobs: list[Job], args, resume: bool, what: str = "files") -> int:
    """The command line's batch: on the cluster that args ask for, else here. Returns
    how many jobs failed."""
    from ..cli import UsageError       # cli imports this module lazily: no cycle at import
    start = time.perf_counter()
    cluster = args.workers is not None or bool(args.scheduler)
    try:
        if cluster:
            require_dask()
        batch = Batch(args.tiles, resume, resume and not args.force, args.quiet,
                      getattr(args, "command", "render"))
        units = batch.plan(jobs)
        runner = None
        if units:
            runner = connect(args.workers, args.scheduler) if cluster else LocalRunner()
    except ClusterUnavailable as e:
        raise UsageError(str(e)) from None
    if runner is not None:
        try:
            batch.run(runner, units)
        finally:
            runner.close()
    line = batch.worker_line()
    if line and not args.quiet:
        print(line, file=sys.stderr)
    if len(jobs) > 1 or batch.skipped:
        print(batch.summary(len(jobs), start, what))
    return len(batch.failed)
