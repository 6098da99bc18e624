"""The ways the tracing kernels are compiled, and how they run on every core.

Walk code allocates nothing, so it is compiled without numba's reference
counting (`_nrt=False`): with it, every array argument and every field read from
the Flat tuple costs an atomic increment and decrement, which measured as a
fifth of the walk's time, and the per-node steps passed the whole Flat (twenty
arrays) at each call. The per-node steps are inlined into the walks."""
from concurrent.futures import ThreadPoolExecutor

from numba import config, njit

kernel = njit(cache=True, error_model="numpy", nogil=True, _nrt=False)
inline = njit(cache=True, error_model="numpy", nogil=True, _nrt=False, inline="always")
# a worker's share of a batch: it allocates its scratch, so it keeps reference counting
share = njit(cache=True, error_model="numpy", nogil=True)


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


def on_threads(fn, workers: int, *args) -> None:
    """fn(w, workers, *args) for every worker w, each on a thread of its own (fn is a
    `share` and releases the GIL). Not numba's prange: its parallel passes over such a
    body gave wrong hits, and compiling the parallel wrapper around an already compiled
    share took 20 to 30 s more."""
    if workers <= 1:
        fn(0, 1, *args)
        return
    with ThreadPoolExecutor(workers) as pool:
        for job in [pool.submit(fn, w, workers, *args) for w in range(workers)]:
            job.result()
