"""`--set NAME=VALUE`: a parameter's value as the notation writes a number, with a sign."""
from __future__ import annotations

import argparse
import math
import re
import sys

# the grammar's NUMBER (pcsg.lark). Python's float() also took 1_0 (ten), inf, nan and
# "infinity", none of which a file can write
NUMBER = re.compile(r"[+-]?([0-9]+\.[0-9]*|\.[0-9]+|[0-9]+)([eE][+-]?[0-9]+)?")


def underflows(text: str) -> bool:
    """Whether `text` is a number too small for a double, which reads as 0 (1e-400): one
    written with a digit other than 0. Text that is no number is not."""
    try:
        value = float(text)
    except ValueError:
        return False
    mantissa = re.split(r"[eE]", text, maxsplit=1)[0]
    return value == 0.0 and any(c in "123456789" for c in mantissa)


def set_number(value: str, text: str) -> float:
    """VALUE of `--set TEXT`, or the error that says what a number is."""
    if not NUMBER.fullmatch(value.strip()):
        raise argparse.ArgumentTypeError(
            f"'{value}' is not a number (in --set {text}): write it as a file would, "
            f"e.g. 12, -0.5, .5, 1e-3")
    if not math.isfinite(number := float(value)):
        # 1e400: inf, which --set c=inf was refused as
        raise argparse.ArgumentTypeError(f"'{value}' is too large (in --set {text}): a "
                                         f"parameter holds at most {sys.float_info.max:.2g}")
    if underflows(value.strip()):
        # 1e-400: 0, which the file would then divide by or scale with, without a word
        raise argparse.ArgumentTypeError(
            f"'{value}' is too small (in --set {text}): it would be 0; a parameter other "
            f"than 0 is at least {5e-324:.2g} in size")
    return number


def set_value(text: str) -> tuple[str, float]:
    name, eq, value = text.partition("=")
    if not eq or not name.strip():
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE, got '{text}'")
    return name.strip(), set_number(value, text)


def given_twice(overrides) -> str | None:
    """The first name that `--set` gives more than once: which should win is not ours to
    guess (render and stats took the last, sweep refused it)."""
    names = [name for name, _ in overrides]
    twice = sorted({n for n in names if names.count(n) > 1})
    return twice[0] if twice else None
