"""Kernels loaded from numba's cache without numba's compiler set-up (trace/cacheload.py)
give the same picture as numba's own load, and skip that set-up; their symbols come
from the object file, the same names numba reads off the bitcode, and the bitcode is
still there for a compile that links them. numba's runtime is compiled once, then read."""
import json
import os
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
    cacheload.codegen.CPUCodeLibrary._unserialize = cacheload.NUMBA_UNSERIALIZE
    cacheload.codegen.CPUCodeLibrary._get_module_for_linking = cacheload.NUMBA_LINKING
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


# every library a render loads from the cache: the names its object file defines, and
# those its bitcode defines, as numba lists them
SYMBOLS = """
import json, sys
from llvmlite import binding
from pcsg.trace import cacheload
seen = []
def kept(cls, codegen_, state):
    seen.append(state)
    return cacheload._unserialize(cls, codegen_, state)
cacheload.codegen.CPUCodeLibrary._unserialize = classmethod(kept)
from pcsg.cli import main
assert main(["render", sys.argv[1], "--set", "cnt=3", "--size", "24x18", "-q",
             "-o", sys.argv[2]]) == 0
out = []
for name, kind, (objects, bitcode) in seen:
    module = binding.parse_bitcode(bitcode)
    numba = {g.name for gs in (module.functions, module.global_variables) for g in gs
             if not g.is_declaration}
    out.append([name, sorted(cacheload.defined_symbols(objects)), sorted(numba)])
print(json.dumps(out))
"""


def test_the_object_files_define_the_names_the_bitcode_does(tmp_path):
    # the terrain: the walk, the instance table and the system's blocks besides the shading.
    # A render first compiles whatever is not cached yet (the blocks are cached per system
    # and per version of vm.py), so that the second loads everything
    warm = subprocess.run([sys.executable, "-m", "pcsg", "render",
                           str(GRAMMARS / "carpenter_terrain.pcsg"), "--set", "cnt=3",
                           "--size", "24x18", "-q", "-o", str(tmp_path / "w.png")],
                          capture_output=True, text=True, timeout=900)
    assert warm.returncode == 0, warm.stderr
    out = subprocess.run([sys.executable, "-c", SYMBOLS, str(GRAMMARS / "carpenter_terrain.pcsg"),
                          str(tmp_path / "t.png")], capture_output=True, text=True, timeout=900)
    assert out.returncode == 0, out.stderr
    libraries = json.loads(out.stdout.splitlines()[-1])
    names = {name.split(".")[-1] for name, _, _ in libraries}
    assert {"shade_share", "walk", "run_blocks"} <= {n.split("$")[0] for n in names}, names
    for name, ours, numbas in libraries:
        assert ours == numbas, name
        assert len(ours) > 0


# a kernel loaded from the cache, then linked into a function compiled afterwards
LINK = """
import numpy as np
from numba import njit
from pcsg.trace import vm
assert vm.hash_to_unit.signatures == []          # declared, loaded at its first use
vm.hash_to_unit(np.uint64(1))
library = vm.hash_to_unit.overloads[vm.hash_to_unit.signatures[0]].library
assert "_pcsg_bitcode" in library.__dict__      # loaded, its bitcode not parsed

@njit
def twice(h):
    return 2.0 * vm.hash_to_unit(h)

h = np.uint64(0x9E3779B97F4A7C15)
assert twice(h) == 2.0 * vm.hash_to_unit(h) == 2.0 * float(int(h) >> 11) / 2.0 ** 53
assert "_pcsg_bitcode" not in library.__dict__ and library._shared_module is not None
print("linked")
"""


def test_a_kernel_loaded_from_the_cache_links_into_a_new_compile():
    out = subprocess.run([sys.executable, "-c", LINK], capture_output=True, text=True,
                         timeout=900)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split()[-1] == "linked"


# numba's runtime in a fresh process: compiled (and kept) or read, then linked into a
# function compiled afterwards, which allocates (the runtime's work)
RUNTIME = """
import numpy as np
from numba.core.runtime import nrtdynmod
compiled = []
create = nrtdynmod.create_nrt_module
nrtdynmod.create_nrt_module = lambda ctx: compiled.append(1) or create(ctx)
import pcsg.trace
from numba import njit
total = njit(lambda n: np.ones(n).sum())(10)
print(len(compiled), total)
"""


def test_numbas_runtime_is_compiled_once_then_read_from_the_cache(tmp_path):
    env = dict(os.environ, PCSG_CACHE_DIR=str(tmp_path))

    def start():
        out = subprocess.run([sys.executable, "-c", RUNTIME], capture_output=True,
                             text=True, timeout=300, env=env)
        assert out.returncode == 0, out.stderr
        return out.stdout.split()
    assert start() == ["1", "10.0"]
    assert len(list(tmp_path.glob("nrt-*.bin"))) == 1
    assert start() == ["0", "10.0"]


# a render whose kernels load from the cache, and the modules that load imported
MODULES = """
import sys
from pcsg.cli import main
assert main(["render", sys.argv[1], "--size", "16x12", "-q", "-o", sys.argv[2]]) == 0
print(" ".join(m for m in ("numba.np.arraymath", "numba.np.linalg", "numpy.ma")
               if m in sys.modules))
"""


def test_a_cached_render_imports_neither_numbas_numpy_maths_nor_numpy_ma(tmp_path):
    """A cached kernel's environment imports the modules of the numba implementations it
    was compiled from; `calc_cache.any()` in make_scratch made every render import
    numba.np.arraymath (with numba.np.linalg and a probe for scipy), 9 ms. And numba's
    typeof of the first array imported numpy.ma, 8 ms (trace/dispatch.py)."""
    for run in range(2):      # the first may compile: a compile imports all of numba
        out = subprocess.run([sys.executable, "-c", MODULES,
                              str(GRAMMARS / "carpenter_terrain.pcsg"), str(tmp_path / "t.png")],
                             capture_output=True, text=True, timeout=900)
        assert out.returncode == 0, out.stderr
    assert out.stdout.splitlines()[-1].split() == []
