"""What tracing glass of overlapping parts as one solid costs (graph/solidglass.py): renders
each file with the pass and with an identity in its place, alternating, in one process
(the kernels loaded once), and prints the median whole render of each.

    python tools/ab_glass.py [FILE ...] [--rounds 5] [--size 320x240]

Without files, the two scenes in tools/glass/: two overlapping glass balls on a slab, and
two glass balls given operand by operand beside a recursive checkerboard floor."""
from __future__ import annotations

import argparse
import contextlib
import io
import statistics
import tempfile
import time
from pathlib import Path

import pcsg.tracer as tracer
from pcsg.cli import main as pcsg

SCENES = sorted((Path(__file__).parent / "glass").glob("*.pcsg"))


def run(files: list[Path], rounds: int, size: str) -> None:
    with_pass = tracer.glass_unions_as_solids
    with tempfile.TemporaryDirectory() as out:
        for f in files:
            times: dict[str, list[float]] = {"solid": [], "off": []}
            for _ in range(rounds):
                for mode in times:
                    tracer.glass_unions_as_solids = with_pass if mode == "solid" else (
                        lambda graph: graph)
                    start = time.perf_counter()
                    with contextlib.redirect_stdout(io.StringIO()):      # its summary line
                        pcsg(["render", str(f), "--size", size, "-q", "-o",
                              f"{out}/{mode}.png"])
                    times[mode].append(time.perf_counter() - start)
            solid, off = (statistics.median(times[m]) for m in ("solid", "off"))
            print(f"{f.name}: {solid:.3f} s as one solid, {off:.3f} s with the pass off "
                  f"({solid / off:.2f}x), medians of {rounds}")
    tracer.glass_unions_as_solids = with_pass


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("files", nargs="*", type=Path)
    p.add_argument("--rounds", type=int, default=5)
    p.add_argument("--size", default="320x240")
    a = p.parse_args()
    run(a.files or SCENES, a.rounds, a.size)
