"""The ways the tracing kernels are compiled, and how they run on every core.

Walk code allocates nothing, so it is compiled without numba's reference
counting (`_nrt=False`): with it, every array argument and every field read from
the Flat tuple costs an atomic increment and decrement, which measured as a
fifth of the walk's time, and the per-node steps passed the whole Flat (twenty
arrays) at each call. The per-node steps are inlined into the walks."""
import os
import threading
import time
from concurrent.futures import ThreadPoolExecutor, wait

from numba import config

from . import compiling
from .dispatch import cached_jit

kernel = cached_jit(error_model="numpy", nogil=True, _nrt=False)
inline = cached_jit(error_model="numpy", nogil=True, _nrt=False, inline="always")
# a worker's share of a batch: it allocates its scratch, so it keeps reference counting
share = cached_jit(error_model="numpy", nogil=True)


@inline
def copy_into(dst, src):
    """dst[:] = src[:len(dst)] element by element: numba lowers an array assigned to a
    slice with a temporary copy, which code without reference counting cannot make."""
    for i in range(dst.shape[0]):
        dst[i] = src[i]


_threads = config.NUMBA_NUM_THREADS


def threads() -> int:
    """The threads a batch runs on: NUMBA_NUM_THREADS (default: the cores), or fewer
    after set_threads. Not numba.get_num_threads(): its first call starts numba's own
    pool of threads for prange (OpenMP here), which pcsg does not use, in 5 to 40 ms of
    every render."""
    return _threads


def set_threads(n: int) -> None:
    global _threads
    _threads = max(1, min(int(n), config.NUMBA_NUM_THREADS))


_pool: ThreadPoolExecutor | None = None
_pool_size = 0
_pool_lock = threading.Lock()


def _helpers(count: int) -> ThreadPoolExecutor:
    """The process's pool of helper threads, started once and grown when more are asked
    for. A pool per call started its threads for every batch of rays, and waited for
    each to start: Sierpinski 6 rendered in 0.14 to 0.18 s that way, 0.14 to 0.15 s
    with this pool (tools/performance_notes.md)."""
    global _pool, _pool_size
    with _pool_lock:
        if _pool is None or _pool_size < count:
            if _pool is not None:
                _pool.shutdown(wait=False)
            _pool, _pool_size = ThreadPoolExecutor(count, thread_name_prefix="pcsg"), count
        return _pool


def _forget_pool() -> None:
    # a forked child has the pool but not its threads: jobs given to it would never run
    global _pool, _pool_lock, _pool_size
    _pool, _pool_size, _pool_lock = None, 0, threading.Lock()


os.register_at_fork(after_in_child=_forget_pool)


def on_threads(fn, workers: int, *args) -> None:
    """fn(w, workers, *args) for every worker w: worker 0 on the calling thread, the
    others each on a thread of the pool (fn is a `share` and releases the GIL). Not
    numba's prange: its parallel passes over such a body gave wrong hits, and compiling
    the parallel wrapper around an already compiled share took 20 to 30 s more."""
    if workers <= 1:
        fn(0, 1, *args)
        return
    jobs = [_helpers(workers - 1).submit(fn, w, workers, *args) for w in range(1, workers)]
    try:
        fn(0, workers, *args)
    finally:
        wait(jobs)      # the others' shares write into the caller's arrays
    for job in jobs:
        job.result()


def stoppable(fn, workers: int, *args, tick=None, every: float = 0.05) -> None:
    """fn(w, workers, stop, *args) for every worker w, all on helper threads while this
    thread waits, calling tick() every `every` seconds if given. Ctrl-C (or SIGTERM), or
    an exception from tick, sets stop[0], which the shares read before each chunk of
    rays, and is raised once they have stopped. Run on this thread as on_threads runs
    share 0, a batch of a heavy render (the terrain at 12 with area lights: 4 to 6 s)
    held Ctrl-C, SIGTERM and --timeout until it ended. The hand-over costs a 640x480
    render of Sierpinski 6 about 2.5 ms of its 80 (medians of 20 in one process;
    tools/performance_notes.md)."""
    import numpy as np
    stop = np.zeros(1, dtype=np.int64)
    _run_watched([(fn, (w, workers, stop, *args)) for w in range(workers)], stop, tick,
                 every)


def watched(calls, watch, tick=None, every: float = 0.05) -> list:
    """Each call (fn, args) on a helper thread while this thread waits, calling tick()
    every `every` seconds (progress, a deadline); returns their results. Ctrl-C, or an
    exception from tick, sets watch[0], which the walks read every few milliseconds
    (boxwalk.walk_in), and is raised once they have stopped: a walk of several seconds
    on this thread would hold the signal until it ended."""
    return _run_watched(calls, watch, tick, every)


def _run_watched(calls, flag, tick, every: float) -> list:
    """The calls on the helper pool, this thread waiting on an Event their completions
    set, not in concurrent.futures.wait: an interrupt that lands in wait() while it takes
    the futures' locks one by one leaves some held, and the next wait, or a helper's
    set_result, blocks for ever (animate's worker hung so on SIGTERM, once in 20 under
    load). An exception here sets flag[0] and is raised once every call has ended."""
    if not calls:
        return []
    finished = threading.Event()
    lock = threading.Lock()
    left = [len(calls)]

    def one_ended(_job):
        with lock:
            left[0] -= 1
            if left[0] == 0:
                finished.set()
    jobs = []
    try:
        for fn, args in calls:
            jobs.append(_helpers(len(calls)).submit(fn, *args))
            jobs[-1].add_done_callback(one_ended)
        while not finished.wait(every if tick is not None else None):
            tick()
    except BaseException:
        flag[0] = 1
        for job in jobs:            # a poll, which takes no lock across an interrupt
            # but not for a helper in a kernel's first compile, which reads no flag and
            # held Ctrl-C and SIGTERM for minutes (trace/compiling.py)
            while not job.done() and not compiling.threads:
                time.sleep(0.001)
        raise
    return [job.result() for job in jobs]
