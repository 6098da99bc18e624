"""The instance hashes and the rule selection of trace/vm.py in Python integers, bit for
bit the same (tests/test_hashes.py), for the Python that derives and bounds systems:
the derivation, the checks' probe and the bounds' state keys. Calling vm's from Python
loaded six compiled functions from numba's cache in every `pcsg` command, 4 ms,
for work of a few microseconds."""
from __future__ import annotations

import math
import struct

from ..trace import vm

_M64 = (1 << 64) - 1
_GOLDEN = int(vm._GOLDEN)
_M1 = int(vm._M1)
_M2 = int(vm._M2)
_SALT_KEY = int(vm.SALT_KEY)
_CANON_NAN = int(vm._CANON_NAN)
_DOUBLE = struct.Struct("<d")
_BITS = struct.Struct("<Q")


def splitmix64(x: int) -> int:
    z = ((x & _M64) + _GOLDEN) & _M64
    z = ((z ^ (z >> 30)) * _M1) & _M64
    z = ((z ^ (z >> 27)) * _M2) & _M64
    return z ^ (z >> 31)


def mix(h: int, v: int) -> int:
    return splitmix64((h & _M64) ^ splitmix64(v))


def edge_hash(h: int, node: int, child: int) -> int:
    return mix(mix(h, node), child)


def salt(h: int, slot: int) -> int:
    return mix((h & _M64) ^ _SALT_KEY, slot)


def float_bits(x: float) -> int:
    """The bit pattern of x, with -0.0 -> 0.0 and every nan -> one quiet nan."""
    if x != x:
        return _CANON_NAN
    if x == 0.0:
        return 0
    return _BITS.unpack(_DOUBLE.pack(x))[0]


def select_rule(x: float, nrules: int) -> int:
    """The rule number 1..nrules that x rounds to (halves away from zero), or 0 if none
    does."""
    if not math.isfinite(x):
        return 0
    r = float(math.trunc(x))
    if abs(x - r) >= 0.5:
        r += math.copysign(1.0, x)
    if r < 1.0 or r > nrules:
        return 0
    return int(r)
