"""Tracing many rays: fixed chunks of rays under prange, so every ray's result and
every chunk's event counts are the same at any thread count."""
from __future__ import annotations

from numba import njit, prange

from .scratch import make_scratch
from .walk import trace_chunk

CHUNK = 256


@njit(cache=True, parallel=True, error_model="numpy")
def trace_rays(flat, origins, directions, tmin, tmax, any_hit, lod, max_depth, limits,
               workers, out, events):
    """out[i] = the R_* row of ray i; events[chunk] counts per event kind and node.
    Each of `workers` takes every workers-th chunk with scratch of its own, allocated
    once per call: fresh pages per chunk cost a tenth of the time."""
    n = origins.shape[0]
    chunks = (n + CHUNK - 1) // CHUNK
    for w in prange(workers):
        S = make_scratch(flat, limits)
        for c in range(w, chunks, workers):
            trace_chunk(flat, origins, directions, c * CHUNK, min(n, (c + 1) * CHUNK),
                        tmin, tmax, any_hit, lod, max_depth, S, events[c], out)
