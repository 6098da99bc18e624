"""Two versions of pcsg against each other: the render and bounds phases and the whole
process (--timings' total; with --phases every phase, start-up's too) of fresh `pcsg
render --timings` processes, alternating which goes first in every round (a fixed order biases in-process comparisons by several per
cent, see tools/performance_notes.md), medians, and whether the PNGs are the same bytes.

    git worktree add /tmp/before HEAD~1
    (cd /tmp && PYTHONPATH=/tmp/before python -m pcsg.cli render ...)   # compile its kernels
    python tools/ab.py /tmp/before . --rounds 8 carpenter_terrain:cnt=9 sierpinski:c=8
A load is a sample's name or a .pcsg path (from the repository's root), and its --set if any;
--options adds render options to every render (after the bench's, which they override):
    python tools/ab.py /tmp/before . tests/data/bush_uscale.pcsg:d=12 \
        --options "--size 160x120 --eye 5,-6,3 --at 0,0,1.8"

More versions at once (their order turning every round), renders only, with the bounds
kept on disk after each version's first walk:
    python tools/ab.py /tmp/s61 . --also /tmp/mid --keep-bounds carpenter_terrain:cnt=12
(/tmp/mid is compared with A as B is.)

Each version runs from its own source tree (PYTHONPATH, from /tmp so that neither tree's
working directory shadows it), with its own kernel cache; compile both before timing.
"""
from __future__ import annotations

import argparse
import hashlib
import os
import re
import shlex
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


BENCH = ["--no-adaptive", "--shadow-samples", "1"]    # bench.py's: a ray a pixel, point lights


def grammar_path(grammar: str) -> Path:
    """A sample's name, or a .pcsg file's path from the repository's root."""
    return ROOT / grammar if grammar.endswith(".pcsg") else ROOT / "grammars" / f"{grammar}.pcsg"


def render(tree: Path, grammar: str, setting: str, png: Path,
           look: list[str] = BENCH, keep_bounds: bool = False) -> tuple[dict, str]:
    """({phase: s} of --timings, PNG digest) of one fresh process of the pcsg in `tree`."""
    # the bounds walked in every process: kept ones would time a file read (graph/boxcache.py)
    env = dict(os.environ, PYTHONPATH=str(tree), PCSG_BOUNDS_CACHE="1" if keep_bounds else "0")
    out = subprocess.run([sys.executable, "-m", "pcsg.cli", "render",
                          str(grammar_path(grammar)), *(("--set", setting) if setting else ()),
                          "--size", "640x480", *look, "--timings", "-q", "-o", str(png)],
                         cwd=tempfile.gettempdir(), env=env, capture_output=True, text=True)
    if out.returncode != 0:
        raise SystemExit(f"{tree}: {grammar} {setting}: exit {out.returncode}\n{out.stderr}")
    phases = {name: float(s) for name, s in re.findall(r"^\s+(\w+)\s+([\d.]+) s", out.stderr,
                                                        re.M)}
    return phases, hashlib.sha256(png.read_bytes()).hexdigest()


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("a", type=Path, help="the source tree of version A (before)")
    ap.add_argument("b", type=Path, help="the source tree of version B (after)")
    ap.add_argument("loads", nargs="+", metavar="GRAMMAR:NAME=VALUE",
                    help="a sample's name or a .pcsg path, and one --set")
    ap.add_argument("--also", type=Path, action="append", default=[], metavar="TREE",
                    help="a further version, compared with A as B is (repeatable); the "
                         "order of the versions turns by one every round")
    ap.add_argument("--keep-bounds", action="store_true",
                    help="the bounds kept on disk after each version's first walk: compares "
                         "renders of systems whose walk takes long (the terrain at 12) in a "
                         "fraction of the time; bounds and totals then time a file read")
    ap.add_argument("--rounds", type=int, default=6)
    ap.add_argument("--phases", action="store_true",
                    help="also every phase of --timings (interpreter, imports, compile, ...)")
    ap.add_argument("--user-defaults", action="store_true",
                    help="render with the command's own defaults (adaptive oversampling, "
                         "area lights' shadow samples), not bench.py's " + " ".join(BENCH))
    ap.add_argument("--options", default="", help="render options added to every render, as "
                    "one string: \"--size 160x120 --eye 5,-6,3\"")
    args = ap.parse_args()
    look = ([] if args.user_defaults else BENCH) + shlex.split(args.options)
    trees = tuple(t.resolve() for t in (args.a, args.b, *args.also))
    if len(set(trees)) < len(trees):
        ap.error("a version is given twice (their samples would be pooled)")
    # both trees' modules as bytecode, as bench.py has them: where PYTHONDONTWRITEBYTECODE
    # is set (this machine), a tree without them compiled its sources at every start, and
    # its imports took 0.04 s longer than the other's
    for t in trees:
        subprocess.run([sys.executable, "-m", "compileall", "-q", str(t / "pcsg")], check=True)
    with tempfile.TemporaryDirectory() as tmp:
        for load in args.loads:
            grammar, _, setting = load.partition(":")     # a sample as its file has it
            phases = {t: {} for t in trees}
            digests = {}
            if args.keep_bounds:        # each version's walk, kept before the first round
                for t in trees:
                    render(t, grammar, setting, Path(tmp) / "fill.png", look, True)
            for i in range(args.rounds):
                k = i % len(trees)         # with two versions: each goes first every other round
                for t in trees[k:] + trees[:k]:
                    times, d = render(t, grammar, setting, Path(tmp) / f"{trees.index(t)}.png",
                                      look, args.keep_bounds)
                    for name, seconds in times.items():
                        phases[t].setdefault(name, []).append(seconds)
                    digests.setdefault(t, set()).add(d)

            def median(t, name):
                return statistics.median(phases[t].get(name, [0.0]))
            for other in trees[1:]:
                pair = (trees[0], other)
                a, b = (median(t, "render") for t in pair)
                ba, bb = (median(t, "bounds") for t in pair)
                wa, wb = (median(t, "total") for t in pair)
                same = len(digests[pair[0]] | digests[pair[1]]) == 1
                name = "B" if other == trees[1] else other.name
                print(f"{grammar} {setting}: render A {a:.4f} s, {name} {b:.4f} s "
                      f"({name}/A {b / a:.3f}); bounds A {ba:.3f} s, {name} {bb:.3f} s; total "
                      f"A {wa:.3f} s, {name} {wb:.3f} s ({name}/A {wb / wa:.3f}); same PNG "
                      f"bytes: {same}", flush=True)
            for other in trees[1:] if args.phases else ():
                name = "B" if other == trees[1] else other.name
                print(f"  phases of {name} against A:")
                for phase in phases[trees[0]]:
                    pa, pb = median(trees[0], phase), median(other, phase)
                    print(f"  {phase:12s} A {1000 * pa:8.1f} ms  {name} {1000 * pb:8.1f} ms  "
                          f"{name}-A {1000 * (pb - pa):+7.1f} ms", flush=True)

if __name__ == "__main__":
    main()
