"""`pcsg sweep FILE --set c=1..12`: one image per value of one parameter."""
from __future__ import annotations

import argparse
from pathlib import Path

from ..overrides import set_number


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
