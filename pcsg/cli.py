"""The `pcsg` command: check, expand, stats, graph, render, sweep, animate and export .pcsg
files."""
from __future__ import annotations

import atexit
import contextlib
import gc
import glob
import importlib
import importlib.util
import json
import os
import re
import sys
import time
import warnings
from pathlib import Path

IMPORTS_BEGAN = time.perf_counter()     # for --timings: the imports start here

from .arguments import parser  # noqa: E402
from .interrupt import (Terminated, redeliver_in_finalizers, release_compiler_lock,  # noqa: E402
                        tell, terminate_as_interrupt)
from .language import prefetch  # noqa: E402
from .language.files import MAX_FILE_BYTES, pcsg_files  # noqa: E402
from .language.errors import PcsgError, labelled  # noqa: E402
from .overrides import given_twice  # noqa: E402
from .limits import (GIF_FPS, GIF_PIXELS, MAX_FRAMES, bounces_problem,  # noqa: E402
                     shadow_samples_problem, size_problem)
from .timings import Timings, note_startup  # noqa: E402
from .statusout import is_stdout, status_stream  # noqa: E402

EXIT_OK, EXIT_ERRORS, EXIT_USAGE, EXIT_INTERNAL = 0, 1, 2, 3


class UsageError(Exception):
    pass


def expand_globs(patterns: list[str]) -> list[str]:
    """Shell globs arrive expanded; quoted ones (or ones on shells that don't) are expanded
    here, and a directory is its .pcsg files (`pcsg render grammars/ -o out/`)."""
    out = []
    for pat in patterns:
        if not os.path.exists(pat) and any(ch in pat for ch in "*?["):
            # `**` as bash's globstar: any depth of directories (it was one level)
            matches = sorted(glob.glob(pat, recursive=True))
            if not matches:
                raise UsageError(f"no file matches '{pat}'")
        else:
            matches = [pat]
        found: dict[str, None] = {}     # 'd/**' matches d/ and its files: each once
        for m in matches:
            found.update(dict.fromkeys(pcsg_files(m) if os.path.isdir(m) else [m]))
        # where no directory held any, each fails alone, as a file that cannot be read does
        out += found or matches
    return out


def _report(err: PcsgError | None, warnings, stream=None):
    stream = stream or sys.stderr
    for w in warnings:
        print(w.format(), file=stream)
    if err is not None:
        for d in err.diagnostics:
            print(d.format(), file=stream)


def _compile(path, overrides):
    from .compiler import compile_file
    return compile_file(path, dict(overrides))


def cmd_check(args) -> int:
    failed = 0
    for path in expand_globs(args.files):
        failed += _check_file(path, args)
    return EXIT_ERRORS if failed else EXIT_OK


def _check_file(path, args) -> int:
    """1 where the file fails the check, after its report."""
    from .graph.checks import derivation_faults
    try:
        graph = _compile(path, args.overrides)
        errors, warnings = derivation_faults(graph)
        if errors:
            raise PcsgError(errors)
        graph.warnings += warnings
    except PcsgError as e:
        _unbroken(_report, e, [])
        return 1
    _unbroken(_report, None, graph.warnings)
    if args.werror and graph.warnings:
        n = len(graph.warnings)
        _unbroken(print, f"{path}: failed: {_counted(n, 'warning')} with --werror",
                  file=sys.stderr)
        return 1
    if not args.quiet:
        from .graph.volumes import graftal_nodes
        n = len(graph.warnings)
        # not the tracer's `pixels`
        params = len([p for p in graph.params if graph.params[p] != graph.pixels])
        graftals = len(graftal_nodes(graph))
        _unbroken(print, f"{path}: ok ({_counted(len(graph.nodes), 'node')}, "
                  f"{_counted(len(graph.modules), 'module')}, {_counted(params, 'parameter')}"
                  + (f", {_counted(graftals, 'graftal')}" if graftals else "")
                  + (f", {_counted(n, 'warning')}" if n else "") + ")")
    return 0


def _unbroken(say, *args, **kwargs):
    """say(...), where a reader that left is no reason to stop: `pcsg check dir | head -1`
    checks the files after all the same, since their errors are the exit status (it was 0,
    the rest unchecked)."""
    try:
        say(*args, **kwargs)
    except BrokenPipeError:
        _drop_broken_streams()


def _drop_broken_streams():
    """Standard output or error, whichever pipe lost its reader, to /dev/null from now on
    (the other may be a terminal that still reads)."""
    import select
    for stream in (sys.stdout, sys.stderr):
        try:
            fd = stream.fileno()
        except (AttributeError, OSError, ValueError):     # None, closed, or no file's
            continue
        poll = select.poll()
        poll.register(fd, select.POLLOUT)
        # a pipe's write end whose read end is closed polls POLLERR
        if any(events & select.POLLERR for _, events in poll.poll(0)):
            os.dup2(os.open(os.devnull, os.O_WRONLY), fd)


def _counted(n: int, word: str) -> str:
    return f"{n} {word}{'' if n == 1 else 's'}"


def _write(text: str, output: str | None, source: str):
    if output is None:
        if sys.stdout is None:          # started with it closed (`>&-`): said, not lost
            raise UsageError("standard output is closed: give -o FILE")
        sys.stdout.write(text)
        return
    _output_directory(output)
    _not_an_input(output, "-o", [source])
    from .output import write_atomic
    write_atomic(Path(output), text.encode("utf-8"))


def _not_an_input(output: str | Path, option: str, inputs):
    """An output named like one of the command's inputs (a slip of the shell's history:
    `export s.pcsg --pov s.pcsg`) would replace it; refused before anything is written."""
    for given in inputs:
        if _same_file(output, given):
            raise UsageError(f"{option} {output}: that is {given}, which this command reads; "
                             f"name another file")


def _same_file(a: str | Path, b: str | Path) -> bool:
    """By name, or by the file itself: a hard link of the input is the input (writing it
    replaced the link with the output and left the file it shared under its other name)."""
    if Path(a).resolve() == Path(b).resolve():
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:             # one of them is not there (yet): not the same
        return False


def _make_directory(path: Path, output: str):
    from .output import make_directory
    if problem := make_directory(path):
        raise UsageError(f"-o {output}: {problem}")


def _output_directory(output: str, option: str = "-o"):
    """An output into a directory that is not there, said as such (the error named the
    temporary file beside the output), by every command that writes one."""
    from .output import cannot_write_in
    parent = Path(output).parent
    if Path(output).is_dir():
        raise UsageError(f"{option} {output}: that is a directory; name a file in it")
    if output.endswith(("/", os.sep)):
        # Path() drops the slash: `-o new/` wrote a file named new (QA)
        raise UsageError(f"{option} {output}: a name that ends in / is a directory's; name "
                         f"a file")
    if not parent.is_dir():
        what = (f"the directory {parent} does not exist" if not parent.exists()
                else f"{parent} is a file, not a directory")
        raise UsageError(f"{option} {output}: {what}")
    if _device(Path(output)):
        return          # written into, not replaced (output.open_atomic)
    # through a link the file it names is replaced, beside it
    target = Path(os.path.realpath(output))
    if target.parent != parent.resolve() and not target.parent.is_dir():
        raise UsageError(f"{option} {output}: that is a link to {target}, whose directory "
                         f"does not exist")
    if problem := cannot_write_in(target.parent):
        raise UsageError(f"{option} {output}: {problem}")


def cmd_expand(args) -> int:
    from .graph.expand import ExpansionTooLarge, expand_file
    from .graph.stats import MAX_LEVELS
    if args.steps < 0:
        raise UsageError("-n must be 0 or more")
    if args.steps > MAX_LEVELS:
        # expand stopped at MAX_LEVELS steps and its header said -n's
        raise UsageError(f"-n {args.steps}: expand takes at most {MAX_LEVELS} steps")
    if args.max_chars is not None and args.max_chars < 1:
        raise UsageError(f"--max-chars {args.max_chars}: give 1 or more")
    if args.output:
        _named_as_another_kind(args.output, "-o", "a grammar", ".pcsg")
    graph = _compile(args.file, args.overrides)
    _report(None, graph.warnings)
    notes: list[str] = []
    # by default no longer than pcsg reads back: 50 million characters were written that
    # check and render then refused (QA); a character is at least a byte
    readable = f"pcsg reads grammars of up to {MAX_FILE_BYTES:,} bytes (8 MiB)"
    limit = MAX_FILE_BYTES if args.max_chars is None else args.max_chars
    try:
        text = expand_file(graph, args.steps, limit, notes, args.overrides)
        size = len(text.encode("utf-8")) if len(text) > MAX_FILE_BYTES // 4 else 0
    except ExpansionTooLarge as e:
        if args.max_chars is not None:
            raise UsageError(str(e)) from None
        size = None
    if args.max_chars is None and (size is None or size > MAX_FILE_BYTES):
        said = f"more than {MAX_FILE_BYTES:,}" if size is None else f"{size:,}"
        raise UsageError(f"the expansion is {said} bytes, and {readable}: use fewer "
                         f"steps, or --max-chars to write it anyway")
    if size and size > MAX_FILE_BYTES:
        notes.append(f"the expansion is {size:,} bytes, and {readable}: check and render "
                     f"will refuse it")
    _write(text, args.output, args.file)
    for note in notes:
        print(f"{args.file}: warning: {note}", file=sys.stderr)
    return EXIT_OK


def cmd_stats(args) -> int:
    from .graph.stats import graph_stats
    results, failed = [], 0
    for path in expand_globs(args.files):
        try:
            graph = _compile(path, args.overrides)
            _report(None, graph.warnings)
            results.append(graph_stats(graph))
        except PcsgError as e:
            _report(e, [])
            failed += 1
    if args.json:
        # one object for one file; a list for several, however many of them failed
        several = len(results) + failed > 1
        print(json.dumps(results if several else results[0] if results else None, indent=2))
    else:
        for r in results:
            print(_stats_text(r))
    return EXIT_ERRORS if failed else EXIT_OK


def _stats_text(r: dict) -> str:
    from .graph.stats import TOO_MANY
    kinds = ", ".join(f"{v} {k}" for k, v in r["node_kinds"].items() if v)
    modules = ", ".join(f"{m} ({n} rule{'s' if n != 1 else ''})" for m, n in r["modules"].items())
    if r.get("count_digits"):
        count = f"not written: {r['not_counted']}"
    elif r.get("not_counted", "").startswith(TOO_MANY):
        count = f"not counted: {r['not_counted']}"
    elif r.get("not_counted"):
        count = (f"not counted: {r['not_counted']}; a render refines it to pixel size or "
                 f"--max-depth")
    elif r.get("endless"):
        count = ("endless: a graftal, refined to pixel size when rendered (`pcsg export "
                 "--max-depth N` writes it cut at depth N)")
    else:
        by_kind = r["primitives_by_kind"]
        # one kind named too: "89 in the complete derivation" did not say of what
        count = f"{r['primitives']:,} in the complete derivation" + (
            f" ({', '.join(f'{n:,} {k}' for k, n in by_kind.items())})" if len(by_kind) > 1
            else f" ({next(iter(by_kind))})" if by_kind else "")
    lines = [
        f"{r['file']}",
        f"  nodes        {r['nodes']} ({kinds})",
        f"  modules      {modules or 'none'}",
        f"  parameters   {', '.join(r['parameters']) or 'none'}",
        f"  expressions  {r['expressions']} "
        f"({_many(r['bytecode_instructions'], 'instruction')})",
        f"  primitives   {count}",
    ]
    for k, (name, v) in enumerate(r.get("bounding_volumes", {}).items()):
        lines.append(("  bounds       " if k == 0 else " " * 15) + _volume_text(name, v))
    return "\n".join(lines)


def _volume_text(name: str, v: dict) -> str:
    """A graftal module's bounding volume: the one with the smaller mean projected area."""
    box = "box " + " x ".join(f"{hi - lo:.3g}" for lo, hi in zip(v["box"][:3], v["box"][3:]))
    if v["sphere"] is None:
        return f"{name}: {box}, mean projected area {v['box_area']:.4g} (no finite sphere)"
    sphere = f"sphere of radius {v['sphere'][3]:.4g}"
    win, lose = (sphere, box) if v["volume"] == "sphere" else (box, sphere)
    areas = (v["sphere_area"], v["box_area"]) if v["volume"] == "sphere" else \
        (v["box_area"], v["sphere_area"])
    return f"{name}: {win}, mean projected area {areas[0]:.4g} ({lose}: {areas[1]:.4g})"


# what a file's name says it holds, by its suffix
KINDS = {**dict.fromkeys((".png", ".gif", ".jpg", ".jpeg", ".bmp", ".tga", ".ppm", ".exr",
                          ".hdr", ".tif", ".tiff", ".svg", ".pdf", ".webp"), "an image"),
         ".pcsg": "a grammar", ".npy": "an array", ".pov": "a POV-Ray scene",
         ".dot": "Graphviz text", ".gv": "Graphviz text"}


def _named_as_another_kind(output: str, option: str, writes: str, suffix: str) -> None:
    """The kind an output's name says it holds where the command writes another: text
    under an image's name, which a viewer then refused, or over a grammar (`graph -o
    other.pcsg`, `export --pov s.pcsg` replaced it with exit 0). Refused with `writes`,
    what the command writes, and a name of `suffix`."""
    out = Path(output)
    kind = KINDS.get(out.suffix.lower())
    if kind is None or kind == writes or _device(out):
        return
    raise UsageError(f"{option} {output}: the file is {writes}, not {kind}; name it "
                     f"{out.with_suffix(suffix).name}")


def cmd_graph(args) -> int:
    from .graph.dot import to_dot
    out = Path(args.output or "")
    if args.output and KINDS.get(out.suffix.lower()) == "an image" and not _device(out):
        dot = out.with_suffix(".dot")
        raise UsageError(f"-o {args.output}: pcsg graph writes Graphviz text, not an image: "
                         f"-o {dot}, then `dot -T{out.suffix[1:].lower()} {dot} "
                         f"-o {args.output}`")
    if args.output:
        _not_an_input(args.output, "-o", [args.file])      # said as that, first
        _named_as_another_kind(args.output, "-o", "Graphviz text", ".dot")
    graph = _compile(args.file, args.overrides)
    _report(None, graph.warnings)
    _write(to_dot(graph), args.output, args.file)
    return EXIT_OK


def _options(args, overrides: dict | None = None):
    """The render options of render, sweep and animate, checked before anything is
    compiled."""
    from .render.job import Options, check_options
    depth = getattr(args, "depth", None)
    opts = Options(size=args.size, samples=args.samples,
                   overrides=dict(args.overrides) if overrides is None else overrides,
                   eye=args.eye, at=args.at, up=args.up, fov=args.fov, light=args.light,
                   alpha=args.alpha,
                   depth=Path(depth) if depth else None, max_depth=args.max_depth,
                   shadows=not args.no_shadows, bounces=args.bounces, quiet=args.quiet,
                   reference=args.reference, shadow_samples=args.shadow_samples,
                   adaptive=not args.no_adaptive, strict=args.strict, timeout=args.timeout,
                   stack_depth=args.stack_depth, interval_rows=args.interval_rows,
                   max_instances=args.max_instances, bounds_budget=args.bounds_budget,
                   ao=args.ao,
                   ao_distance=args.ao_distance)
    _threads(args)
    problem = check_options(opts)
    if problem and getattr(args, "tiles", 1) > 1:
        from .distributed.batch import check_tiles
        problem = check_tiles(opts, args.tiles)
    if problem:
        raise UsageError(problem)
    return opts


def _threads(args) -> None:
    """--threads: the tracer's threads in this process (animate's frame processes take
    it as their share, Animation.threads). A cluster's workers have their own."""
    if args.threads is None:
        return
    if args.threads < 1:
        raise UsageError(f"--threads {args.threads}: give 1 or more")
    cluster = _cluster_option(args)
    if cluster:
        raise UsageError(f"--threads counts this process's threads and {cluster} renders on "
                         f"a cluster's workers, each with its own (NUMBA_NUM_THREADS where "
                         f"it starts): give one of them")
    from numba import config

    from .trace.jit import set_threads
    most = config.NUMBA_NUM_THREADS
    if args.threads > most:     # a note, as the level of detail's: -q hides progress only
        print(f"pcsg {args.command}: note: --threads {args.threads}: at most {most} here (the "
              f"cores, or NUMBA_NUM_THREADS), so {most}", file=sys.stderr)
    set_threads(args.threads)


def _cluster_option(args) -> str | None:
    """--workers or --scheduler, whichever was given (both: _distributed's error), or
    None: the frames or images render in this process's threads."""
    if args.workers is not None:
        return "--workers"
    return "--scheduler" if args.scheduler else None


def _distributed(args) -> bool:
    """--workers, --scheduler or --tiles: the batch goes through pcsg.distributed."""
    if args.workers is not None and args.scheduler:
        raise UsageError("--workers starts a local cluster, --scheduler uses another: "
                         "give one of them")
    if args.workers is not None and not 1 <= args.workers <= 1024:
        raise UsageError(f"--workers {args.workers}: use 1 to 1024")
    tiles = getattr(args, "tiles", 1)       # not animate's
    if tiles != 1 and not 1 <= tiles <= args.size[1]:
        raise UsageError(f"--tiles {tiles}: use 1 to the image height ({args.size[1]})")
    if tiles > 1 and getattr(args, "depth", None):
        raise UsageError("--depth is not written for tiled images; render without --tiles")
    return args.workers is not None or bool(args.scheduler) or tiles > 1


def _depth_output(depth: str, files: list[str]):
    """--depth FILE.npy, checked as -o is: `--depth same.png` replaced the picture with
    an array, and `--depth s.pcsg` the grammar."""
    path = Path(depth)
    if path.suffix.lower() != ".npy" and not _device(path):    # /dev/stdout: as -o
        raise UsageError(f"--depth {depth}: the depths are written as a NumPy array; name "
                         f"the file {path.with_suffix('.npy').name}")
    _output_directory(depth, "--depth")
    _not_an_input(depth, "--depth", files)


def cmd_render(args) -> int:
    files = expand_globs(args.files)
    opts = _options(args)
    distributed = _distributed(args)
    if opts.depth is not None and len(files) > 1:
        raise UsageError("--depth names one file; render one .pcsg file with it")
    if opts.depth is not None:
        _depth_output(str(opts.depth), files)       # before -o's directory is made
    with _removed_if_left_empty(Path(args.output or ".")):
        outputs = _outputs(files, args.output)
        return _render_into(args, files, opts, distributed, outputs)


@contextlib.contextmanager
def _removed_if_left_empty(directory: Path):
    """The directories that `-o DIR/` makes (DIR and its new parents, deepest first),
    removed again where the command wrote nothing in them: a usage error after they were
    made, a batch whose every file failed, or a sweep or animation stopped before its
    first image, left them there."""
    out = directory.absolute()
    made = [d for d in (out, *out.parents) if not os.path.lexists(d)]
    try:
        yield
    finally:
        for d in made:
            if not d.is_dir() or any(d.iterdir()):
                break
            with contextlib.suppress(OSError):
                d.rmdir()


def _render_into(args, files: list[str], opts, distributed: bool, outputs: list[Path]) -> int:
    from .render.job import RenderFailed, render_file
    for out in outputs:
        _not_an_input(out, "-o", files)
    if opts.depth is not None and _same_file(opts.depth, outputs[0]):
        raise UsageError(f"--depth {opts.depth}: that is the image -o writes; name another "
                         f"file")
    if distributed and args.timings:
        raise UsageError("--timings times renders in this process; drop --workers, "
                         "--scheduler and --tiles to use it")
    if distributed:
        from .distributed.batch import Job, run_jobs
        jobs = [Job(f, out, opts) for f, out in zip(files, outputs)]
        return _exit(run_jobs(jobs, args, resume=bool(args.workers or args.scheduler)))
    failed = []
    start = time.perf_counter()
    for k, (path, out) in enumerate(zip(files, outputs)):
        timings = Timings(startup=k == 0)
        try:
            summary, notes = render_file(
                Path(path), out, opts, timings,
                tell=lambda note, path=path: print(labelled(path, note), file=sys.stderr,
                                                   flush=True))
        except PcsgError as e:
            _report(e, [])
            failed.append(path)
            continue
        except RenderFailed as e:
            print(f"pcsg render: {path}: {e}", file=sys.stderr)
            failed.append(path)
            continue
        except OSError as e:
            print(f"pcsg render: {path}: {e.strerror or e}"
                  + (f": {e.filename}" if e.filename else ""), file=sys.stderr)
            failed.append(path)
            continue
        for note in notes:
            print(labelled(path, note), file=sys.stderr)
        print(summary)
        if args.timings:
            print(timings.report(str(path)), file=sys.stderr, flush=True)
    if len(files) > 1:
        done = len(files) - len(failed)
        print(f"rendered {done} of {len(files)} files in {time.perf_counter() - start:.1f} s"
              + (f"; failed: {', '.join(failed)}" if failed else ""))
    return EXIT_ERRORS if failed else EXIT_OK


def cmd_sweep(args) -> int:
    from .distributed.sweep import Swept
    ranges = [(name, values) for name, values in args.overrides if isinstance(values, Swept)]
    if len(ranges) != 1:
        raise UsageError("give one parameter to sweep, e.g. --set c=1..12 "
                         f"({len(ranges)} ranges given)")
    name, values = ranges[0]
    fixed = {n: v[0] for n, v in args.overrides if not isinstance(v, Swept)}
    _distributed(args)          # its checks; a sweep always goes through pcsg.distributed
    out_dir = Path(args.output)
    if out_dir.exists() and not out_dir.is_dir():
        raise UsageError(f"-o {args.output}: a sweep writes one image per value into a "
                         f"directory, and this is a file")
    if not out_dir.exists() and out_dir.suffix.lower() == ".png":
        # it made a directory of that name
        raise UsageError(f"-o {args.output}: a sweep writes one image per value into a "
                         f"directory; name it, e.g. -o {out_dir.with_suffix('')}/")
    with _removed_if_left_empty(out_dir):
        return _sweep_into(args, out_dir, name, values, fixed)


def _sweep_into(args, out_dir: Path, name: str, values: list, fixed: dict) -> int:
    from .distributed.batch import Job, run_jobs
    from .distributed.sweep import drop_other_widths, sweep_outputs
    # the file's errors and unknown names once, not once for every image
    graph = _compile(args.file, {**fixed, name: values[0]})
    if any(w.code == "set-unread" and w.message.startswith(f"'{name}' ")
           for w in graph.warnings):
        # as animate refuses a t that nothing reads: the same image, again and again
        raise UsageError(f"{args.file}: nothing in it reads {name}, so every image of the "
                         f"sweep would be the same")
    # checked before the directory is made: a usage error left an empty one
    options = [_options(args, {**fixed, name: value}) for value in values]
    _make_directory(out_dir, args.output)
    outputs = sweep_outputs(args.file, out_dir, name, values)
    _no_directory_in_the_way(outputs)
    # said under -q too: it tells of files removed, not of progress (QA)
    if dropped := drop_other_widths(args.file, out_dir, name, values, outputs):
        print(f"pcsg sweep: removed {_many(len(dropped), 'image')} "
              f"of these values that an earlier sweep named with other digits "
              f"({', '.join(dropped[:3])}{', ...' if len(dropped) > 3 else ''})",
              file=sys.stderr)
    jobs = [Job(args.file, out, opts, name=out.name) for opts, out in zip(options, outputs)]
    return _exit(run_jobs(jobs, args, resume=True, what="images"))


def _exit(failed: int) -> int:
    return EXIT_ERRORS if failed else EXIT_OK


def _outputs(files: list[str], output: str | None) -> list[Path]:
    """NAME.png here; or -o FILE.png for one file; or -o DIR/ (created) for any number."""
    names = [Path(f).stem + ".png" for f in files]
    if output is None:
        return _distinct(files, [Path(n) for n in names])
    out = Path(output)
    if out.is_dir() or output.endswith(("/", "\\")) or (len(files) > 1 and not out.suffix):
        paths = _distinct(files, [out / n for n in names])
        _make_directory(out, output)
        return paths
    if len(files) > 1:
        raise UsageError(f"-o {output}: several files need a directory, e.g. -o renders/")
    target = Path(os.path.realpath(out))          # -o through a link writes what it names
    if (out.suffix.lower() != ".png" or target.suffix.lower() != ".png") and not _device(out):
        # PNG bytes in x.jpg, which a viewer going by the name then refused; or over
        # other.pcsg, a grammar, which -o replaced without a word
        if out.suffix.lower() == ".png":
            raise UsageError(f"-o {output}: that is a link to {target}, which is no .png: "
                             f"pcsg writes PNG images")
        if output == "-":
            # "name the file -.png, or -/ for a directory"
            raise UsageError("-o -: pcsg writes PNG images to files; to a pipe, give "
                             "-o /dev/stdout")
        name = out.with_suffix(".png").name
        raise UsageError(f"-o {output}: pcsg writes PNG images; name the file {name}"
                         + ("" if out.suffix else f", or {output}/ for a directory"))
    _output_directory(output)
    return [out]


def _no_directory_in_the_way(paths: list[Path]) -> None:
    from .output import directory_in_the_way
    if (d := directory_in_the_way(paths)) is not None:
        raise UsageError(f"{d} is a directory, where an image goes: move it, or write the "
                         f"images elsewhere with -o")


_STANDARD = re.compile(r"/(dev/(stdout|stderr|fd/[0-9]+)|proc/self/fd/[0-9]+)")


def _device(path: Path) -> bool:
    """A pipe, a terminal or /dev/stdout: written into, whatever its name (/dev/stdout
    redirected to a file is that file, and still written into; not any path under /dev/,
    where /dev/shm/other.pcsg is a grammar)."""
    if _STANDARD.fullmatch(str(path)):
        return True
    try:
        return path.exists() and not path.is_file() and not path.is_dir()
    except OSError:
        return False


def _distinct(files: list[str], paths: list[Path]) -> list[Path]:
    """The paths, where no two files of the batch share one (the second image overwrote
    the first, and the batch said it rendered both) and none is a directory."""
    _no_directory_in_the_way(paths)
    first: dict[Path, int] = {}
    for k, (f, n) in enumerate(zip(files, paths)):
        if first.setdefault(n, k) == k:
            continue
        other = files[first[n]]
        if os.path.realpath(other) == os.path.realpath(f):
            raise UsageError(f"{f} is given twice")
        raise UsageError(f"{other} and {f} would both be written to {n}: rename one, or "
                         f"render them apart")
    return paths


def cmd_animate(args) -> int:
    from .render.animate import Animation, BadAnimation, CannotFrame, animate
    opts = _options(args)
    if not 1 <= args.frames <= MAX_FRAMES:
        raise UsageError(f"--frames {args.frames:,}: give 1 to {MAX_FRAMES:,}")
    if not 0.01 <= args.fps < 1000:
        # an APNG's frame delay is a fraction of whole numbers: inf gave a delay of 0
        raise UsageError(f"--fps {args.fps:g}: give a number from 0.01 to below 1000 "
                         f"(a GIF's frame lasts at most 655 s)")
    if args.gif and args.fps > GIF_FPS:
        # a GIF's delays are whole hundredths of a second: 200 fps wrote 0, which players
        # show as 0.1 s, and they slow any delay under 0.02 s so
        raise UsageError(f"--fps {args.fps:g} with --gif: a GIF plays at most {GIF_FPS} "
                         f"frames a second (a frame lasts whole hundredths of a second, two "
                         f"at least); the animated PNG alone takes any rate below 1000")
    if args.jobs is not None and args.jobs < 1:
        raise UsageError(f"--jobs {args.jobs}: give 1 or more")
    cluster = _cluster_option(args)
    if args.jobs is not None and cluster:
        # the cluster's workers render the frames: --jobs was dropped without a word
        raise UsageError(f"--jobs counts local processes and {cluster} renders the frames "
                         f"on a cluster's workers: give one of them")
    if args.path is not None and args.eye is not None:
        raise UsageError("--eye and --path both place the eye; give one")
    if args.at_path is not None and args.at is not None:
        raise UsageError("--at and --at-path both place the point looked at; give one")
    if args.gif and args.alpha:
        raise UsageError("--gif cannot keep --alpha's transparency; leave one out")
    if args.gif and args.frames * opts.size[0] * opts.size[1] > GIF_PIXELS:
        # the animated PNG is written a frame at a time; the GIF's palette and frames are
        # made from all of them at once
        w, h = opts.size
        raise UsageError(f"--gif: {args.frames:,} frames of {w}x{h} are more than "
                         f"{GIF_PIXELS:,} pixels, which a GIF is made from in memory; leave "
                         f"out --gif (the animated PNG is written a frame at a time), or "
                         f"give fewer --frames or a smaller --size")
    source = Path(args.file)
    out = Path(args.output) if args.output else Path(f"{source.stem}_frames")
    if not out.exists() and out.suffix.lower() in (".png", ".gif"):
        # it made a directory of that name, where sweep and render refuse one
        raise UsageError(f"-o {args.output}: animate writes its frames and the animation "
                         f"into a directory; name it, e.g. -o {out.with_suffix('')}/")
    anim = Animation(source, out, args.frames, opts, args.path, args.at_path, args.fps,
                     args.gif, args.jobs, force=args.force, threads=args.threads)
    if _distributed(args):
        from .distributed.cluster import ClusterUnavailable, connect
        try:
            anim.cluster = connect(args.workers, args.scheduler)
        except ClusterUnavailable as e:
            raise UsageError(str(e)) from None
    try:
        with _removed_if_left_empty(out):
            failed = animate(anim)
    except BadAnimation as e:
        raise UsageError(str(e)) from None
    except CannotFrame as e:        # found once the file is compiled: as render says it
        print(f"pcsg animate: {source}: {e}", file=sys.stderr)
        return EXIT_ERRORS
    finally:
        if anim.cluster is not None:
            anim.cluster.close()
    return EXIT_ERRORS if failed else EXIT_OK




def _povray_input(scene) -> str:
    """POV-Ray's +I option as a shell takes it: a name with a space in POV-Ray's own quotes
    (it splits `+Iout file.pov` at the space, even quoted by the shell), the whole in the
    shell's where it needs them."""
    import shlex
    name = str(scene)
    return shlex.quote(f'+I"{name}"' if any(c.isspace() for c in name) else f"+I{name}")


def cmd_export(args) -> int:
    from .povray import export_pov
    from .render.camera import CameraError, make_camera
    from .render.job import view_problem
    from .render.shade import make_lighting
    from .tracer import Traced
    out = Path(args.pov)
    _output_directory(args.pov, "--pov")
    _not_an_input(args.pov, "--pov", [args.file])
    _named_as_another_kind(args.pov, "--pov", "a POV-Ray scene", ".pov")
    for problem in (bounces_problem(args.bounces), size_problem(args.size),
                    shadow_samples_problem(args.shadow_samples),
                    view_problem(args.eye, args.at, args.up, args.fov, args.light)):
        if problem:
            raise UsageError(problem)
    if args.max_depth is not None and not 1 <= args.max_depth <= 10_000:
        raise UsageError(f"--max-depth {args.max_depth}: use 1 to 10000")
    start = time.perf_counter()
    graph = _compile(args.file, args.overrides)
    _report(None, graph.warnings)
    total = None
    if args.max_depth is None:
        # counted before the bounds, so that a scene too large is refused at once (one of
        # 27e9 primitives walked its bounds for 96 s first); a cut is counted as it derives
        total = _export_total(graph, None)
        _export_fits(args, out, total)
    traced = Traced(graph, args.max_depth)
    cut = _export_cut(args, traced)
    w, h = args.size
    try:
        camera = make_camera(traced, w / h, args.eye, args.at, args.up, args.fov)
        camera.basis()
    except CameraError as e:        # an object too large to frame: as render says it
        print(f"pcsg export: {args.file}: {e}", file=sys.stderr)
        return EXIT_ERRORS
    lighting = make_lighting(traced, camera, not args.no_shadows, args.shadow_samples,
                             args.bounces, light_at=args.light)
    if total is None:
        total = _export_total(graph, cut)
        _export_fits(args, out, total)
    progress = _export_progress(args, total)
    try:
        count, empty, dropped = export_pov(traced, camera, lighting, out, args.size,
                                           _export_watch(args, out, total, progress), cut=cut)
    finally:
        progress.close()
    # the bounding walk's (where a map empties instances: the export leaves them out too)
    _report(None, [w for w in traced.warnings if w not in graph.warnings])
    # a pipe's reader takes the scene on its standard input: POV-Ray 3.7 reads no `+I-`
    scene, size = (("/dev/stdin", "") if _device(out) else
                   (out, f", {out.stat().st_size / 1e6:.1f} MB"))
    print(f"{out}: {_many(count, 'primitive')}{size}, {time.perf_counter() - start:.1f} s; "
          f"render with: povray {_povray_input(scene)} +W{w} +H{h}")
    if empty:
        also = (f"; {dropped:,} more went with the ∩ or \\ that lost an operand"
                if dropped else "")
        # a paint that is not finite empties its instance as a map does (the tracer's rule)
        print(f"{args.file}: warning: {_many(empty, 'primitive')} left out: their transform is "
              f"singular or not finite, or their paint not finite (a runtime error in the "
              f"grammar), so pcsg draws nothing there either{also}", file=sys.stderr)
    return EXIT_OK


def _many(n: int, what: str) -> str:
    return f"{n:,} {what}{'' if n == 1 else 's'}"


PROGRESS_STATES = 20_000     # _export_total's count: about 0.2 s at most
EXPORT_LIMIT = 20_000_000    # primitives: POV-Ray holds about a million in a GB
BYTES_AT_LEAST = 100         # a primitive's bytes in the scene (a mesh's triangle: 109)
MIN_FREE = 100_000_000       # bytes an export leaves free on its disk, or stops


def _export_cut(args, traced):
    """The export's cut (graph/cut.py) at --max-depth, where the tracer's walk stops; an
    error for a graftal without one, whose derivation never ends."""
    from .graph.cut import cut_of
    from .language.errors import Diagnostic
    if args.max_depth is None:
        cut = cut_of(traced)
        if cut.graftal:
            g = traced.graph
            s = cut.endless_node()
            raise PcsgError([Diagnostic(
                "error", f"'{g.nodes[s].name}' has no rule that ends, so its derivation "
                         f"never does: give --max-depth N to end it where `pcsg render "
                         f"--max-depth N` does, each instance there its bounding box",
                g.nodes[s].span, g.source, code="export")])
        return None
    if traced.max_depth < args.max_depth:
        print(f"{args.file}: note: the bounds stop at depth {traced.max_depth}, and so do "
              f"the tracer and this export", file=sys.stderr)
    return cut_of(traced)


def _export_total(graph, cut) -> int:
    """The primitives the export will derive, as `pcsg stats` counts them without
    expanding; 0 where they cannot be counted in a few thousand states (a system whose
    rules are drawn at random would be derived twice). A cut (--max-depth) is counted as
    it derives."""
    from .graph.stats import count_primitives
    try:
        return count_primitives(graph, max_states=PROGRESS_STATES, cut=cut)
    except PcsgError:
        return 0


def _export_fits(args, out: Path, total: int):
    """Refuse, before hours of writing, a scene the disk cannot hold (Sierpinski at 14,
    268 million primitives, filled 15 GB of a temporary file in ten minutes and said
    nothing), and past EXPORT_LIMIT one POV-Ray could not hold, unless --force."""
    free = _free(out)
    fits = free is None or total * BYTES_AT_LEAST <= free
    if total > EXPORT_LIMIT and not args.force:
        # --force was offered where the disk check then refused it
        _too_many(args, f"has {_count(total)} primitives, a scene of {_bytes(total * 150)} or "
                        f"so that POV-Ray needs about {_bytes(total * 1000)} of memory to parse",
                  None if fits else f"its disk has {_bytes(free)} free, too little even with "
                                    f"--force")
    if not fits:
        raise UsageError(f"--pov {out}: the {_count(total)} primitives take at least "
                         f"{_bytes(total * BYTES_AT_LEAST)}, and its disk has {_bytes(free)} free")


def _export_watch(args, out: Path, total: int, progress):
    """The export's callback after each chunk: its progress line, and the refusals of
    _export_fits for a derivation that could not be counted beforehand (a binary tree
    whose parameter is in its selection: 65,536 primitives, counted 0), as it goes: past
    EXPORT_LIMIT, or with the disk nearly full, it stops, and nothing is written."""
    def watch(done: int):
        progress.update(done, done)
        if total:                       # counted: measured against both before it began
            return
        if done > EXPORT_LIMIT and not args.force:
            _too_many(args, f"has passed {EXPORT_LIMIT:,} primitives (POV-Ray holds about a "
                            f"million in a GB of memory); stopped, nothing written")
        free = _free(out)
        if free is not None and free < MIN_FREE:
            raise UsageError(f"--pov {out}: its disk has {_bytes(free)} free; stopped "
                             f"after {_many(done, 'primitive')}, nothing written")
    return watch


def _too_many(args, said: str, no_force: str | None = None):
    raise UsageError(f"{args.file}: the derivation {said}; lower the order (--set), cut it "
                     + (f"(--max-depth N): {no_force}" if no_force else
                        "(--max-depth N), or --force to write it"))


def _free(out: Path) -> int | None:
    """The bytes free on the disk `out` is written to; None for a pipe or device (or a
    disk that does not say)."""
    import shutil
    if _device(out):
        return None
    try:
        usage = shutil.disk_usage(out if out.exists() else out.parent)
    except OSError:
        return None
    # /proc and /sys say 0 of 0 bytes: "its disk has 0.0 MB free" was not why it failed
    return usage.free if usage.total else None


def _count(n: int) -> str:
    """A count of primitives: written out, or past 10^15 by its power of ten."""
    if n < 10 ** 15:
        return f"{n:,}"
    digits = len(str(n))
    return f"{n // 10 ** (digits - 3) / 100:.2f}e{digits - 1}"


def _bytes(n: int | float) -> str:
    """A size for people: MB, GB, TB, and past a petabyte by its power of ten (Sierpinski
    at 510 has 1.1e307 primitives, an int no float holds: an internal error here)."""
    if n >= 10 ** 15:
        digits = len(str(int(n)))
        return f"{int(n) // 10 ** (digits - 3) / 100:.2f}e{digits - 1 - 9} GB"
    for unit, size in (("TB", 10 ** 12), ("GB", 10 ** 9)):
        if n >= size:
            return f"{n / size:.1f} {unit}"
    return f"{n / 1e6:.1f} MB"


def _export_progress(args, total: int):
    """A progress line for the export (a derivation of half a million primitives takes a
    minute), out of the primitives counted (_export_total); none with -q or uncounted."""
    from .render.image import Progress
    return Progress(f"{Path(args.file).name} export", total,
                    not args.quiet and total > 0, unit="primitives")


COMMANDS = {"check": cmd_check, "expand": cmd_expand, "stats": cmd_stats, "graph": cmd_graph,
            "render": cmd_render, "sweep": cmd_sweep, "animate": cmd_animate,
            "export": cmd_export}


FILE_COMMANDS = ("render", "sweep", "animate", "export")     # stdout: status lines only


def main(argv: list[str] | None = None) -> int:
    redeliver_in_finalizers()
    # numpy's overflow and invalid-value warnings in pcsg's own arithmetic (the bounds of
    # `xshear(1e308, 1e308) sphere`) printed a source line to the user: the maps that
    # empty an instance are warned of in pcsg's own words (bounds.fault_warnings)
    warnings.filterwarnings("ignore", category=RuntimeWarning, module=r"pcsg\.")
    args = parser().parse_args(argv)
    if args.command not in FILE_COMMANDS:
        return _run(args)
    if args.command == "export" and args.pov == "-":    # it wrote a file named "-"
        args.pov = "/dev/stdout"
    image = args.pov if args.command == "export" else args.output
    # the depths too: `--depth /dev/stdout` had the summary line after the array
    outputs = [image, getattr(args, "depth", None)] if args.command == "render" else [image]
    saved = sys.stdout
    sys.stdout = status_stream(args.command in ("render", "export") and
                               any(bool(o) and is_stdout(o) for o in outputs))
    try:
        return _run(args)
    finally:
        # a caller's own prints go where they went before (the wrapper holds no text of
        # its own: what it took is in that stream, flushed by whoever owns it)
        sys.stdout = saved


def _run(args) -> int:
    try:
        for attr, flag in (("output", "-o"), ("pov", "--pov"), ("depth", "--depth")):
            if getattr(args, attr, None) == "":
                # it was the working directory, or the default name, or an error of another
                raise UsageError(f"{flag} '': name a file or a directory")
        if twice := given_twice(getattr(args, "overrides", [])):
            raise UsageError(f"--set {twice} is given twice")
        return COMMANDS[args.command](args)
    except PcsgError as e:
        _report(e, [])
        return EXIT_ERRORS
    except UsageError as e:
        print(f"pcsg {args.command}: error: {e}", file=sys.stderr)
        return EXIT_USAGE
    except BrokenPipeError:
        # e.g. `pcsg expand ... | head`: the reader left; that is not an error of ours
        # (before OSError, which it is)
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_OK
    except OSError as e:
        what = f"{e.strerror or e}" + (f": {e.filename}" if e.filename else "")
        print(f"pcsg {args.command}: error: {what}", file=sys.stderr)
        return EXIT_ERRORS
    except KeyboardInterrupt as e:
        release_compiler_lock()
        return _interrupted(e)
    except Exception as e:  # noqa: BLE001 -- a user sees one line, never a traceback
        if os.environ.get("PCSG_DEBUG"):
            raise
        print(f"pcsg: internal error: {type(e).__name__}: {e}\n"
              f"  (this is a bug in pcsg; PCSG_DEBUG=1 shows the traceback)", file=sys.stderr)
        return EXIT_INTERNAL


def _interrupted(e: KeyboardInterrupt) -> int:
    """Ctrl-C's message and status (130), or SIGTERM's or SIGHUP's (143, 129). The
    message may have nowhere to go (SIGHUP: the terminal is gone); the status stays."""
    tell(f"pcsg: terminated ({e})" if isinstance(e, Terminated) else "pcsg: interrupted")
    return e.exit_status if isinstance(e, Terminated) else 130


def needs_kernels(argv: list[str]) -> bool:
    """Whether the command may compile or trace: not a bare `pcsg`, nor any asking for
    help or the version, which argparse answers before a command runs (they took 0.25 s,
    all of it numba's import, for a line of text)."""
    return bool(argv) and not HELP_FLAGS.intersection(argv)


HELP_FLAGS = frozenset({"-h", "--help", "--version"})


def import_kernels() -> None:
    """Import the compiler and the tracer (numba, numpy, the cached kernels' helpers)
    with the collector off, then freeze what they made (see run). The imports make no
    garbage, yet the collector walked their objects again and again as they piled up:
    40 to 60 ms of every command. `import pcsg` imports none of this
    (pcsg/__init__.py), so that it happens here.
    numpy's OpenBLAS gets one thread unless the user chose otherwise: pcsg's matrices are
    3x3 and 4x4, and the threads it starts spin on a core after each call (8 % of the
    CPU samples of a terrain render, by `perf`; Sierpinski at 8: 0.418 s against 0.410 s
    whole, medians of 12)."""
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    collecting = gc.isenabled()
    gc.disable()
    try:
        with _numba_without_yaml(), _numba_without_extensions():
            importlib.import_module(".tracer", __package__)
    finally:
        gc.freeze()
        if collecting:
            gc.enable()


@contextlib.contextmanager
def _numba_without_yaml():
    """numba imports PyYAML where it is installed (dask, the cluster extra, brings it)
    only to read a .numba_config.yaml in the working directory: without one, the import
    is hidden from numba, and later imports of yaml find it as usual. 14 ms of every
    command (`import numba` 258.5 ms against 272.7 ms, medians of 20 alternating)."""
    if "yaml" in sys.modules or os.path.exists(".numba_config.yaml"):
        yield
        return
    sys.modules["yaml"] = None          # `import yaml` raises ImportError
    try:
        yield
    finally:
        if "yaml" in sys.modules and sys.modules["yaml"] is None:
            del sys.modules["yaml"]


@contextlib.contextmanager
def _numba_without_extensions():
    """numba loads the `numba_extensions` entry points of every installed distribution
    the first time a kernel loads: it reads the metadata of each (2.5 ms here, more in a
    larger environment), and imports importlib.metadata to do it (10 ms of every command).
    They are plug-ins that teach numba other libraries' types (awkward, numba-scipy, ...),
    which pcsg's kernels never use; loaded into its compiler, they would only make the
    kernels depend on what else is installed. The command skips them, and imports
    importlib.metadata where something uses it (importlib's LazyLoader)."""
    name = "importlib.metadata"
    if name not in sys.modules:
        spec = importlib.util.find_spec(name)
        if spec is not None and spec.loader is not None:
            spec.loader = importlib.util.LazyLoader(spec.loader)
            module = importlib.util.module_from_spec(spec)
            sys.modules[name] = module
            # as an import sets it: `from importlib import metadata` then reads no
            # attribute of the module, which would load it
            importlib.metadata = module
            spec.loader.exec_module(module)     # deferred to the first attribute read
    yield
    entrypoints = sys.modules.get("numba.core.entrypoints")
    if entrypoints is not None and hasattr(entrypoints, "_already_initialized"):
        entrypoints._already_initialized = True


def run() -> None:
    """The console command: main(), then exit without the interpreter's teardown.
    Once main has returned, the files it wrote are closed and only stdout and stderr
    need a flush; what the teardown would do then is free numba's compiled code and
    the modules one by one, which took 0.15 to 0.25 s of every command (a fifth of a
    small render's wall time).
    Before main, the objects of the imports (numba's types, templates and compiled
    kernels: about a hundred thousand) go to gc's permanent generation: they live as long
    as the process, and every full collection during the compile and the bounding walk
    walked them all again (0.1 to 0.25 s of a terrain render)."""
    redeliver_in_finalizers()
    try:
        terminate_as_interrupt()
        if needs_kernels(sys.argv[1:]):
            prefetch.first_file(sys.argv[1:])       # parsed on the other core meanwhile
            import_kernels()
    except KeyboardInterrupt as e:      # main reports one from then on
        os._exit(_interrupted(e))
    note_startup(IMPORTS_BEGAN)
    code = main()
    for stream in (sys.stdout, sys.stderr):
        if stream is None:                      # started with it closed (`>&-`)
            continue
        try:
            stream.flush()
        except (BrokenPipeError, ValueError):   # a reader that left, or a closed stream
            pass
        except OSError as e:                    # a full disk: the output is cut short
            print(f"pcsg: error: {e.strerror or e}", file=sys.stderr, flush=True)
            code = code or EXIT_ERRORS
    atexit._run_exitfuncs()     # what a normal exit runs first (logging, dask, multiprocessing)
    os._exit(code)


if __name__ == "__main__":
    run()
