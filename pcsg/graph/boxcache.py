"""The bounding walk's results kept on disk, for the next render of the same system.

A system bounded instance by instance walks every instance before its first ray: the
terrain at order 12, 44 million of them, for 5 to 7 s of a 9 to 10 s render. Its boxes
depend on the system (with its --set values), the depth and visit budget of the walk,
and the walk's code, and on nothing a render changes from run to run (camera, size,
lights, samples, threads), so a user who renders the same terrain again, from another
eye or at another size, gets them from here: the same boxes and table to the bit, hence
the same picture.

The key hashes what the walk reads: every array of its Flat but the addresses of the
compiled blocks (which change from process to process; their code is `vm_code`), the
walk's arguments, and the sources of the kernels (pcsg.trace.kernel_digest). An entry is
one .npz file, written whole and then renamed; one that cannot be read is walked again.
Only walks of at least MIN_VISITS node visits are kept (below that, the walk costs
little more than reading it back), and the folder is kept under LIMIT bytes, the entries
read least recently removed first. PCSG_BOUNDS_CACHE=0 turns it off."""
from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path

import numpy as np

from ..trace import kernel_digest
from ..caches import cache_dir

FORMAT = 2                  # 2: the walk's faults kept beside its result
# the terrain at 7 (212 k visits) and deeper: its bounds phase takes 0.16 to 0.21 s
# walked on 2 cores and 0.10 s read back, at 9 (3.3 M) 0.27 to 0.29 s and 0.10 s; most
# of a read is flattening the graph and loading its blocks, which a walk does as well
MIN_VISITS = 200_000
LIMIT = 1 << 30             # bytes on disk: an entry of the terrain at 9 to 12 is 14 MB
SKIP = ("calc_fn", "arg_fn")    # addresses of compiled code: per process

hits = 0                    # entries read in this process (the timings say so)


def enabled() -> bool:
    return os.environ.get("PCSG_BOUNDS_CACHE", "1") != "0"


def folder() -> Path:
    return cache_dir() / "bounds"


def key(flat, *arguments) -> str:
    h = hashlib.sha256(f"{FORMAT} {kernel_digest()} {arguments!r}".encode())
    for name, value in zip(flat._fields, flat):
        if name in SKIP:
            continue
        a = np.ascontiguousarray(value)
        h.update(f"{name} {a.dtype.str} {a.shape}".encode())
        h.update(a.tobytes())
    return h.hexdigest()[:32]


def load(k: str):
    """walk_boxes's result and faults (boxwalk.faults_of) kept under key k, or None."""
    global hits
    path = folder() / f"{k}.npz"
    try:
        with np.load(path) as z:
            boxes, depth, complete = z["boxes"], int(z["depth"]), bool(z["complete"])
            table = z["keys"], z["used"], z["vals"]
            found = tuple((int(c), int(n)) for c, n in z["faults"])
        os.utime(path)          # read recently: removed last
    except Exception:       # noqa: BLE001 -- missing, cut short, another format: walk
        return None
    hits += 1
    return (boxes, complete, table, depth), found


def store(k: str, result, found) -> None:
    """Keeps walk_boxes's result under key k; a folder that cannot be written keeps
    nothing (the cache is only ever a speed-up)."""
    boxes, complete, table, depth = result
    keys, used, vals = table          # the entries as a list (instance_table.gather)
    where = folder()
    tmp = None
    try:
        where.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=where, suffix=".tmp")
        with os.fdopen(fd, "wb") as f:
            np.savez(f, boxes=boxes, depth=depth, complete=complete, keys=keys, used=used,
                     vals=vals, faults=np.array(found, dtype=np.int64))
        os.replace(tmp, where / f"{k}.npz")
        _trim(where)
    except BaseException as e:      # noqa: BLE001 -- a full disk, a read-only folder: keep
        if tmp is not None:         # nothing; Ctrl-C, SIGTERM: no .tmp left either (_trim
            Path(tmp).unlink(missing_ok=True)      # counts only entries), and go on up
        if not isinstance(e, Exception):
            raise


def _trim(where: Path) -> None:
    entries = []
    for p in where.glob("*.npz"):
        try:
            s = p.stat()
        except OSError:
            continue
        entries.append((s.st_mtime, s.st_size, p))
    total = sum(size for _, size, _ in entries)
    for _, size, p in sorted(entries):
        if total <= LIMIT:
            break
        p.unlink(missing_ok=True)
        total -= size
