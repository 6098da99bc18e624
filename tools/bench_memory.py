"""Peak memory of tracing a sample at several orders: the graph is never expanded,
so memory should not grow with the order.

    python tools/bench_memory.py [--name sierpinski] [--param c] [--orders 6,10,16]
"""
from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CHILD = """
import resource, time, numpy as np, pcsg
from pcsg.render.camera import make_camera
obj = pcsg.load({path!r}, **{{{param!r}: {order}}})
cam = make_camera(obj, 4 / 3)
ys, xs = np.mgrid[0:480, 0:640]
o, d = cam.rays(640, 480, xs.ravel() + 0.5, ys.ravel() + 0.5)
t = time.perf_counter()
h = obj.trace(o, d, lod=cam.pixel_angle(480))
dt = time.perf_counter() - t
print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, dt, h.hit.mean())
"""


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--name", default="sierpinski")
    ap.add_argument("--param", default="c")
    ap.add_argument("--orders", default="6,10,16")
    args = ap.parse_args()
    path = str(ROOT / "grammars" / f"{args.name}.pcsg")
    for order in args.orders.split(","):
        code = CHILD.format(path=path, param=args.param, order=int(order))
        r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
        if r.returncode:
            print(f"{args.param}={order}: failed: {r.stderr.strip().splitlines()[-1]}")
            continue
        rss, dt, hit = map(float, r.stdout.split())
        print(f"{args.name} {args.param}={order}: peak RSS {rss:.0f} MB, 640x480 primary rays "
              f"with level of detail in {dt:.2f} s ({hit:.0%} hit)")


if __name__ == "__main__":
    main()
