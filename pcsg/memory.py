"""Large blocks that pcsg frees go back to the system.

glibc serves an allocation of 128 KiB or more with its own mapping, which a free
returns, but after each such free it raises that threshold to the block's size (up to
32 MiB): once the bounding walk had freed its first instance table (35 MB) and its
threads' table buffers, the next walks' tables and the render's arrays came from the
heap instead, which keeps what is freed. The `pcsg` command fixes the threshold, which
turns that adjustment off: the terrain's peak memory is 15 MB lower at orders 9 and 12
(288 against 273 MB at 12, /usr/bin/time). A library does not change its host's
allocator, so `pcsg.load` leaves it alone."""
from __future__ import annotations

import ctypes

M_MMAP_THRESHOLD = -3           # mallopt's parameter number (malloc.h)
THRESHOLD = 128 * 1024          # glibc's own default, held there


def return_freed_memory() -> bool:
    """Whether the threshold was fixed: False where the C library has no mallopt
    (macOS, musl), which changes nothing else."""
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    return bool(mallopt(M_MMAP_THRESHOLD, THRESHOLD))
