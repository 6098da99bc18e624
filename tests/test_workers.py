"""jit.on_threads: every worker's share runs, worker 0 on the caller's thread, errors
reach the caller, and a forked child can still use it (its pool's threads stay behind)."""
import os
import signal
import threading

import pytest

from pcsg.trace.jit import on_threads


def _record(seen):
    def share(w, workers, tag):
        seen.append((w, workers, tag, threading.current_thread().name))
    return share


def test_every_share_runs_and_worker_0_is_the_caller():
    for workers in (1, 2, 3, 2):
        seen = []
        on_threads(_record(seen), workers, "x")
        assert sorted(s[:3] for s in seen) == [(w, workers, "x") for w in range(workers)]
        caller = threading.current_thread().name
        assert [s[3] for s in seen if s[0] == 0] == [caller]
        assert all(s[3] != caller for s in seen if s[0] != 0)


@pytest.mark.parametrize("failing", [0, 1])
def test_an_error_in_a_share_reaches_the_caller_after_every_share_ran(failing):
    seen = []

    def share(w, workers):
        seen.append(w)
        if w == failing:
            raise ValueError(f"share {w}")
    with pytest.raises(ValueError, match=f"share {failing}"):
        on_threads(share, 3)
    assert sorted(seen) == [0, 1, 2]


def test_a_forked_child_runs_its_shares():
    on_threads(_record([]), 2, "parent")        # the parent's pool and its thread exist
    pid = os.fork()
    if pid == 0:                                # the child: exit 0 only if both shares ran
        try:
            signal.alarm(20)                    # a share given to a dead thread hangs
            seen = []
            on_threads(_record(seen), 2, "child")
            os._exit(0 if sorted(s[0] for s in seen) == [0, 1] else 1)
        except BaseException:
            os._exit(2)
    _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0
