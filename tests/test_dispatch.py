"""pcsg's numba dispatchers set themselves up at their first compile (trace/dispatch.py):
importing pcsg compiles and caches nothing, and a declared signature still decides how
every call converts its arguments, whether Python or a kernel calls first."""
import subprocess
import sys
import threading
from collections import namedtuple

import numba
import numpy as np
from numba import njit

from pcsg.trace.dispatch import argument_type, cached_jit, declared


@declared("uint64(uint64)")
def _double(x):
    return x + x


@declared("uint64(uint64)")
def _triple(x):
    return x + x + x


@declared("uint64(uint64)")
def _shared(x):
    return x * np.uint64(5)


@cached_jit()
def _negate(x):
    return -x


def test_a_declared_function_is_compiled_for_its_signature_at_its_first_call():
    assert _double.signatures == []
    assert _double(3) == 6
    # the declared uint64, not the int64 a plain int would be typed as: it wraps
    assert _double(2**63 + 1) == 2
    assert [str(t) for sig in _double.signatures for t in sig] == ["uint64"]
    # a kernel passing an int64 converts it to the declared signature, as with njit(sig)
    assert njit(lambda v: _double(v))(np.int64(4)) == 8
    assert [str(t) for sig in _double.signatures for t in sig] == ["uint64"]


def test_a_declared_function_first_used_by_a_kernel_compile_takes_its_signature():
    assert _triple.signatures == []
    assert njit(lambda v: _triple(v))(np.int64(2)) == 6
    assert [str(t) for sig in _triple.signatures for t in sig] == ["uint64"]


def test_threads_calling_a_declared_function_first_get_its_one_signature():
    start = threading.Barrier(6)
    results = []

    def call(i):
        start.wait()
        results.append((i, _shared(i)))

    threads = [threading.Thread(target=call, args=(i,)) for i in range(6)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert sorted(results) == [(i, 5 * i) for i in range(6)]
    assert [str(t) for sig in _shared.signatures for t in sig] == ["uint64"]


def test_a_lazily_cached_function_sets_its_cache_up_when_it_compiles():
    from numba.core.caching import FunctionCache, NullCache
    assert isinstance(_negate._cache, NullCache)
    assert _negate(2.5) == -2.5
    assert isinstance(_negate._cache, FunctionCache)


IMPORTS = """
import gc
from numba.core.caching import NullCache
from numba.core.dispatcher import Dispatcher
import pcsg.cli, pcsg.compiler, pcsg.render.job, pcsg.trace.kernel, pcsg.trace.reference
from pcsg.trace.dispatch import Deferred, make_all
def ours():
    return [d for d in gc.get_objects()
            if isinstance(d, Dispatcher) and d.py_func.__module__.startswith("pcsg.")]
deferred = sum(type(d) is Deferred for d in gc.get_objects())
made = len(ours())
make_all()
print(deferred, made, len(ours()), sum(len(d.signatures) > 0 for d in ours()),
      sum(not isinstance(d._cache, NullCache) for d in ours()))
"""


def test_importing_pcsg_makes_no_dispatcher_and_compiles_nothing():
    """Importing pcsg's modules leaves their jitted functions Deferred: no dispatcher is
    made; made, none of them has compiled anything or set its cache up."""
    out = subprocess.run([sys.executable, "-c", IMPORTS], capture_output=True, text=True,
                         timeout=600)
    assert out.returncode == 0, out.stderr
    deferred, made, count, compiled, caches = map(int, out.stdout.split())
    assert deferred > 100 and made == 0
    assert count >= deferred and (compiled, caches) == (0, 0)


MADE = """
import numpy as np
from numba import njit
import pcsg.trace.vm as vm
from pcsg.trace.dispatch import Deferred
from pcsg.trace.vm import mix
assert type(mix) is Deferred and type(vm.fmin) is Deferred

@njit(cache=False)
def uses(a, b):                 # a compile: every Deferred is made first
    return mix(np.uint64(a), np.uint64(b)), vm.fmin(1.0, 2.0)

print(uses(3, 4) == (vm.mix(np.uint64(3), np.uint64(4)), 1.0), type(mix).__name__,
      type(vm.fmin).__name__, type(vm.fmax).__name__)
"""


def test_a_compile_makes_every_deferred_function_first():
    """numba compiles a function from the globals its code reads (and inlines a call by
    what it finds there): before it compiles anything, every module's Deferred global,
    this test's own too, names its dispatcher."""
    out = subprocess.run([sys.executable, "-c", MADE], capture_output=True, text=True,
                         timeout=600)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["True", "Declared", "CachedLater", "CachedLater"]


LOADS = """
from pcsg.trace import vm
vm.rand_seed(1.5)
print(sum(vm.rand_seed.stats.cache_hits.values()))
"""


def test_a_declared_function_loads_from_numbas_cache_in_a_later_process():
    hits = []
    for _ in range(2):
        out = subprocess.run([sys.executable, "-c", LOADS], capture_output=True, text=True,
                             timeout=600)
        assert out.returncode == 0, out.stderr
        hits.append(int(out.stdout.split()[-1]))
    assert hits[1] == 1


def _arguments():
    readonly = np.zeros(4)
    readonly.flags.writeable = False
    pair = namedtuple("pair", "a b")
    arrays = [np.zeros(3), np.zeros((3, 4)), np.zeros((3, 4), order="F"),
              np.zeros((3, 4))[:, ::2], np.zeros(0), np.zeros(()), readonly,
              np.zeros((2, 2, 2), dtype=np.int16), np.zeros(3, dtype=np.uint64),
              np.zeros(3, dtype=bool), np.zeros(2, dtype=np.complex64),
              np.zeros(3, dtype=[("a", "f8"), ("b", "i4")]),
              np.array(["2020-01-01"], dtype="datetime64[D]"), np.zeros(3, dtype=np.float32)]
    scalars = [1, 2**63, -1, 1.5, True, np.uint64(7), np.int16(3), np.float32(2.0), None]
    return (arrays + scalars + [tuple(arrays[:3]), (np.zeros(2), 3, (np.ones(1), 2.5)),
                                pair(np.zeros(2), np.uint64(1)), pair(1, 2), ()])


def test_arguments_are_typed_as_numba_types_them():
    for value in _arguments():
        assert argument_type(value) == numba.typeof(value), value


def test_what_numba_must_decide_is_left_to_it():
    masked = np.ma.masked_array([1.0, 2.0])
    assert argument_type(masked) is None
    assert argument_type((np.zeros(2), masked)) is None
    assert argument_type(np.array([object()])) == numba.typeof(np.array([object()]))


FIRST_USE = """
from pcsg.trace import vm
from pcsg.trace.dispatch import Deferred
assert type(vm.fmax) is Deferred
print(vm.fmax(1.0, 2.0), type(vm.fmax).__name__)
"""


def test_a_deferred_function_first_used_is_its_modules_dispatcher_from_then_on():
    """Calls through the module reach the dispatcher itself after the first use."""
    out = subprocess.run([sys.executable, "-c", FIRST_USE], capture_output=True, text=True,
                         timeout=600)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["2.0", "CachedLater"]


FORKED = """
import os, signal, threading
from pcsg.trace import dispatch, vm
held, done = threading.Event(), threading.Event()
def hold():                 # a thread making a dispatcher when the process forks
    with dispatch._making:
        held.set()
        done.wait()
threading.Thread(target=hold).start()
held.wait()
pid = os.fork()
if pid == 0:
    signal.alarm(20)        # a child left with the parent's held lock would hang here
    os._exit(0 if vm.fmin(1.0, 2.0) == 1.0 else 1)
_, status = os.waitpid(pid, 0)
done.set()
print(os.waitstatus_to_exitcode(status))
"""


def test_a_child_forked_while_a_dispatcher_is_made_makes_its_own():
    out = subprocess.run([sys.executable, "-c", FORKED], capture_output=True, text=True,
                         timeout=600)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["0"]
