"""Ctrl-C that lands in a finalizer (pcsg/interrupt.py): Python would print a traceback
and drop it; pcsg delivers it again, so the command stops and prints no traceback. The
animation test that presses Ctrl-C while workers load kernels (test_animate.py) met
llvmlite's ObjectRef.__del__ that way. And a Ctrl-C that leaves numba's compiler lock held
(raised as its acquire returns, before the `with` body): released once it has unwound."""
import subprocess
import sys

PROGRAM = """
import signal, sys, time
# Python leaves SIGINT alone where it starts with it ignored (a job started with `&` in
# a script, nohup), and the redelivered interrupt would then be dropped
signal.signal(signal.SIGINT, signal.default_int_handler)
{install}
class Finalized:
    def __del__(self):
        raise KeyboardInterrupt       # as a signal handler would, inside the finalizer
try:
    Finalized()
    start = time.monotonic()
    while time.monotonic() - start < {seconds}:      # the main thread's next steps
        pass
    print("went on")
except KeyboardInterrupt:
    print("interrupted")
"""


def run(install: str, seconds: float = 20.0):
    return subprocess.run([sys.executable, "-c", PROGRAM.format(install=install,
                                                                 seconds=seconds)],
                          capture_output=True, text=True, timeout=60)


def test_an_interrupt_in_a_finalizer_stops_the_program_without_a_traceback():
    p = run("from pcsg.interrupt import redeliver_in_finalizers; redeliver_in_finalizers()")
    assert p.stdout.strip() == "interrupted" and "Traceback" not in p.stderr, p.stderr


def test_without_it_python_prints_a_traceback_and_goes_on():
    """What the hook is for (so the test above shows a difference)."""
    p = run("", seconds=0.2)
    assert p.stdout.strip() == "went on" and "Traceback" in p.stderr


def test_other_exceptions_in_finalizers_are_still_reported():
    p = run("from pcsg.interrupt import redeliver_in_finalizers\n"
            "redeliver_in_finalizers()\n"
            "class Other:\n"
            "    def __del__(self):\n"
            "        raise ValueError('from a finalizer')\n"
            "Other()")
    assert "ValueError: from a finalizer" in p.stderr and p.stdout.strip() == "interrupted"


def test_a_compiler_lock_left_held_by_an_interrupt_is_released_for_the_other_threads():
    import threading
    from numba.core.compiler_lock import global_compiler_lock
    from pcsg.interrupt import release_compiler_lock

    def another_thread_gets_it():
        got = []

        def take():
            ok = global_compiler_lock._lock.acquire(timeout=0.5)
            got.append(ok)
            if ok:
                global_compiler_lock._lock.release()
        t = threading.Thread(target=take)
        t.start()
        t.join()
        return got[0]

    # what an interrupt between numba's acquire and its `with` body leaves: held twice
    global_compiler_lock.acquire()
    global_compiler_lock.acquire()
    try:
        assert not another_thread_gets_it()
    finally:
        release_compiler_lock()
    assert another_thread_gets_it()
    release_compiler_lock()         # not held: nothing to do, no error


def test_stoppable_raises_what_tick_raises_once_every_share_has_stopped():
    """jit.stoppable: the shares run on helper threads and read stop[0]; an exception
    in the waiting thread (Ctrl-C, SIGTERM, --timeout's check) sets it."""
    import numpy as np
    import pytest
    from pcsg.trace.jit import stoppable
    ended = {}

    def share(w, workers, stop, steps):
        import time
        for k in range(steps):          # minutes, unless stopped
            if stop[0] != 0:
                break
            time.sleep(0.001)
        ended[w] = (k, int(stop[0]))

    ticks = []

    def tick():
        ticks.append(1)
        if len(ticks) == 3:
            raise TimeoutError("stopped by tick")
    with pytest.raises(TimeoutError):
        stoppable(share, 2, 200_000, tick=tick, every=0.01)
    assert sorted(ended) == [0, 1] and all(k < 200_000 - 1 and s == 1
                                          for k, s in ended.values()), ended
    done = np.zeros(2, dtype=np.int64)

    def quick(w, workers, stop, out):
        out[w] = w + 1
    stoppable(quick, 2, done)                   # no tick: waits for the shares, returns
    assert done.tolist() == [1, 2]


def test_the_compiled_shares_read_the_stop_flag_before_each_chunk():
    """With stop[0] set, trace_share traces no chunk: its rows keep what they held."""
    import numpy as np
    import pcsg
    from pcsg.trace.kernel import CHUNK, trace_share
    from pcsg.trace.nodes import no_events
    from pcsg.trace.walk import R_WIDTH
    obj = pcsg.loads("sphere")
    n = 3 * CHUNK
    o = np.tile([0.0, 0.0, 5.0], (n, 1))
    d = np.tile([0.0, 0.0, -1.0], (n, 1))
    for stop, traced in ((1, False), (0, True)):
        out = np.full((n, R_WIDTH), -7.0)
        events = no_events(len(obj.graph.nodes), 3)
        trace_share(0, 1, np.array([stop], dtype=np.int64), obj.flat, o, d, np.zeros(n), 1e-9,
                    np.inf, False, 0.0, obj.max_depth, obj.limits, False, out, events)
        assert (out != -7.0).any() == traced


def test_sigterm_is_raised_once_and_a_second_one_does_not_cut_the_clean_up_short():
    program = """
import os, signal, time
from pcsg.interrupt import Terminated, terminate_as_interrupt
terminate_as_interrupt()
try:
    os.kill(os.getpid(), signal.SIGTERM)
    time.sleep(5)
    print("went on")
except Terminated as e:
    os.kill(os.getpid(), signal.SIGTERM)       # the second, during the clean-up
    time.sleep(0.2)
    print("cleaned up", e.exit_status, e)
"""
    p = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True,
                       timeout=60)
    assert p.stdout.split() == ["cleaned", "up", "143", "SIGTERM"], (p.stdout, p.stderr)


def test_a_sigterm_lost_in_a_finalizer_is_delivered_again_as_itself():
    """As Ctrl-C's is (above): redelivered as SIGINT, it made the command say
    "interrupted" and exit with 130 instead of 143."""
    program = """
import signal, time
from pcsg.interrupt import Terminated, redeliver_in_finalizers, terminate_as_interrupt
terminate_as_interrupt()
redeliver_in_finalizers()
class Finalized:
    def __del__(self):
        raise Terminated(signal.SIGTERM)    # as the handler would, inside the finalizer
try:
    Finalized()
    start = time.monotonic()
    while time.monotonic() - start < 20:
        pass
    print("went on")
except Terminated as e:
    print("terminated", e.exit_status)
except KeyboardInterrupt:
    print("interrupted")
"""
    p = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True,
                       timeout=60)
    assert p.stdout.split() == ["terminated", "143"], (p.stdout, p.stderr)


def test_animate_workers_keep_a_sighup_that_was_ignored():
    """`nohup pcsg animate ... &` then logging out: the command ignores SIGHUP (it kept
    nohup's SIG_IGN), and so must its workers, which inherit it across the spawn."""
    program = """
import signal
signal.signal(signal.SIGHUP, signal.SIG_IGN)
from pcsg.render.animate import _init_worker
_init_worker(1)
print(signal.getsignal(signal.SIGHUP) is signal.SIG_IGN,
      signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL)
"""
    p = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True,
                       timeout=120)
    assert p.stdout.split() == ["True", "True"], (p.stdout, p.stderr)


def test_only_llvmlites_second_close_is_kept_quiet():
    """An interrupt that cut an ObjectRef's close short makes its finalizer fail on the
    attribute the first close removed: that is noise; any other failure is reported."""
    from types import SimpleNamespace
    from pcsg.interrupt import _closed_twice

    class ObjectRef:
        def __del__(self):
            pass
    ObjectRef.__del__.__qualname__ = "ObjectRef.__del__"      # as llvmlite's, at top level
    gone = AttributeError("'GlobalContextRef' object has no attribute '_as_parameter_'")
    assert _closed_twice(SimpleNamespace(exc_type=AttributeError, exc_value=gone,
                                         object=ObjectRef.__del__))
    assert not _closed_twice(SimpleNamespace(exc_type=AttributeError,
                                             exc_value=AttributeError("other"),
                                             object=ObjectRef.__del__))
    assert not _closed_twice(SimpleNamespace(exc_type=ValueError, exc_value=ValueError(),
                                             object=ObjectRef.__del__))
