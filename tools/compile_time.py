"""How long the kernels take to compile from a cold cache, and which ones cost.

    python tools/compile_time.py [--min 1.0]

Runs a trace and then a small render in a child process whose numba cache is an empty
directory (so nothing is loaded, everything compiles), and prints every function numba
compiled for longer than --min seconds, in the order the compiles ended: a function
follows the ones its compile started, which are indented one step deeper. Then the two
totals. A function listed twice was compiled for two signatures.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def child(threshold: float) -> None:
    from numba.core import event

    import numpy as np

    started: list[tuple[str, float]] = []
    done: list[tuple[int, str, float]] = []

    class Timer(event.Listener):
        def on_start(self, ev):
            started.append((ev.data["dispatcher"].py_func.__qualname__, time.perf_counter()))

        def on_end(self, ev):
            name, t = started.pop()
            done.append((len(started), name, time.perf_counter() - t))

    event.register("numba:compile", Timer())
    import pcsg
    from pcsg.cli import main

    sample = ROOT / "grammars" / "sierpinski.pcsg"
    obj = pcsg.load(sample)
    o = np.tile([0.0, 0.0, 5.0], (4, 1))
    d = np.tile([0.0, 0.0, -1.0], (4, 1))
    t = time.perf_counter()
    obj.trace(o, d)
    traced = time.perf_counter() - t
    with tempfile.TemporaryDirectory() as out:
        t = time.perf_counter()
        main(["render", str(sample), "--size", "32x24", "-q", "-o", str(Path(out) / "x.png")])
        rendered = time.perf_counter() - t
    for depth, name, seconds in done:
        if seconds >= threshold:
            print(f"{'  ' * depth}{name} {seconds:.1f} s")
    print(f"trace (bounds and the tracing kernels): {traced:.1f} s")
    print(f"render (the shading kernel and the rest): {rendered:.1f} s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--min", type=float, default=1.0, help="seconds below which to stay quiet")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(args.min)
        return
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache,
               "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
        subprocess.run([sys.executable, __file__, "--child", "--min", str(args.min)],
                       env=env, cwd=ROOT, check=True)


if __name__ == "__main__":
    main()
