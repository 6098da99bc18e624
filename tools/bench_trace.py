"""Primary-ray throughput of the graph tracer on the samples, after compilation.

    python tools/bench_trace.py [--size 640x480] [--repeat 3] [--lod]

Prints rays/s per sample (best of --repeat runs) on all threads and on one thread
(per core), and the machine.
"""
from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

import numpy as np

import pcsg
from pcsg.trace import jit
from pcsg.render.camera import make_camera
from pcsg.render.image import tile_order

ROOT = Path(__file__).resolve().parent.parent
SAMPLES = ["sierpinski", "sympodial_tree", "carpenter_terrain"]


def primary_rays(obj, width, height):
    """In the order a render traces them: block after block (image.tile_order)."""
    cam = make_camera(obj, width / height)
    ys, xs = np.mgrid[0:height, 0:width]
    order = tile_order(height, width)
    return cam, *cam.rays(width, height, xs.ravel()[order] + 0.5, ys.ravel()[order] + 0.5)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="640x480")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--lod", action="store_true", help="with the pixel-size level of detail")
    ap.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    args = ap.parse_args()
    width, height = map(int, args.size.split("x"))
    overrides = {k: float(v) for k, v in (s.split("=") for s in args.set)}
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"python {platform.python_version()}")
    for name in SAMPLES:
        path = ROOT / "grammars" / f"{name}.pcsg"
        t = time.perf_counter()
        obj = pcsg.load(path, **{k: v for k, v in overrides.items()})
        prep = time.perf_counter() - t
        cam, o, d = primary_rays(obj, width, height)
        lod = cam.pixel_angle(height) if args.lod else 0.0
        h = obj.trace(o, d, lod=lod)                  # compile (or load the cache)
        threads = jit.threads()
        best = {}
        for n in (threads, 1):
            jit.set_threads(n)
            best[n] = min(timed(obj, o, d, lod) for _ in range(args.repeat))
        jit.set_threads(threads)
        print(f"{name:20s} {width}x{height}: {len(o) / best[threads] / 1e6:6.2f} M rays/s "
              f"on {threads} threads, {len(o) / best[1] / 1e6:5.2f} M on 1 "
              f"({h.hit.mean():.0%} hit; load+bounds {prep:.2f} s, "
              f"bounds {obj.bounds_method})")


def timed(obj, o, d, lod):
    t = time.perf_counter()
    obj.trace(o, d, lod=lod)
    return time.perf_counter() - t


if __name__ == "__main__":
    main()
