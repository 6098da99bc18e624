"""pcsg/memory.py: inside freeing_blocks, blocks freed after a large one has been freed go
back to the system, and numpy's arrays are not advised huge pages; after it, freed blocks
are kept for reuse (the render's) and numpy advises them again."""
import platform
import subprocess
import sys

import pytest

PROGRAM = """
import numpy as np
from pcsg.memory import freeing_blocks
def rss():
    with open("/proc/self/status") as f:
        return next(int(l.split()[1]) for l in f if l.startswith("VmRSS")) // 1024
def allocate_and_free():
    before = rss()
    np.ones(20 << 17)           # 20 MiB, mapped and unmapped: glibc raises its threshold
    blocks = [np.ones(10 << 17) for _ in range(3)]      # 3 x 10 MiB, touched
    del blocks
    return rss() - before
with freeing_blocks():
    print(allocate_and_free())
print(allocate_and_free())      # after the block, as in the render
"""


def still_resident() -> tuple[int, int]:
    """MiB still resident after the blocks were freed, inside and after the block."""
    out = subprocess.run([sys.executable, "-c", PROGRAM],
                         capture_output=True, text=True, check=True)
    return tuple(int(x) for x in out.stdout.split())


@pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="glibc's mallopt")
def test_freed_blocks_go_back_to_the_system_inside_and_are_kept_after():
    # the same allocations, inside and after: returned inside, kept after. Without it,
    # glibc's own adjustment keeps them as it does after (30 MiB run by run alone; once,
    # in a run of the whole suite beside the bounds-checked pass, 0: so not asserted)
    inside, after = still_resident()
    assert inside < 5
    assert after >= 25



HUGE = """
import numpy as np
from pcsg.memory import freeing_blocks
def advised(a):
    # the VmFlags of the mapping that holds a's middle ('hg' for MADV_HUGEPAGE): numpy
    # advises the whole huge pages within the array, a mapping of their own
    start = a.ctypes.data + a.nbytes // 2
    with open("/proc/self/smaps") as f:
        inside = False
        for line in f:
            head = line.split()[0]
            if "-" in head and not head.endswith(":"):
                lo, hi = (int(x, 16) for x in head.split("-"))
                inside = lo <= start < hi
            elif inside and head == "VmFlags:":
                return "hg" in line.split()
    raise SystemExit("no mapping")
size = 16 << 17             # 16 MiB: numpy advises from 4 MiB up
before = advised(np.zeros(size))
with freeing_blocks():
    within = advised(np.zeros(size))
print(before, within, advised(np.zeros(size)))
"""


@pytest.mark.skipif(platform.system() != "Linux", reason="/proc/self/smaps")
def test_no_huge_pages_are_advised_inside_and_numpys_choice_is_back_after():
    out = subprocess.run([sys.executable, "-c", HUGE], capture_output=True, text=True,
                         check=True).stdout.split()
    if out[0] != "True":
        pytest.skip("this numpy or kernel advises no huge pages")
    assert out == ["True", "False", "True"]


ZEROED = """
import numpy as np
from pcsg.memory import zeroed
def rss():
    with open("/proc/self/status") as f:
        return next(int(l.split()[1]) for l in f if l.startswith("VmRSS")) // 1024
before = rss()
block = zeroed(64 << 20)
mapped = rss() - before
small = zeroed(1000)
print(mapped, int(block.any()), int(small.any()), block.size, small.size,
      int(block.flags.writeable), block.ctypes.data % 4096)
"""


@pytest.mark.skipif(platform.system() != "Linux", reason="MAP_POPULATE")
def test_zeroed_blocks_come_with_their_pages():
    """A large block of zeros is resident before anything touches it (its pages mapped
    at once, not one fault per page as the instance table's random writes reach them),
    writable and page-aligned; a small one is numpy's own."""
    out = subprocess.run([sys.executable, "-c", ZEROED], capture_output=True, text=True,
                         check=True)
    mapped, big_any, small_any, big, small, writeable, offset = map(int, out.stdout.split())
    assert mapped >= 60 and big_any == 0 and small_any == 0
    assert (big, small, writeable, offset) == (64 << 20, 1000, 1, 0)
