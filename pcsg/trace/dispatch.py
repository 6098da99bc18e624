"""numba's dispatchers, set up at their first compile rather than at import.

A render whose kernels load from numba's cache never compiles most of pcsg's ~140
jitted functions: the per-node steps are inlined into the walks, and the small helpers
are inside the cached kernels already. numba does two things for each of them at
import that only a compile needs:
- `cache=True` locates the cache directory and proves it writable by making and
  removing a file there, about 60 µs a function;
- a declared signature (`njit("uint64(uint64)")`) compiles it, or loads it from the
  cache, there and then: the nine of vm.py took 12 ms of every `pcsg` command (4 ms of
  it numba's runtime set up for the first, which the first kernel's load does now).
Here both wait for the first compile: a call from Python, a kernel's compile typing a
call to it, or `cached()` below. Under NUMBA_DISABLE_JIT the functions stay Python.

And an argument of plain arrays (an array, or tuples of arrays and scalars such as the
Flat) is typed without numba's test for a masked array, which imported `numpy.ma`, 8 ms,
the first time a process passed an array to any jitted function."""
from __future__ import annotations

import numpy as np
from numba import njit
from numba.core import errors, typeinfer, types
from numba.core.compiler_lock import global_compiler_lock
from numba.core.registry import CPUDispatcher
from numba.core.typing.typeof import Purpose, typeof
from numba.np import numpy_support


class CachedLater(CPUDispatcher):
    """njit(cache=True)'s dispatcher, its on-disk cache made at the first compile."""

    def compile(self, sig):
        self.cached()
        return super().compile(sig)

    def cached(self) -> CachedLater:
        """Itself, with numba's on-disk cache set up (its `_cache`)."""
        with global_compiler_lock:      # threads: one sets it up, the others wait for it
            if self.__dict__.pop("_cache_later", False):
                self.enable_caching()
        return self

    def typeof_pyval(self, val):
        # numba's dispatcher asks this the first time it meets an argument of a new kind
        tp = argument_type(val)
        if tp is None:
            return super().typeof_pyval(val)
        self._types_active_call.add(tp)
        return tp


def argument_type(val):
    """numba's type of an argument, as `numba.typeof` gives it, for plain arrays and
    tuples (named or not) of them and of what numba types without looking at an array;
    None for anything else, and where numba's own typeof should decide (or fail)."""
    if type(val) is np.ndarray:
        return array_type(val)
    if isinstance(val, np.ndarray):
        return None                     # a subclass: a masked array among them
    if isinstance(val, tuple):          # as typing/typeof.py's _typeof_tuple
        tys = [argument_type(v) for v in val]
        if any(t is None for t in tys):
            return None
        return types.BaseTuple.from_types(tys, type(val))
    try:
        return typeof(val, Purpose.argument)
    except (errors.NumbaValueError, ValueError):
        return None


def array_type(val: np.ndarray):
    """numba's type of a plain ndarray, as numba's typeof gives it (typing/typeof.py,
    _typeof_ndarray) without its test for a masked array, which no plain ndarray is; None
    for a dtype numba types otherwise, so that numba's own typeof decides (and fails)."""
    try:
        dtype = numpy_support.from_dtype(val.dtype)
    except errors.NumbaNotImplementedError:
        return None
    return types.Array(dtype, val.ndim, numpy_support.map_layout(val),
                       readonly=not val.flags.writeable)


class Declared(CachedLater):
    """njit(signature, cache=True)'s dispatcher, compiled for its signature at the first
    use. That compiles the declared signature alone and then disables compiling, as
    njit(signature) does, so that calls convert their arguments to it."""

    def _declare(self):
        with global_compiler_lock:
            signature = self.__dict__.pop("_signature", None)
            if signature is not None:
                with typeinfer.register_dispatcher(self):
                    self.compile(signature)
                self.disable_compile()

    def get_call_template(self, args, kws):
        self._declare()
        return super().get_call_template(args, kws)

    def _compile_for_args(self, *args, **kws):
        self._declare()
        if self._can_compile:           # never declared (a copy unpickled without it)
            return super()._compile_for_args(*args, **kws)
        return self      # numba's dispatcher calls what this returns: itself, declared now


def cached_jit(**options):
    """njit(cache=True, **options), the cache set up at the first compile."""
    return lambda f: _become(njit(**options)(f), CachedLater, _cache_later=True)


def declared(signature: str, **options):
    """njit(signature, cache=True, **options), compiled at the first use."""
    return lambda f: _become(cached_jit(**options)(f), Declared, _signature=signature)


def _become(dispatcher, cls, **state):
    """The dispatcher made a `cls` with `state`; a plain function (NUMBA_DISABLE_JIT) as
    it is."""
    if isinstance(dispatcher, CPUDispatcher):
        dispatcher.__class__ = cls
        dispatcher.__dict__.update(state)
    return dispatcher


def cached(dispatcher):
    """The dispatcher with its on-disk cache set up, for code that reads numba's cache
    index; anything else (a plain function under NUMBA_DISABLE_JIT) as it is."""
    return dispatcher.cached() if isinstance(dispatcher, CachedLater) else dispatcher
