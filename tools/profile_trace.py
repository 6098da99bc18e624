"""Where the tracing kernel spends its time: a `perf` profile of primary rays, mapped
onto the kernel's machine code.

    python tools/profile_trace.py [SAMPLE] [--set NAME=VALUE] [--repeat 3] [--top 15] [--walk]

numba loads the kernel from its cache as an object file with no symbols that `perf`
can see, so this keeps that object file as numba loads it, records the samples of this
process while it traces the camera rays of SAMPLE (default carpenter_terrain) on one
thread, and prints the share of samples in each run of 16 instructions, with the
instructions of the hottest runs, and the share on push instructions (arguments a call
passes on the stack). With --walk it profiles the bounding walk
(trace/boxwalk.py, every instance once) instead, and lists the runs of the library
most samples fell in. Needs `perf` (Debian: linux-perf) and binutils.
"""
from __future__ import annotations

import argparse
import collections
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from numba.core.codegen import CPUCodeLibrary

import pcsg

sys.path.insert(0, str(Path(__file__).resolve().parent))

ROOT = Path(__file__).resolve().parent.parent
RUN = 16                    # instructions per reported run


def loaded_objects(action):
    """(library, object code) of every compiled library numba loads during action()."""
    seen = []
    original = CPUCodeLibrary._set_compiled_object

    def keep(self, value):
        seen.append((self, value))
        return original(self, value)

    CPUCodeLibrary._set_compiled_object = keep
    try:
        action()
    finally:
        CPUCodeLibrary._set_compiled_object = original
    return seen


def code_range(library, path: Path):
    """(runtime address, size) of the object file's code section as numba loaded it: the
    section is loaded in one piece, so a function's address less its offset in the file
    is the section's address (the walk is inlined into an unnamed part of it)."""
    out = subprocess.run(["nm", "--defined-only", str(path)], capture_output=True,
                         text=True, check=True).stdout
    engine = library._codegen._engine._ee
    base = None
    for line in out.splitlines():
        parts = line.split()
        if len(parts) == 3 and parts[1] == "T":
            address = engine.get_function_address(parts[2])
            if address:
                base = address - int(parts[0], 16)
                break
    sections = subprocess.run(["size", "-A", str(path)], capture_output=True, text=True,
                              check=True).stdout
    size = max(int(m.group(1)) for m in re.finditer(r"^\.l?text\s+(\d+)", sections, re.M))
    return base, size


def library_shares(ips, ranges) -> str:
    """The samples' shares by the library whose code they fall in. numba links a callee
    into each library that calls it, and the loader resolves every call of a shared
    helper to the copy loaded first: the expression machine (vm.eval_row) of the trace
    runs from the bounding walk's library, so it shows under that library's name."""
    shares = collections.Counter()
    for ip in (int(x, 16) for x in ips):
        shares[next((name for b, n, name in ranges if b <= ip < b + n), "other")] += 1
    return ", ".join(f"{name} {100 * c / max(len(ips), 1):.1f} %"
                     for name, c in shares.most_common())


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("sample", nargs="?", default="carpenter_terrain")
    ap.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--top", type=int, default=15)
    ap.add_argument("--size", default="640x480")
    ap.add_argument("--walk", action="store_true",
                    help="profile the bounding walk instead of the camera rays")
    args = ap.parse_args()
    if args.walk:
        # bounds kept on disk would spare pcsg.load the walk, whose code then loaded
        # outside `objects` below and showed as "other"
        os.environ["PCSG_BOUNDS_CACHE"] = "0"
    width, height = map(int, args.size.split("x"))
    overrides = {k: float(v) for k, v in (s.split("=") for s in args.set)}
    loaded = {}

    def prepare():
        # every import of pcsg.trace in here, so that `objects` has the libraries that
        # load at import (the expression machine's)
        from bench_trace import primary_rays
        # the load too: a helper that several compiled functions call (vm.eval_row) runs
        # from the copy in the library loaded first, the bounding walk's
        loaded["obj"] = obj = pcsg.load(ROOT / "grammars" / f"{args.sample}.pcsg",
                                        **overrides)
        _, loaded["o"], loaded["d"] = primary_rays(obj, width, height)
        obj.trace(loaded["o"][:64], loaded["d"][:64])

    objects = loaded_objects(prepare)
    obj, o, d = loaded["obj"], loaded["o"], loaded["d"]
    if not objects:
        sys.exit("numba compiled the kernel instead of loading it: run this once more")
    work = Path(tempfile.mkdtemp(prefix="pcsg-profile-"))
    ranges, paths = [], []      # (base, size, name) of every library loaded, its file
    for k, (library, code) in enumerate(sorted(objects, key=lambda x: -len(x[1]))):
        path = work / ("kernel.o" if k == 0 else f"lib{k}.o")
        path.write_bytes(code)
        lib_base, lib_size = code_range(library, path)
        if lib_base is not None:
            ranges.append((lib_base, lib_size, library.name))
            paths.append(path)
    if not ranges or ranges[0][2] != max(objects, key=lambda x: len(x[1]))[0].name:
        sys.exit("cannot find where numba loaded the kernel's code")
    from pcsg.trace import jit      # imported by prepare: its libraries are in `objects`
    jit.set_threads(1)
    if args.walk:
        from pcsg.trace.boxwalk import walk_boxes

        def action():
            walk_boxes(obj.graph, 64, instances=True)     # as Traced calls it
    else:
        def action():
            obj.trace(o, d)
    perf = subprocess.Popen(["perf", "record", "-q", "-F", "4000", "-o", str(work / "perf.data"),
                             "-p", str(os.getpid())],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    time.sleep(1.0)                                     # perf attaches
    start = time.perf_counter()
    for _ in range(args.repeat):
        action()
    seconds = (time.perf_counter() - start) / args.repeat
    perf.send_signal(signal.SIGINT)
    perf.wait()
    ips = subprocess.run(["perf", "script", "-i", str(work / "perf.data"), "-F", "ip"],
                         capture_output=True, text=True, check=True).stdout.split()
    # the listing: the kernel (the largest library), or for --walk the hottest
    k = 0
    if args.walk:
        k = max(range(len(ranges)), key=lambda i: sum(
            ranges[i][0] <= int(ip, 16) < ranges[i][0] + ranges[i][1] for ip in ips))
    base, size, _ = ranges[k]
    counts = collections.Counter(int(ip, 16) - base for ip in ips
                                 if 0 <= int(ip, 16) - base < size)
    asm = []
    dump = subprocess.run(["objdump", "-d", "--no-show-raw-insn", str(paths[k])],
                          capture_output=True, text=True, check=True).stdout
    for line in dump.splitlines():
        m = re.match(r"\s*([0-9a-f]+):\s+(.*)", line)
        if m:
            asm.append((int(m.group(1), 16), re.sub(r"<[^>]*>", "", m.group(2)).strip()))
    inside = sum(counts.values())
    what = "the bounding walk" if args.walk else f"{width}x{height}, a trace"
    print(f"{args.sample} {overrides or ''} {what}: {seconds:.3f} s on one thread; "
          f"{len(ips)} samples, {inside} in {ranges[k][2]}")
    print("by compiled function (its library): " + library_shares(ips, ranges))
    # a call that passes arrays by value pushes their fields one by one, hundreds of words
    # for the Flat: spread over many runs, it reads as a flat profile (session 72)
    pushed = sum(counts.get(a, 0) for a, ins in asm if ins.startswith("push"))
    print(f"on push instructions (a call's arguments on the stack): "
          f"{100 * pushed / max(inside, 1):.1f} %")
    runs = collections.Counter()
    for k, (a, _) in enumerate(asm):
        runs[k // RUN] += counts.get(a, 0)
    for k, c in runs.most_common(args.top):
        print(f"\n{100 * c / max(inside, 1):5.1f} % at {asm[k * RUN][0]:x}:")
        for a, ins in asm[k * RUN:(k + 1) * RUN]:
            share = 100 * counts.get(a, 0) / max(inside, 1)
            print(f"   {share:5.1f} {a:6x}  {ins}")


if __name__ == "__main__":
    main()
