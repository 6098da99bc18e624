"""Where pcsg keeps what it makes once and reads again: the systems' compiled blocks,
long bounding walks, numba's runtime functions."""
from __future__ import annotations

import os
from pathlib import Path


def cache_dir() -> Path:
    """PCSG_CACHE_DIR, else pcsg under XDG_CACHE_HOME or ~/.cache."""
    if os.environ.get("PCSG_CACHE_DIR"):
        return Path(os.environ["PCSG_CACHE_DIR"])
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "pcsg"
