"""The recursion limit is the interpreter's: passes on two threads that raise it must not
leave each other with a lower one (pcsg/recursion.py)."""
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
