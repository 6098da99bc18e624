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
