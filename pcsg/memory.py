"""The bounding walk's large blocks go back to the system when it frees them.

glibc serves an allocation of 128 KiB or more with a mapping of its own, which a free
returns, but after each such free it raises that threshold to the block's size (up to
32 MiB): once the bounding walk had freed its first instance table (35 MB) and its
threads' table buffers, the next walks' tables came from the heap instead, which keeps
what is freed, and the render's arrays were added on top. `freeing_blocks` holds the
threshold at 128 KiB while the walk runs (the terrain's peak memory: 272 MB against
286 MB at orders 9 and 12) and sets it to 32 MiB after, the heap keeping up to twice
that when freed, as glibc's own adjustment would have it by then: each batch of the
render allocates its workers' scratch anew, and mapped afresh every time it cost a
fifth of Sierpinski 6's render in page faults.

Inside it numpy's large arrays are also made without asking the kernel for huge pages
(MADV_HUGEPAGE, numpy's default): every walk maps its tables and buffers afresh, and a
huge page the kernel first had to compact memory for held one for 50 to 80 ms, in about
one render in three. The terrain at order 8, 16 renders each: bounds 0.121 to 0.232 s
with huge pages, 0.129 to 0.140 s without, the render phase the same within 2 %.

A library does not change its host's allocator, so `pcsg.load` leaves both alone;
`pcsg render` does."""
from __future__ import annotations

import ctypes
import mmap
from contextlib import contextmanager

import numpy as np

M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3     # mallopt's parameter numbers (malloc.h)
RETURNED = 128 * 1024           # glibc's initial threshold
KEPT = 32 * 1024 * 1024         # the most its own adjustment raises it to


def _mallopt():
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):
        return None             # no mallopt (macOS, musl): nothing changes
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    return mallopt


def set_threshold(size: int) -> bool:
    """Whether the threshold is now fixed at `size` bytes, and the free memory the heap
    keeps at twice that."""
    mallopt = _mallopt()
    return (mallopt is not None and bool(mallopt(M_MMAP_THRESHOLD, size))
            and bool(mallopt(M_TRIM_THRESHOLD, 2 * size)))


def huge_pages(on: bool) -> bool:
    """Set whether numpy advises huge pages for its large arrays; the setting before.
    A numpy without the switch keeps its own and answers `on`."""
    try:
        from numpy._core import multiarray
    except ImportError:                     # numpy 1.x
        from numpy.core import multiarray
    switch = getattr(multiarray, "_set_madvise_hugepage", None)
    return on if switch is None else bool(switch(on))


@contextmanager
def freeing_blocks():
    """Blocks of 128 KiB or more freed inside go back to the system; after it, the heap
    serves and keeps blocks up to 32 MiB. Inside, numpy's arrays get no huge pages."""
    set_threshold(RETURNED)
    huge = huge_pages(False)
    try:
        yield
    finally:
        set_threshold(KEPT)
        huge_pages(huge)


POPULATED = 1 << 20             # zeroed() maps blocks from this size with their pages


def zeroed(nbytes: int) -> np.ndarray:
    """nbytes zero bytes (uint8), page-aligned where large. A block of POPULATED bytes or
    more is mapped with all its pages at once (MAP_POPULATE, Linux): a table filled in
    hash order touches its pages in random order, and each first touch was a fault of
    its own, which cost the terrain at 9's instance table (16 MB) 11 ms more than
    writing into pages already there; populating them takes 4 ms. Freed with the array."""
    flag = getattr(mmap, "MAP_POPULATE", 0)
    if nbytes < POPULATED or not flag:
        return np.zeros(nbytes, dtype=np.uint8)
    try:
        block = mmap.mmap(-1, nbytes, flags=mmap.MAP_PRIVATE | mmap.MAP_ANONYMOUS | flag)
    except OSError:
        return np.zeros(nbytes, dtype=np.uint8)
    return np.frombuffer(block, dtype=np.uint8)
