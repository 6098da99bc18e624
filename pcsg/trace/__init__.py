"""The njit side: expression machine, transformations, primitives, walks.

numba's on-disk cache checks only the file of the function it caches, not the
files of the functions it calls, so a kernel in kernel.py would keep running an
old copy of walk.py after an upgrade. The guard below drops the cached kernels
whenever any source they are built from changes."""
from __future__ import annotations

import functools
import hashlib
from pathlib import Path

from . import (cacheload, compilestack, compiling, inlinecopy, inlinepasses, livebits,
               ssablocks)


def _cache_dirs(here: Path) -> list[Path]:
    """Where numba keeps this package's kernels: beside the sources, and under
    NUMBA_CACHE_DIR when that is set (the test command's bounds-check pass)."""
    dirs = [here / "__pycache__"]
    from numba.core import config
    if config.CACHE_DIR:
        from numba.core.caching import _CacheLocator
        dirs.append(Path(config.CACHE_DIR)
                    / _CacheLocator.get_suitable_cache_subpath(str(here / "kernel.py")))
    return dirs


@functools.cache
def kernel_digest() -> str:
    """A hash of every source the kernels are built from."""
    here = Path(__file__).resolve().parent
    sources = sorted(here.glob("*.py")) + [here.parent / "graph" / "model.py",
                                           here.parent / "language" / "names.py"]
    return hashlib.sha256(b"".join(p.read_bytes() for p in sources)).hexdigest()


def _refresh_kernel_cache() -> None:
    here = Path(__file__).resolve().parent
    digest = kernel_digest()
    for cache in _cache_dirs(here):
        stamp = cache / "pcsg-kernels.sha256"
        try:
            if stamp.read_text() == digest:
                continue
        except OSError:
            pass
        try:
            cache.mkdir(parents=True, exist_ok=True)
            for f in list(cache.glob("*.nbi")) + list(cache.glob("*.nbc")):
                f.unlink(missing_ok=True)
            stamp.write_text(digest)
        except OSError:
            pass    # a read-only install: numba keeps its cache in the user's directory


_refresh_kernel_cache()
cacheload.install()
compilestack.install()
inlinecopy.install()
compiling.install()
inlinepasses.install()
ssablocks.install()
livebits.install()
