"""pcsg against POV-Ray on the same objects, in one run.

    python tools/bench.py [--repeat 3] [--only sierpinski] [--out tools/bench_results.json]

For each workload, POV-Ray renders the scene `pcsg export --pov` wrote (exported
once into .bench/, kept between runs) and `pcsg render` renders the .pcsg file:
640x480, one ray per pixel, point lights with shadows, 2 threads, alternating
run by run. Prints a table (medians: whole-process wall time, trace-phase rays/s,
peak RSS in MiB, and the ratio POV-Ray/pcsg of wall times) and writes it as JSON with the
machine it came from. The deepest orders run with pcsg alone: POV-Ray cannot hold
their expansion.

Where tools/pov/ has a recursive macro for the object (MACROS), POV-Ray also renders that:
the object built the way a POV-Ray user writes it, the peer the issue measured, with the
exported scene's camera, lights and sky; the table gives its wall time, its ratio to pcsg's
and its peak RSS beside.

pcsg walks its bounds in every run of the table (PCSG_BOUNDS_CACHE=0). The workloads in
KEPT are also run with the bounds an earlier render kept on disk (graph/boxcache.py), as a
user's second render of the same system finds them: a row of their own, "bounds kept",
after one run that fills the cache and is not counted.
"""
from __future__ import annotations

import argparse
import importlib.metadata
import json
import os
import platform
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
WORK = ROOT / ".bench"
SIZE = (640, 480)
# (grammar, parameter, order, also POV-Ray[, pcsg's own options])
WORKLOADS = [
    ("sierpinski", "c", 6, True), ("sierpinski", "c", 8, True), ("sierpinski", "c", 10, True),
    ("sierpinski", "c", 16, False),
    ("sympodial_tree", "cnt", 11, True), ("sympodial_tree", "cnt", 14, True),
    ("sympodial_tree", "cnt", 15, True), ("sympodial_tree", "cnt", 20, False),
    ("carpenter_terrain", "cnt", 8, True), ("carpenter_terrain", "cnt", 9, True),
    # past the list: where POV-Ray's parse of the terrain's mesh grows past 10x
    ("carpenter_terrain", "cnt", 10, True),
    ("carpenter_terrain", "cnt", 12, False),      # in full: 213 million node visits
    # the budget before 2026-12-02, which stopped the bounding walk at depth 11
    ("carpenter_terrain", "cnt", 12, False, ("--bounds-budget", "60000000")),
]
COMMON = ["--shadow-samples", "1"]      # point lights: POV-Ray's light_source
KEPT = [("carpenter_terrain", "cnt", 8), ("carpenter_terrain", "cnt", 9),
        ("carpenter_terrain", "cnt", 12)]
# the objects written as POV-Ray recursive macros (tools/pov/), at the orders the issue's
# table measured them
MACROS = {("sierpinski", "c"): ("sierpinski.inc", (6, 8, 10)),
          ("sympodial_tree", "cnt"): ("sympodial_tree.inc", (11, 14, 15)),
          ("carpenter_terrain", "cnt"): ("carpenter_terrain.inc", (8, 9))}
# macros whose picture is not pcsg's: POV-Ray's language has no integer bit operations for
# the grammar's rand(seed), so the terrain macro's island is another, smaller one, and its
# trace rays/s are mostly of sea
OTHER_PICTURE = {"carpenter_terrain"}
WALK = {**os.environ, "PCSG_BOUNDS_CACHE": "0"}
KEEP = {**os.environ, "PCSG_BOUNDS_CACHE": "1"}


def run(cmd: list[str], timeout: float, env: dict | None = None) -> dict:
    """Wall time, peak RSS (this process alone, via wait4) and output of one command."""
    with tempfile.TemporaryFile("w+") as out:
        start = time.perf_counter()
        p = subprocess.Popen(cmd, stdout=out, stderr=subprocess.STDOUT, text=True, env=env)
        deadline = start + timeout
        while True:
            pid, status, usage = os.wait4(p.pid, os.WNOHANG)
            if pid:
                break
            if time.perf_counter() > deadline:
                p.kill()
                os.wait4(p.pid, 0)
                return {"wall": None, "rss_mb": None, "output": "", "timeout": timeout}
            time.sleep(0.005)
        wall = time.perf_counter() - start
        p.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        text = out.read()
    if p.returncode != 0:
        raise RuntimeError(f"exit {p.returncode}: {' '.join(cmd)}\n{text[-2000:]}")
    return {"wall": wall, "rss_mb": usage.ru_maxrss / 1024, "output": text}


def pcsg_cmd(workload: tuple, png: Path) -> list[str]:
    grammar, param, order = workload[:3]
    return [sys.executable, "-m", "pcsg.cli", "render", str(ROOT / "grammars" / f"{grammar}.pcsg"),
            "--set", f"{param}={order}", "-o", str(png), "--size", f"{SIZE[0]}x{SIZE[1]}",
            "--no-adaptive", "-q", *COMMON, *options(workload)]


def options(workload: tuple) -> tuple:
    return workload[4] if len(workload) > 4 else ()


def pcsg_result(r: dict) -> dict:
    if r["wall"] is None:
        return {"wall": None, "timed_out_s": r["timeout"]}
    m = re.search(r"([\d.]+) s, ([\d.]+) M rays/s", r["output"])
    # too many instances to bound: refined only to this derivation depth (a warning says so)
    cut = re.search(r"refinement stops there, as with --max-depth (\d+)", r["output"])
    return {"wall": r["wall"], "rss_mb": r["rss_mb"], "trace_s": float(m.group(1)),
            "rays_per_s": float(m.group(2)) * 1e6, "depth_bound": cut and int(cut.group(1))}


def pov_result(r: dict) -> dict:
    if r["wall"] is None:
        return {"wall": None, "timed_out_s": r["timeout"]}
    out = r["output"]

    def seconds(phase):
        m = re.search(phase + r" Time:.*\(([\d.]+) seconds\)", out)
        return float(m.group(1)) if m else 0.0

    rays = sum(int(x) for x in re.findall(r"(?:^Rays|Shadow Ray Tests):\s+(\d+)", out, re.M))
    trace = seconds("Trace")
    return {"wall": r["wall"], "rss_mb": r["rss_mb"], "parse_s": seconds("Parse"),
            "trace_s": trace, "rays_per_s": rays / trace if trace > 0 else None}


def export(grammar: str, param: str, order: int) -> Path:
    pov = WORK / f"{grammar}-{param}{order}.pov"
    if not pov.exists():
        print(f"exporting {pov.name} (once; kept in {WORK})", flush=True)
        subprocess.run([sys.executable, "-m", "pcsg.cli", "export",
                        str(ROOT / "grammars" / f"{grammar}.pcsg"), "--set", f"{param}={order}",
                        "--pov", str(pov), "--size", f"{SIZE[0]}x{SIZE[1]}", *COMMON],
                       check=True)
    return pov


def macro_scene(workload: tuple, exported: Path) -> Path | None:
    """The scene of `workload` built by its recursive macro (MACROS) in WORK; None where
    there is no macro for it."""
    grammar, param, order = workload[:3]
    inc, orders = MACROS.get((grammar, param), (None, ()))
    if order not in orders or options(workload):
        return None
    return write_macro_scene(inc, order, exported, WORK / f"{grammar}-{param}{order}-macros.pov")


def write_macro_scene(inc: str, order: int, exported: Path, out: Path) -> Path:
    """A scene at `out`: the camera, lights and sky of the exported scene (its lines
    before the first #declare), then tools/pov/`inc` at `order`."""
    header = []
    with open(exported) as f:
        for line in f:
            if line.startswith("#declare"):
                break
            header.append(line)
    out.write_text("".join(header) + f"#declare Order = {order};\n"
                   f'#include "{ROOT / "tools" / "pov" / inc}"\n')
    return out


def kernel_cache_state() -> str:
    """'warm' if kernels compiled from the sources as they are now are cached."""
    # importing pcsg.trace drops kernels compiled from older sources (trace/__init__.py)
    subprocess.run([sys.executable, "-c", "import pcsg.trace"], cwd=ROOT, check=True)
    cache = ROOT / "pcsg" / "trace" / "__pycache__"
    return "warm" if any(cache.glob("shading.shade_share-*.nbi")) else "cold"


def median(rows: list[dict], key: str):
    if any(r["wall"] is None for r in rows):
        return None                 # a timed-out run: no figure rather than a flattering one
    values = [r[key] for r in rows if r.get(key) is not None]
    return statistics.median(values) if values else None


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--only", help="workloads whose grammar name contains this")
    ap.add_argument("--out", default=str(ROOT / "tools" / "bench_results.json"))
    ap.add_argument("--timeout", type=float, default=300,
                    help="seconds per render; a render past it is reported as timed out")
    args = ap.parse_args()
    povray = shutil.which("povray")
    if povray is None:
        sys.exit("POV-Ray is not installed: apt-get install povray")
    pov_version = subprocess.run([povray, "--version"], capture_output=True, text=True).stderr
    pov_version = (re.search(r"POV-Ray ([\d.]+\S*)", pov_version) or [None, "?"])[1]
    WORK.mkdir(exist_ok=True)
    loads = [w for w in WORKLOADS if args.only is None or args.only in w[0]]
    povs = {w: export(*w[:3]) for w in loads if w[3]}
    macros = {w: m for w in povs if (m := macro_scene(w, povs[w])) is not None}

    # pcsg's modules as bytecode, as an installed package has them (tools/venv.sh)
    subprocess.run([sys.executable, "-m", "compileall", "-q", str(ROOT / "pcsg")], check=True)
    # the first pcsg start may compile the kernels: measured once, reported apart
    state = kernel_cache_state()
    first = run(pcsg_cmd(loads[0], WORK / "first.png"), args.timeout, WALK)
    results = {w: {"pcsg": [], "pov": [], "kept": [], "macros": []} for w in loads}
    kept = [w for w in loads if w[:3] in KEPT and not options(w)]
    for w in kept:
        print(f"filling the bounds cache: {w[0]} {w[1]}={w[2]}", flush=True)
        run(pcsg_cmd(w, WORK / "pcsg.png"), args.timeout, KEEP)
    for rep in range(args.repeat):
        for w in loads:
            print(f"run {rep + 1}/{args.repeat}: {w[0]} {w[1]}={w[2]} {' '.join(options(w))}",
                  flush=True)
            done = results[w]["pcsg"]
            if done and done[-1]["wall"] is None:
                continue                # timed out once: not again
            done.append(pcsg_result(run(pcsg_cmd(w, WORK / "pcsg.png"), args.timeout, WALK)))
            if w in kept:
                results[w]["kept"].append(
                    pcsg_result(run(pcsg_cmd(w, WORK / "pcsg.png"), args.timeout, KEEP)))
            for kind, scene in (("pov", povs.get(w)), ("macros", macros.get(w))):
                if scene and not (results[w][kind] and results[w][kind][-1]["wall"] is None):
                    results[w][kind].append(pov_result(run(
                        [povray, f"+I{scene}", f"+O{WORK / 'pov.png'}", f"+W{SIZE[0]}",
                         f"+H{SIZE[1]}", "-D", "-A", "+WT2"], args.timeout)))

    rows = []
    for w, runs, label in [(w, results[w]["pcsg"], "") for w in loads] + [
            (w, results[w]["kept"], ", bounds kept") for w in kept]:
        p, v = runs, results[w]["pov"]
        row = {"object": w[0], "order": " ".join([f"{w[1]}={w[2]}", *options(w)]) + label,
               **{f"pcsg_{k}": median(p, k) for k in ("wall", "trace_s", "rays_per_s", "rss_mb")},
               "pcsg_depth_bound": next((x.get("depth_bound") for x in p if x.get("depth_bound")),
                                        None)}
        peer(row, "pov", v, ("wall_ratio", "rays_ratio"))
        peer(row, "macros", results[w]["macros"], ("macros_ratio", "macros_rays_ratio"))
        rows.append(row)
    report = {
        "machine": f"{platform.machine()}, {os.cpu_count()} cores, "
                   f"{os.sysconf('SC_PHYS_PAGES') * os.sysconf('SC_PAGE_SIZE') / 2**30:.0f} GiB, "
                   f"{platform.platform()}",
        "python": platform.python_version(), "povray": pov_version,
        # the same code measured 15 % more memory on a later day's .venv: which versions ran
        "packages": {name: importlib.metadata.version(name)
                     for name in ("numpy", "numba", "llvmlite", "lark", "Pillow")},
        "commit": subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT,
                                 capture_output=True, text=True).stdout.strip(),
        "repeat": args.repeat, "size": f"{SIZE[0]}x{SIZE[1]}", "timeout_s": args.timeout,
        "kernel_cache_before_first_start": state,
        "first_start_wall_s": first["wall"],
        "date": time.strftime("%Y-%m-%d"),
        "rows": rows,
    }
    Path(args.out).write_text(json.dumps(report, indent=1) + "\n")
    print(table(report))


def peer(row: dict, name: str, runs: list, ratios: tuple[str, str]):
    """One POV-Ray peer's medians into row (name_wall, ...), with its whole-process ratio
    (POV-Ray over pcsg) and trace ratio (pcsg's rays/s over POV-Ray's) under `ratios`."""
    if not runs:
        return
    row.update({f"{name}_{k}": median(runs, k)
                for k in ("wall", "parse_s", "trace_s", "rays_per_s", "rss_mb")})
    wall, rays = row[f"{name}_wall"], row[f"{name}_rays_per_s"]
    row[ratios[0]] = wall / row["pcsg_wall"] if wall and row["pcsg_wall"] else None
    row[ratios[1]] = (row["pcsg_rays_per_s"] / rays
                      if rays and row["pcsg_rays_per_s"] else None)


def table(report: dict) -> str:
    def f(x, fmt, unit=""):
        return "—" if x is None else format(x, fmt) + unit
    lines = [f"{report['machine']}; POV-Ray {report['povray']}; medians of {report['repeat']} "
             f"runs; kernel cache {report['kernel_cache_before_first_start']} at the first "
             f"start ({report['first_start_wall_s']:.1f} s)", "",
             "| object | order | pcsg wall | POV-Ray wall | POV/pcsg | pcsg rays/s | "
             "POV-Ray rays/s | pcsg RSS | POV-Ray RSS | POV-Ray macros wall | macros/pcsg | "
             "macros rays/s | macros RSS |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in report["rows"]:
        def mega(x):
            return x and x / 1e6

        def other(r):
            return " M*" if r["object"] in OTHER_PICTURE else " M"
        cut = r.get("pcsg_depth_bound")
        lines.append(
            f"| {r['object']} | {r['order']}{f' (depth {cut})' if cut else ''} | "
            f"{f(r['pcsg_wall'], '.2f', ' s')} | "
            f"{f(r.get('pov_wall'), '.2f', ' s')} | {f(r.get('wall_ratio'), '.1f', 'x')} | "
            f"{f(mega(r['pcsg_rays_per_s']), '.2f', ' M')} | "
            f"{f(mega(r.get('pov_rays_per_s')), '.2f', ' M')} | "
            f"{f(r['pcsg_rss_mb'], '.0f', ' MiB')} | {f(r.get('pov_rss_mb'), '.0f', ' MiB')} | "
            f"{f(r.get('macros_wall'), '.2f', ' s')} | {f(r.get('macros_ratio'), '.1f', 'x')} | "
            f"{f(mega(r.get('macros_rays_per_s')), '.2f', other(r))} | "
            f"{f(r.get('macros_rss_mb'), '.0f', ' MiB')} |")
    lines.append("")
    lines.append(f"— : not run, or past the {report['timeout_s']:.0f} s timeout; (depth N): "
                 f"too many instances to bound, refined to derivation depth N only; "
                 f"*: the macro's picture is another than pcsg's (OTHER_PICTURE)")
    return "\n".join(lines)


if __name__ == "__main__":
    main()
