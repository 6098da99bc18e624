"""Tracing many rays: fixed chunks of rays shared out among the workers, so every
ray's result and every chunk's event counts are the same at any thread count."""
from __future__ import annotations

import numpy as np

from .jit import share, stoppable
from .packet import PACKET, make_packet, trace
from .scratch import make_scratch
from .walk import R_WIDTH

CHUNK = PACKET


def trace_rays(flat, origins, directions, cones, tmin, tmax, any_hit, lod, max_depth, limits,
               workers, together, out, events):
    """out[i] = the R_* row of ray i; events[chunk] counts per event kind and node.
    cones[i]: the width ray i starts with (0 for a camera ray), to which a fractal's
    surface is marched with lod's spread (trace/fractals.py).
    With `together`, a chunk's rays walk the graph as one packet (packet.py). Ctrl-C
    stops it after the chunk each worker is tracing (jit.stoppable)."""
    stoppable(trace_share, workers, flat, origins, directions, cones, tmin, tmax, any_hit,
              lod, max_depth, limits, together, out, events)


@share
def trace_share(w, workers, stop, flat, origins, directions, cones, tmin, tmax, any_hit, lod,
                max_depth, limits, together, out, events):
    """Worker w's share: every workers-th chunk, with scratch of its own, allocated once
    per call (fresh pages per chunk cost a tenth of the time), until stop[0] is set."""
    n = origins.shape[0]
    chunks = (n + CHUNK - 1) // CHUNK
    S = make_scratch(flat, limits)
    P = make_packet(flat)
    res = np.empty((PACKET, R_WIDTH))
    for c in range(w, chunks, workers):
        if stop[0] != 0:
            break
        i0 = c * CHUNK
        m = min(n, i0 + CHUNK) - i0
        for k in range(m):
            for a in range(3):
                P.O[k, a] = origins[i0 + k, a]
                P.D[k, a] = directions[i0 + k, a]
            P.cone[k] = cones[i0 + k]
        trace(flat, m, tmin, tmax, any_hit, lod, max_depth, S, P, together, events[c], res)
        out[i0:i0 + m] = res[:m]
