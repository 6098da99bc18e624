"""The `pcsg` command's arguments: a parser per subcommand, and the options they share."""
from __future__ import annotations

import argparse
import re
import sys

from . import __version__
from .distributed.sweep import sweep_set
from .overrides import set_value
from .limits import (BOUNDS_BUDGET, DEEPEST_DEFAULT, INTERVAL_ROWS, MAX_BOUNCES, MAX_DEPTH,
                     MAX_DEPTH_ASKED, MAX_FRAMES, MAX_INSTANCES, MAX_INTERVAL_ROWS,
                     MAX_SAMPLES, MAX_SHADOW_SAMPLES, MAX_STACK_DEPTH)
from .scene import DEFAULT_FOV, MIN_FOV


# a token such as -3,2,1 or -.5: a value, never an option. argparse reads only -3 or -0.5
# as numbers and took `--eye -3,2,1` for an option, "expected one argument"; no option of
# ours starts with a digit
NEGATIVE = re.compile(r"-\.?\d")


class Parser(argparse.ArgumentParser):
    """argparse's parser, with negative vectors and sizes read as values. Its sub-command
    parsers are of this class too (add_subparsers makes them of the parent's type)."""

    def parse_args(self, args=None, namespace=None):
        """An unknown option is said by its command's parser, with that command's usage:
        `pcsg sweep ... --timings` printed the top level's "usage: pcsg COMMAND ..."."""
        given = list(sys.argv[1:] if args is None else args)
        args, extra = self.parse_known_args(given, namespace)
        if extra and isinstance(getattr(args, "files", None), list) and not any(
                x.startswith("-") and not NEGATIVE.match(x) for x in extra):
            # files after options (`pcsg render a.pcsg --size 64x48 b.pcsg`): argparse
            # takes a list of positionals in one run, and called b.pcsg unrecognized
            args.files += extra
            extra = []
        if extra:
            name = getattr(args, "command", None)
            command = getattr(self, "commands", {}).get(name, self)
            if name in given and extra[0] in given and given.index(extra[0]) < given.index(name):
                command = self          # `pcsg --bogus check ...`: before the command
            command.error(f"unrecognized arguments: {' '.join(extra)}")
        return args

    def _parse_optional(self, arg_string):
        if NEGATIVE.match(arg_string):
            return None
        return super()._parse_optional(arg_string)


def parser() -> argparse.ArgumentParser:
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--set", dest="overrides", metavar="NAME=VALUE", action="append",
                        type=set_value, default=[],
                        help="override an initial parameter of the axiom (repeatable)")
    common.add_argument("--no-color", action="store_true", help=argparse.SUPPRESS)

    p = Parser(prog="pcsg", description="Compile and inspect PCSG grammars: "
                                "parametric CSG rewriting systems as cyclic CSG graphs.")
    p.add_argument("--version", action="version", version=f"pcsg {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    p.commands = sub.choices

    c = sub.add_parser("check", parents=[common], help="check files; errors as file:line:col")
    c.add_argument("files", nargs="+", metavar="FILE")
    c.add_argument("-q", "--quiet", action="store_true", help="print only errors and warnings")
    c.add_argument("--werror", action="store_true", help="treat warnings as errors")

    e = sub.add_parser("expand", parents=[common],
                       help="the axiom after N parallel derivation steps, as PCSG text")
    e.add_argument("file", metavar="FILE")
    e.add_argument("-n", "--steps", type=int, default=1, help="derivation steps (default 1)")
    e.add_argument("-o", "--output", metavar="OUT", help="write to OUT instead of stdout")
    e.add_argument("--max-chars", type=int, default=None,
                   help="refuse expansions longer than this (default: what pcsg reads "
                        "back, 8 MiB)")

    s = sub.add_parser("stats", parents=[common], help="node, module and primitive counts")
    s.add_argument("files", nargs="+", metavar="FILE")
    s.add_argument("--json", action="store_true", help="machine-readable output")

    looks = render_options()
    r = sub.add_parser("render", parents=[common, looks], help="ray trace files to PNG images")
    r.add_argument("files", nargs="+", metavar="FILE")
    r.add_argument("-o", "--output", metavar="OUT",
                   help="the PNG (one file) or a directory (default: NAME.png here)")
    r.add_argument("--depth", metavar="FILE.npy", help="also write float32 hit distances")
    r.add_argument("--timings", action="store_true",
                   help="print where each file's time went: start-up, compile, bounds, "
                        "render, PNG")
    cluster_arguments(r)

    w = sub.add_parser("sweep", parents=[looks],
                       help="one image per value of a parameter (--set c=1..12)")
    w.add_argument("file", metavar="FILE")
    w.add_argument("--set", dest="overrides", metavar="NAME=A..B[..STEP]", action="append",
                   type=sweep_set, default=[],
                   help="the parameter to sweep (integers, B included where the steps reach "
                        "it); more --set NAME=VALUE fix other parameters")
    w.add_argument("-o", "--output", metavar="DIR", default=".",
                   help="the directory for FILE_NAME=VALUE.png (default: here)")
    w.add_argument("--no-color", action="store_true", help=argparse.SUPPRESS)
    cluster_arguments(w)

    a = sub.add_parser("animate", parents=[common, looks],
                       help="frames over time t and a camera path, to PNGs and an animation")
    a.add_argument("file", metavar="FILE")
    a.add_argument("--frames", type=int, default=24, metavar="N",
                   help=f"frames; frame i sets t = i/(N-1) (default 24, at most "
                        f"{MAX_FRAMES:,})")
    a.add_argument("--path", type=_points, metavar="'X,Y,Z X,Y,Z ...'",
                   help="the eye's path: a Bezier control polygon from t = 0 to 1")
    a.add_argument("--at-path", type=_points, metavar="'X,Y,Z X,Y,Z ...'",
                   help="the path of the point looked at, likewise")
    a.add_argument("-o", "--output", metavar="DIR",
                   help="directory for frame_0000.png ... and NAME.png, the animated PNG "
                        "(default: NAME_frames here)")
    a.add_argument("--fps", type=float, default=10.0, help="frames per second (default 10)")
    a.add_argument("--gif", action="store_true", help="also write NAME.gif")
    a.add_argument("-j", "--jobs", type=int, metavar="N",
                   help="frames rendered at once, each in its own process (default: one "
                        "per core)")
    cluster_arguments(a, tiles=False)

    x = sub.add_parser("export", parents=[common],
                       help="the expanded derivation as a POV-Ray scene (small and medium orders)")
    x.add_argument("file", metavar="FILE")
    x.add_argument("--pov", required=True, metavar="OUT.pov", help="the POV-Ray scene to write")
    x.add_argument("--size", type=_size, default=(640, 480), metavar="WxH",
                   help="the image size the camera is framed for (default 640x480)")
    view_arguments(x)
    x.add_argument("--shadow-samples", type=int, default=8, metavar="N",
                   help="1: lights are points; more: area lights stay area lights")
    x.add_argument("--no-shadows", action="store_true", help="lights cast no shadows")
    x.add_argument("--force", action="store_true",
                   help="write a scene past 20 million primitives (POV-Ray holds about a "
                        "million in a GB of memory)")
    x.add_argument("--bounces", type=int, default=3, metavar="N",
                   help="reflection and refraction depth (default 3)")
    x.add_argument("--max-depth", type=int, metavar="N",
                   help="end the derivation where `pcsg render --max-depth N` does: deeper "
                        "selections take their terminating rule, and a graftal's instances "
                        "become their bounding boxes (default: derive to the end; a graftal "
                        "needs it)")
    x.add_argument("-q", "--quiet", action="store_true", help="no progress line")

    g = sub.add_parser("graph", parents=[common], help="the cyclic CSG graph as Graphviz dot")
    g.add_argument("file", metavar="FILE")
    g.add_argument("-o", "--output", metavar="OUT", help="write to OUT instead of stdout")
    return p


def view_arguments(r: argparse.ArgumentParser):
    """The camera and the light, over the file's #camera and #light: render's and export's."""
    r.add_argument("--eye", type=_vec, metavar="X,Y,Z", help="camera position")
    r.add_argument("--at", type=_vec, metavar="X,Y,Z", help="point looked at")
    r.add_argument("--up", type=_vec, metavar="X,Y,Z", help="up direction (default 0,0,1)")
    r.add_argument("--fov", type=float, metavar="DEG",
                   help=f"vertical field of view, {MIN_FOV:g} to under 180 (default: the "
                        f"file's #camera fov, else {DEFAULT_FOV:g})")
    r.add_argument("--light", type=_vec, metavar="X,Y,Z",
                   help="one point light at X,Y,Z instead of the file's #light lines (default: "
                        "those, else a sun above and to the left of the camera)")


def render_options() -> argparse.ArgumentParser:
    """What a picture looks like and how it is traced: shared by render, sweep and animate."""
    r = argparse.ArgumentParser(add_help=False)
    r.add_argument("--size", type=_size, default=(640, 480), metavar="WxH",
                   help="image size (default 640x480)")
    r.add_argument("--samples", type=int, default=1, metavar="N",
                   help=f"stratified jittered samples per pixel, 1 to {MAX_SAMPLES} (default 1, "
                        f"with adaptive oversampling where neighbouring pixels differ)")
    view_arguments(r)
    r.add_argument("--alpha", action="store_true", help="transparent background")
    r.add_argument("--max-depth", type=int, metavar="N",
                   help=f"derivation levels a ray may descend, 1 to {MAX_DEPTH_ASKED:,} "
                        f"(default: the derivation's "
                        f"own depth where it ends within {DEEPEST_DEFAULT:,} levels and is "
                        f"bounded by its states, not instance by instance; else {MAX_DEPTH})")
    r.add_argument("--stack-depth", type=int, metavar="N",
                   help=f"frames of a ray's walk, 16 to {MAX_STACK_DEPTH:,} (default: from "
                        f"--max-depth and the widest union); raise it when a render reports a "
                        f"full walk stack")
    r.add_argument("--interval-rows", type=int, default=INTERVAL_ROWS, metavar="N",
                   help=f"interval-list rows per worker for ∩ and \\ subtrees, 16 to "
                        f"{MAX_INTERVAL_ROWS:,} (default {INTERVAL_ROWS}); raise it when a "
                        f"render reports full interval lists")
    r.add_argument("--max-instances", type=int, default=MAX_INSTANCES, metavar="N",
                   help=f"S-node instances one ray may enter (default {MAX_INSTANCES:,}); "
                        "bounds systems that neither end nor contract")
    r.add_argument("--bounds-budget", type=int, default=BOUNDS_BUDGET, metavar="N",
                   help=f"node visits the bounding walk may make (default {BOUNDS_BUDGET:,}, "
                        "11 to 13 s on two cores); past it the boxes, and the refinement, "
                        "stop at the deepest derivation depth whose instances fit")
    r.add_argument("--no-shadows", action="store_true", help="skip shadow rays")
    r.add_argument("--shadow-samples", type=int, default=8, metavar="N",
                   help=f"shadow rays per area light, 1 to {MAX_SHADOW_SAMPLES} (default 8; 1: "
                        f"lights are points)")
    r.add_argument("--no-adaptive", action="store_true",
                   help="exactly --samples rays per pixel, no adaptive oversampling")
    r.add_argument("--strict", action="store_true",
                   help="runtime errors in the grammar (invalid selections, non-finite or "
                        "singular transformations) and full walk buffers fail the file instead "
                        "of emptying instances")
    r.add_argument("--timeout", type=float, metavar="SECONDS",
                   help="stop an image's render after this long, writing nothing")
    r.add_argument("--bounces", type=int, default=3, metavar="N",
                   help=f"reflection and refraction depth, 0 (off) to {MAX_BOUNCES} (default 3)")
    r.add_argument("--ao", type=int, metavar="N",
                   help="ambient occlusion: N hemisphere rays per shading point (default: "
                        "the file's #occlusion, else 0: off)")
    r.add_argument("--ao-distance", type=float, metavar="D",
                   help="occluders farther than D do not darken (default: the file's "
                        "#occlusion, else 15%% of the object's box diagonal)")
    r.add_argument("--reference", action="store_true",
                   help="trace the fully expanded system instead (small orders; for checking)")
    r.add_argument("--threads", type=int, metavar="N",
                   help="the tracer's threads in this process, at most the cores (default: "
                        "every core; animate: each frame process's share); the bytes do "
                        "not depend on N")
    r.add_argument("-q", "--quiet", action="store_true", help="no progress lines")
    return r


def cluster_arguments(r: argparse.ArgumentParser, tiles: bool = True):
    """--workers, --scheduler, --tiles, --force: for any command that renders a batch
    through pcsg.distributed.batch.run_jobs (animate sends whole frames: no --tiles)."""
    c = r.add_argument_group("across processes and machines (needs Dask: pip install '/path/to/pcsg[dask]')")
    c.add_argument("--workers", type=int, metavar="N",
                   help="render on a local Dask cluster of N worker processes")
    c.add_argument("--scheduler", metavar="ADDRESS", type=_scheduler,
                   help="render on an existing Dask cluster, e.g. tcp://10.0.0.5:8786")
    if tiles:
        c.add_argument("--tiles", type=int, default=1, metavar="N",
                       help="split each image into N bands of rows, rendered apart (on the "
                            "cluster's workers, or here one after another) and assembled into "
                            "the same PNG bytes")
    c.add_argument("--force", action="store_true",
                   help="render again outputs that a cluster batch, a sweep or an animation "
                        "would skip as already complete")


SCHEMES = ("tcp", "tls", "ws", "wss", "ucx")     # dask's, but inproc: no other process's


def _scheduler(text: str) -> str:
    """A Dask scheduler's address, [SCHEME://]HOST:PORT, checked before dask is imported:
    dask's own parse raised ValueErrors that came out as internal errors."""
    scheme, sep, rest = text.partition("://")
    if not sep:
        scheme, rest = "tcp", text
    host, colon, port = rest.rpartition(":")
    host = host[1:-1] if host.startswith("[") and host.endswith("]") else host   # IPv6
    if scheme not in SCHEMES or not colon or not host or "/" in rest \
            or not port.isdigit() or not 1 <= int(port) <= 65535:
        raise argparse.ArgumentTypeError(
            f"expected a Dask scheduler's address, e.g. tcp://10.0.0.5:8786 "
            f"({'|'.join(SCHEMES)}://HOST:PORT), got '{text}'")
    return text


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = text.lower().split("x")
        return int(w), int(h)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT, e.g. 640x480, got '{text}'") \
            from None


def _vec(text: str) -> tuple[float, float, float]:
    try:
        x, y, z = (float(v) for v in text.split(","))
        return x, y, z
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected X,Y,Z, e.g. 3,-4,2, got '{text}'") from None


def _points(text: str):
    from .render.path import parse_points
    try:
        return parse_points(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None
