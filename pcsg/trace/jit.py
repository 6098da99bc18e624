"""The two ways the tracing kernels are compiled.

Walk code allocates nothing, so it is compiled without numba's reference
counting (`_nrt=False`): with it, every array argument and every field read from
the Flat tuple costs an atomic increment and decrement, which measured as a
fifth of the walk's time, and the per-node steps passed the whole Flat (twenty
arrays) at each call. The per-node steps are inlined into the walks."""
from numba import njit

kernel = njit(cache=True, error_model="numpy", nogil=True, _nrt=False)
inline = njit(cache=True, error_model="numpy", nogil=True, _nrt=False, inline="always")
