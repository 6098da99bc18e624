"""Where units run: here, one after another, or on a Dask cluster. The only module that
imports Dask, and only when a cluster is asked for."""
from __future__ import annotations

import logging
import os
import signal
import socket
import struct

# pcsg is installed from its checkout: 'pcsg' on PyPI is another project
INSTALL_HINT = ("--workers and --scheduler need Dask: pip install '/path/to/pcsg[dask]', the "
                "path of pcsg's checkout (in it: bash tools/test.sh sets up .venv with Dask)")
RETRIES = 2             # a task that raised runs again, elsewhere if need be
LOCAL = "this process"
PROBE_WAIT = 10.0       # seconds for a --scheduler to open with its handshake
MAX_HANDSHAKE = 1 << 20  # bytes: a scheduler's handshake is a few hundred


class ClusterUnavailable(Exception):
    """Dask is not installed, or the scheduler cannot be reached: a usage error."""


class LocalRunner:
    """No cluster: the units in order, in this process (--tiles, sweeps)."""
    workers = 1

    def run(self, fn, items):
        for item in items:
            yield item, fn(item), LOCAL, None

    def call(self, fn, *args):
        return fn(*args)

    def close(self):
        pass


def _on_worker(fn, item):
    """Runs on a worker: the result and which worker it was, for the progress lines."""
    from distributed import get_worker
    return get_worker().address, fn(item)


class DaskRunner:
    """Units as Dask tasks; results stream back in the order they finish. A worker that
    dies loses its tasks to the others (the scheduler reruns them); a task that raised
    is retried RETRIES times."""

    def __init__(self, client, cluster=None):
        self.client, self.cluster = client, cluster

    @property
    def workers(self) -> int:
        return len(self.client.scheduler_info(n_workers=-1)["workers"])

    def run(self, fn, items):
        from distributed import as_completed
        pending = {self.client.submit(_on_worker, fn, item, retries=RETRIES, pure=False): item
                   for item in items}
        for future in as_completed(list(pending)):
            item = pending.pop(future)      # dropping it lets the cluster free the result
            try:
                worker, result = future.result()
                yield item, result, worker, None
            except Exception as e:          # noqa: BLE001 -- one unit failed, not the batch
                yield item, None, None, e
            finally:
                future.release()

    def call(self, fn, *args):
        return self.client.submit(fn, *args, retries=RETRIES, pure=False).result()

    def close(self):
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()


def require_dask():
    """Before any work: say how to install Dask rather than fail on an import."""
    try:
        import distributed  # noqa: F401
    except ImportError:
        raise ClusterUnavailable(INSTALL_HINT) from None


def connect(workers: int | None = None, scheduler: str | None = None) -> DaskRunner:
    """A local cluster of `workers` processes, or the cluster at `scheduler`."""
    require_dask()
    from distributed import Client, LocalCluster
    if scheduler:
        if problem := not_a_scheduler(scheduler):
            raise ClusterUnavailable(f"--scheduler {scheduler}: {problem}")
        _silence_dask()
        try:
            client = Client(scheduler, timeout="20s")
        except (OSError, TimeoutError) as e:
            raise ClusterUnavailable(f"--scheduler {scheduler}: cannot connect ({e})") from None
        try:
            _check_workers(client, scheduler)
        except BaseException:
            client.close()
            raise
        return DaskRunner(client)
    # one thread per worker process: numba's own threads share the cores among the workers
    threads = max(1, (os.cpu_count() or 1) // workers)
    # the worker processes start with SIGINT ignored, which Python keeps so: a Ctrl-C at
    # a terminal reaches the whole process group, and each worker printed the traceback
    # of its KeyboardInterrupt beside `pcsg: interrupted`; this process closes them
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               host="127.0.0.1", dashboard_address=":0",   # not 8787: taken?
                               silence_logs=logging.CRITICAL,   # no tracebacks at shutdown
                               env={"NUMBA_NUM_THREADS": str(threads)})
    finally:
        signal.signal(signal.SIGINT, previous)
    return DaskRunner(Client(cluster), cluster)


def _silence_dask():
    """Dask's client logged its own tracebacks where the scheduler went away mid-run;
    each image that fails says so (batch.py), as a LocalCluster's logs are silenced
    (silence_logs). Its loggers' records all reach the handler of "distributed", whose
    own loggers keep levels of their own."""
    for handler in logging.getLogger("distributed").handlers:
        if isinstance(handler, logging.StreamHandler):
            handler.setLevel(logging.CRITICAL)


def not_a_scheduler(address: str, wait: float = PROBE_WAIT) -> str | None:
    """Why a tcp:// address is no Dask scheduler, by the first bytes it sends on
    connecting (a scheduler opens with its handshake: a message of a few hundred bytes,
    its length first, 8 bytes little-endian); None where it may be one, or where the
    scheme is not tcp. Dask's client read an HTTP server's reply as that length and
    asked for 3 EiB (an internal error, MemoryError), and waited without end on a server
    that says nothing first (its timeout covers the connection, not the handshake)."""
    scheme, _, rest = address.partition("://")
    if scheme != "tcp":
        return None
    host, _, port = rest.rpartition(":")
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=wait) as s:
            s.settimeout(wait)
            head = b""
            while len(head) < 8:
                more = s.recv(8 - len(head))
                if not more:
                    break
                head += more
    except socket.timeout:
        return (f"it accepted the connection but sent nothing within {wait:g} s, as a Dask "
                f"scheduler would at once: is it one?")
    except OSError:
        return None         # Dask's own connect says why, after its retries
    if len(head) < 8:
        return "it closed the connection at once: it is not a Dask scheduler"
    (length,) = struct.unpack("<Q", head)
    if not 0 < length <= MAX_HANDSHAKE:
        start = head.decode("latin-1")
        return (f"it is not a Dask scheduler (it answered {start!r}..."
                f"{', a web server?' if start.startswith('HTTP') else ''})")
    return None


def _pcsg_version() -> str:
    from .. import __version__
    return __version__


def _check_workers(client, scheduler: str, wait: float = 60):
    """A cluster without workers would wait forever; one without pcsg (or another
    version) would fail every task or draw other pictures."""
    try:
        client.wait_for_workers(1, timeout=wait)
    except TimeoutError:
        raise ClusterUnavailable(f"--scheduler {scheduler}: no worker joined within "
                                 f"{wait:g} s (start some: dask worker {scheduler})") from None
    try:
        versions = client.run(_pcsg_version)
    except Exception as e:          # noqa: BLE001 -- a worker that cannot import pcsg
        raise ClusterUnavailable(f"--scheduler {scheduler}: the workers cannot run pcsg "
                                 f"({type(e).__name__}: {e}); install the same pcsg on "
                                 f"each") from None
    mine = _pcsg_version()
    other = sorted({f"{w} has {v}" for w, v in versions.items() if v != mine})
    if other:
        raise ClusterUnavailable(f"--scheduler {scheduler}: pcsg {mine} here, but "
                                 + ", ".join(other))
