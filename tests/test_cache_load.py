"""Kernels loaded from numba's cache without numba's compiler set-up (trace/cacheload.py)
give the same picture as numba's own load, and skip that set-up."""
import json
import subprocess
import sys

from .conftest import GRAMMARS

# a whole `pcsg render` in one fresh process, counting numba's context refreshes
RENDER = """
import hashlib, json, sys
from numba.core import base
calls = []
refresh = base.BaseContext.refresh
def counted(self):
    calls.append(1)
    refresh(self)
base.BaseContext.refresh = counted
import pcsg.trace
from pcsg.trace import cacheload
if sys.argv[1] == "numba":
    cacheload.Cache.load_overload = cacheload.NUMBA_LOAD
from pcsg.cli import main
assert main(["render", sys.argv[2], "--set", "c=3", "--size", "48x36", "-q",
             "-o", sys.argv[3]]) == 0
print(json.dumps({"refreshes": len(calls),
                  "png": hashlib.sha256(open(sys.argv[3], "rb").read()).hexdigest()}))
"""


def render(tmp_path, load: str) -> dict:
    out = subprocess.run([sys.executable, "-c", RENDER, load, str(GRAMMARS / "sierpinski.pcsg"),
                          str(tmp_path / f"{load}.png")],
                         capture_output=True, text=True, timeout=900)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.splitlines()[-1])


def test_cached_kernels_load_without_the_compiler_set_up(tmp_path):
    # numba's own load first: it compiles whatever is not cached yet, so that the
    # second process finds every kernel it needs in the cache
    theirs = render(tmp_path, "numba")
    ours = render(tmp_path, "pcsg")
    assert theirs["refreshes"] > 0
    assert ours["refreshes"] == 0
    assert ours["png"] == theirs["png"]
