"""The recursion limit is the interpreter's: passes on two threads that raise it must not
leave each other with a lower one (pcsg/recursion.py)."""
import os
import subprocess
import sys
import threading

import pytest

from pcsg.recursion import recursion_limit


def test_nested_passes_get_the_highest_limit_and_the_first_limit_returns():
    before = sys.getrecursionlimit()
    with recursion_limit(before + 4000):
        assert sys.getrecursionlimit() == before + 4000
        with recursion_limit(before + 7000):
            assert sys.getrecursionlimit() == before + 7000
        assert sys.getrecursionlimit() == before + 4000
        with recursion_limit(10):               # never lowered
            assert sys.getrecursionlimit() == before + 4000
    assert sys.getrecursionlimit() == before


def test_a_pass_that_leaves_first_does_not_lower_another_threads_limit():
    """Thread A raises the limit, B raises it further, A leaves while B still recurses:
    B keeps its limit. Saving and restoring per pass gave B A's saved value here."""
    before = sys.getrecursionlimit()
    a_in, b_in, a_out = threading.Event(), threading.Event(), threading.Event()
    seen = {}

    def a():
        with recursion_limit(before + 3000):
            a_in.set()
            b_in.wait()
        a_out.set()

    def b():
        a_in.wait()
        with recursion_limit(before + 6000):
            b_in.set()
            a_out.wait()
            seen["b after a left"] = sys.getrecursionlimit()

    threads = [threading.Thread(target=a), threading.Thread(target=b)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert seen["b after a left"] == before + 6000
    assert sys.getrecursionlimit() == before


def test_the_limit_returns_when_a_pass_raises():
    before = sys.getrecursionlimit()
    with pytest.raises(ValueError):
        with recursion_limit(before + 1000):
            raise ValueError("inside")
    assert sys.getrecursionlimit() == before


@pytest.mark.parametrize("terms, code", [(20_000, 0), (100_000, 1)])
def test_a_long_sum_compiles_or_is_too_deep_without_a_crash(tmp_path, terms, code):
    """A sum of 20 000 terms is 20 000 levels of the syntax tree, and its constant fold
    recursed in C as well (a generator inside tuple()): the main thread's stack ran out
    and the process died of a segmentation fault, under the recursion limit. In its own
    process, since a crash would end the test run."""
    f = tmp_path / "sum.pcsg"
    f.write_text("move(" + "+".join(["1"] * terms) + ", 0, 0) sphere\n", encoding="utf-8")
    r = subprocess.run([sys.executable, "-m", "pcsg", "check", str(f)], capture_output=True,
                       text=True, timeout=300, env={**os.environ, "PCSG_PREFETCH": "0"})
    assert r.returncode == code, (r.returncode, r.stderr[-500:])
    if code:
        # where: the error had no line and column
        assert f"{f}:1:6: error: an expression is nested too deeply to compile" in r.stderr
    else:
        assert "ok (2 nodes" in r.stdout


def test_on_deep_stack_returns_and_raises_as_a_call_would():
    from pcsg.recursion import on_deep_stack
    assert on_deep_stack(divmod, 7, 2) == (3, 1)
    with pytest.raises(ZeroDivisionError):
        on_deep_stack(divmod, 1, 0)
