"""pcsg/memory.py: blocks freed after a large one has been freed go back to the system."""
import platform
import subprocess
import sys

import pytest

from pcsg.memory import return_freed_memory

PROGRAM = """
import numpy as np
{fix}
def rss():
    with open("/proc/self/status") as f:
        return next(int(l.split()[1]) for l in f if l.startswith("VmRSS")) // 1024
np.ones(20 << 17)               # 20 MB, mapped and unmapped: glibc raises its threshold
before = rss()
blocks = [np.ones(10 << 17) for _ in range(3)]      # 3 x 10 MB, touched
del blocks
print(rss() - before)
"""


def grown(fix: str) -> int:
    """MB still resident after the three blocks were freed."""
    out = subprocess.run([sys.executable, "-c", PROGRAM.format(fix=fix)], capture_output=True,
                         text=True, check=True)
    return int(out.stdout)


@pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="glibc's mallopt")
def test_freed_blocks_go_back_to_the_system():
    assert return_freed_memory()
    assert grown("from pcsg.memory import return_freed_memory; return_freed_memory()") < 5
    # what the fix is for: without it the heap keeps them
    assert grown("") >= 25
