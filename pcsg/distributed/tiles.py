"""One image from bands of rows rendered apart (on any workers, in any order).

Memory: the bands go into a uint8 array memory-mapped on a scratch file beside the
output (3 or 4 bytes a pixel, paged by the OS, not held in RAM), each band released as
soon as it is copied there; Pillow then encodes it once, holding its own copy of 4 bytes
a pixel. A 16000x12000 poster so needs about 770 MB in the client, and each worker the
float buffers of one band (about 120 bytes a pixel)."""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

from ..output import open_atomic
from ..render.image import save_png

MAX_TILED_PIXELS = 1_000_000_000


def bands(height: int, tiles: int) -> list[tuple[int, int]]:
    """`tiles` bands of rows, as equal as can be, top to bottom."""
    edges = [height * i // tiles for i in range(tiles + 1)]
    return [(a, b) for a, b in zip(edges, edges[1:]) if b > a]


class Assembler:
    def __init__(self, out: Path, width: int, height: int, channels: int, tiles: int):
        self.out, self.left = Path(out), tiles
        fd, self.scratch = tempfile.mkstemp(prefix=f".{self.out.name}.", suffix=".tiles",
                                            dir=self.out.parent)
        os.close(fd)
        self.image = np.memmap(self.scratch, np.uint8, "w+", shape=(height, width, channels))
        self.seconds, self.rays, self.events, self.met = 0.0, 0, None, False

    def add(self, rows: tuple[int, int], samples: np.ndarray, seconds: float, rays: int,
            events: np.ndarray | None, met: bool = False) -> bool:
        """Place one band; True when it was the last. `met`: a ray of it met the object."""
        from ..trace.nodes import add_events
        self.image[rows[0]:rows[1]] = samples
        self.met = self.met or met
        self.seconds += seconds
        self.rays += rays
        if events is not None:
            self.events = events.copy() if self.events is None else add_events(self.events,
                                                                               events)
        self.left -= 1
        return self.left == 0

    def write(self):
        """The PNG, by temporary file and rename, then no scratch file."""
        try:
            with open_atomic(self.out) as f:
                save_png(f, self.image)
        finally:
            self.discard()

    def discard(self):
        self.image = None
        try:
            os.unlink(self.scratch)
        except OSError:
            pass
