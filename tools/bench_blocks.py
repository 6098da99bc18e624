"""Compiled calculation blocks (trace/native.py) against the expression machine.

    python tools/bench_blocks.py [SAMPLE] [--set NAME=VALUE] [--runs 1000000] [--rounds 5]

For every block of SAMPLE (default carpenter_terrain, order 9) that is compiled: the
time of one run of it, compiled and on the machine (best of --rounds, each --runs runs
in one compiled loop); then the bounding walk of the whole system (walk_boxes, on every
core) with the blocks compiled and on the machine, alternating, medians of --rounds.
"""
from __future__ import annotations

import argparse
import os
import statistics
import time
from pathlib import Path

import numpy as np
from numba import njit

ROOT = Path(__file__).resolve().parent.parent


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("sample", nargs="?", default="carpenter_terrain")
    ap.add_argument("--set", action="append", default=None, metavar="NAME=VALUE")
    ap.add_argument("--runs", type=int, default=1_000_000)
    ap.add_argument("--rounds", type=int, default=5)
    args = ap.parse_args()
    sets = args.set if args.set is not None else (
        ["cnt=9"] if args.sample == "carpenter_terrain" else [])
    overrides = {k: float(v) for k, v in (s.split("=") for s in sets)}

    from pcsg.compiler import compile_file
    from pcsg.graph.flat import flatten_graph
    from pcsg.trace import native, vm
    from pcsg.trace.boxwalk import walk_boxes

    @njit(cache=True)
    def compiled(address, block, params, consts, runs):
        for i in range(runs):
            for p in range(params.shape[1]):
                params[1, p] = params[0, p]
            native.call_block(address, params, 1, consts, np.uint64(i), block)
        return params[1, 0]

    @njit(cache=True)
    def machine(code, consts, start, end, params, stack, runs):
        for i in range(runs):
            for p in range(params.shape[1]):
                params[1, p] = params[0, p]
            vm.eval_row(code, consts, start, end, params, 1, np.uint64(i), -1, stack)
        return params[1, 0]

    graph = compile_file(ROOT / "grammars" / f"{args.sample}.pcsg", overrides)
    flat = flatten_graph(graph, np.zeros((len(graph.nodes), 6)))
    params = np.full((2, flat.n_params), 0.5)
    stack = np.zeros(flat.max_stack)

    def best(fn):
        fn(10)
        times = []
        for _ in range(args.rounds):
            t = time.perf_counter()
            fn(args.runs)
            times.append(time.perf_counter() - t)
        return min(times) / args.runs * 1e9

    nodes = np.flatnonzero(flat.calc_fn)
    if not len(nodes):
        print(f"{args.sample}: no block is compiled (blocks of {native.MIN_ROWS} rows or more "
              "without jumps are)")
    for node in nodes:
        s, e = int(flat.calc_start[node]), int(flat.calc_end[node])
        on = best(lambda n: compiled(flat.calc_fn[node], flat.block_no[node], params,
                                     flat.vm_consts, n))
        off = best(lambda n: machine(flat.vm_code, flat.vm_consts, s, e, params, stack, n))
        print(f"block of node {node} ({e - s} rows): {on:.0f} ns compiled, {off:.0f} ns on "
              f"the machine ({off / on:.1f}x)")

    walks = {"compiled": [], "machine": []}
    for r in range(args.rounds + 1):            # the first round loads what it needs
        for mode, switch in (("compiled", "1"), ("machine", "0")):
            os.environ["PCSG_NATIVE"] = switch
            t = time.perf_counter()
            walk_boxes(graph, 64, instances=True)
            if r:
                walks[mode].append(time.perf_counter() - t)
    on, off = (statistics.median(walks[m]) for m in ("compiled", "machine"))
    print(f"bounding walk of {args.sample} {overrides}: {on:.3f} s with the blocks compiled, "
          f"{off:.3f} s on the machine ({off / on:.2f}x; medians of {args.rounds}, "
          "alternating)")


if __name__ == "__main__":
    main()
