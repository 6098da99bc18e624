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

import os
import sys
import threading

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
    """njit(cache=True, **options), the cache set up at the first compile; the
    dispatcher itself made at its first use (Deferred)."""
    return lambda f: _deferred(f, lambda: _become(njit(**options)(f), CachedLater,
                                                  _cache_later=True))


def declared(signature: str, **options):
    """njit(signature, cache=True, **options), compiled at the first use."""
    return lambda f: _deferred(f, lambda: _become(njit(**options)(f), Declared,
                                                  _cache_later=True, _signature=signature))


class Deferred:
    """A jitted function whose numba dispatcher is made where it is first used: called,
    an attribute read, or typed by numba (numba reads `_numba_type_`). Of pcsg's ~150
    jitted functions a render whose kernels load from the cache calls some twenty; the
    others are inlined into those kernels, and making their dispatchers at import (numba
    inspects the signature and registers each with its typing context) took 8 to 10 ms
    of every command. numba compiles a function from the globals its code reads, and
    inlines a call where it finds a dispatcher there, so before it compiles anything
    every Deferred is made and every module's global that names one names its dispatcher
    instead (make_all, from numba's compilers: compile_hooks)."""

    def __init__(self, func, make):
        self.__wrapped__ = self.py_func = func
        self.__name__, self.__qualname__ = func.__name__, func.__qualname__
        self.__module__, self.__doc__ = func.__module__, func.__doc__
        self._make = make
        self._made = None

    def made(self):
        """The dispatcher (the function itself under NUMBA_DISABLE_JIT). Its own module's
        global names the dispatcher from then on, so that calls through the module reach
        it directly; names imported elsewhere call through this (0.3 µs more a call)."""
        made = self._made
        if made is None:
            with _making:
                if self._made is None:
                    self._made = self._make()
                    names = getattr(sys.modules.get(self.__module__), "__dict__", {})
                    if names.get(self.__name__) is self:
                        names[self.__name__] = self._made
                made = self._made
        return made

    def __call__(self, *args, **kwargs):
        made = self._made
        return (made if made is not None else self.made())(*args, **kwargs)

    def __getattr__(self, name):        # what the dispatcher has and this does not
        return getattr(self.made(), name)

    def __repr__(self):
        return f"<deferred {self.__qualname__}>"

    def __reduce__(self):               # by name, as pickle takes a function
        return _named, (self.__module__, self.__qualname__)


def _named(module: str, qualname: str):
    import importlib
    found = importlib.import_module(module)
    for part in qualname.split("."):
        found = getattr(found, part)
    return found


_making = threading.RLock()
_deferred_all: list[Deferred] = []
_all_made = False


def _unlocked_after_fork() -> None:
    # a child forked while another thread was making a dispatcher has the lock held by a
    # thread it does not have; what that thread had not finished, the child makes again
    global _making
    _making = threading.RLock()


os.register_at_fork(after_in_child=_unlocked_after_fork)


def _deferred(func, make):
    if _all_made:
        return make()
    d = Deferred(func, make)
    _deferred_all.append(d)
    return d


def make_all() -> None:
    """Every Deferred made, and in every module each global that names one made to name
    its dispatcher (a module imported afterwards gets dispatchers: _deferred)."""
    global _all_made
    if _all_made:
        return
    with _making:
        if _all_made:
            return
        for d in _deferred_all:
            d.made()
        for module in list(sys.modules.values()):
            try:    # not getattr: a module that loads when first read (LazyLoader) would
                names = object.__getattribute__(module, "__dict__")
            except AttributeError:
                continue
            if not isinstance(names, dict):
                continue
            for name, value in list(names.items()):
                if type(value) is Deferred:
                    names[name] = value.made()
        _all_made = True


def compile_hooks() -> None:
    """make_all before numba compiles a function (a jitted one, or a C callback) that
    its cache does not hold: cache loads need no other dispatcher."""
    from numba.core import ccallback, dispatcher
    for cls, name in ((dispatcher._FunctionCompiler, "compile"),
                      (ccallback.CFunc, "_compile_uncached")):
        original = getattr(cls, name, None)
        if original is None or getattr(original, "_pcsg_makes_all", False):
            continue

        def hooked(self, *args, _original=original, **kwargs):
            make_all()
            return _original(self, *args, **kwargs)
        hooked._pcsg_makes_all = True
        setattr(cls, name, hooked)


compile_hooks()


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
    if type(dispatcher) is Deferred:
        dispatcher = dispatcher.made()
    return dispatcher.cached() if isinstance(dispatcher, CachedLater) else dispatcher
