"""`pcsg sweep FILE --set c=1..12`: one image per value of one parameter."""
from __future__ import annotations

import argparse
import re
from pathlib import Path

from ..overrides import set_number
from ..resume import Manifest


MAX_IMAGES = 10_000


class Swept(list):
    """The values of a range A..B: one value (c=2..2) is still the parameter swept."""


def sweep_set(text: str) -> tuple[str, list[float]]:
    """NAME=VALUE, or NAME=A..B / NAME=A..B..STEP (integers, B included)."""
    name, eq, value = text.partition("=")
    name = name.strip()
    if not eq or not name:
        raise argparse.ArgumentTypeError(f"expected NAME=A..B or NAME=VALUE, got '{text}'")
    if ".." not in value:
        return name, [set_number(value, text)]
    try:
        parts = [int(p) for p in value.split("..")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"--set {text}: a range is A..B or A..B..STEP in "
                                         f"integers, e.g. c=1..12") from None
    if len(parts) not in (2, 3) or (len(parts) == 3 and parts[2] <= 0):
        raise argparse.ArgumentTypeError(f"--set {text}: a range is A..B or A..B..STEP, "
                                         f"with a positive STEP")
    a, b, step = parts[0], parts[1], parts[2] if len(parts) == 3 else 1
    values = range(a, b + 1, step) if a <= b else range(a, b - 1, -step)
    if len(values) > MAX_IMAGES:
        # the list alone of a range of 10^8 took seconds, and then as many renders
        raise argparse.ArgumentTypeError(f"--set {text}: {len(values):,} images; a sweep "
                                         f"renders at most {MAX_IMAGES:,}")
    return name, Swept(float(v) for v in values)


def sweep_outputs(file: str, directory: Path, name: str, values: list[float]) -> list[Path]:
    """sierpinski_c=03.png: zero-padded so that the names sort by value (among values of
    one sign: c=-2 sorts after c=-1)."""
    width = max(len(str(abs(int(v)))) for v in values)
    stem = Path(file).stem
    return [directory / f"{stem}_{name}={'-' if v < 0 else ''}{abs(int(v)):0{width}d}.png"
            for v in values]


def drop_other_widths(file: str, directory: Path, name: str, values: list[float],
                      outputs: list[Path]) -> list[str]:
    """Removes the images an earlier sweep of this file made of these values under another
    zero-padding (c=1.png where this one writes c=01.png), which sorted among the new ones
    (c=09, c=1, c=10) as stale copies; only those the directory's list of images made
    names. Returns their names."""
    image = re.compile(rf"{re.escape(Path(file).stem)}_{re.escape(name)}=(-?[0-9]+)\.png")
    swept = {int(v) for v in values}

    def same_value(n: str) -> bool:
        m = image.fullmatch(n)
        return m is not None and int(m.group(1)) in swept
    stale = Manifest(directory).forget_others({p.name for p in outputs}, same_value)
    for n in stale:
        (directory / n).unlink(missing_ok=True)
    return stale
