"""numba's inlining, a callee's untyped passes run once per compile of a kernel.

To inline a call to an `inline="always"` function (the walks' steps), numba runs the
callee's whole untyped pipeline at that call site (`InlineWorker.inline_function`), from
its bytecode up, and that pipeline inlines the callee's own callees the same way: a step
inlined at a dozen sites was translated a dozen times, and each of its callees again for
each of those: 44 s of a 277 s profile of the tracing kernels' compile, and about 5 s of
130 s without the profiler (README, "Compiling the kernels"). What the pipeline gives
depends on the function, on the compile's flags and on the globals the function reads,
which stay the same during one compile; so within one compile of a kernel the first
site's IR serves the later ones (kept in that compile's dict, `compiling.this_compile`).
The inliner copies a callee's IR before it changes anything (its `inline_ir` starts so),
and names the inlined variables after the callee's FunctionIdentity, which each site
still gets new (`derive`), as numba's own run gives it one."""
from __future__ import annotations

import copy

from numba.core import inline_closurecall

from . import compiling

NUMBA_INLINE_FUNCTION = inline_closurecall.InlineWorker.inline_function


def inline_function(self, caller_ir, block, i, function, arg_typs=None):
    scope = compiling.this_compile()
    if scope is None or self.locals:
        # outside a dispatcher's compile, or with locals declared, which numba's with-
        # lifting passes on: numba's own way
        return NUMBA_INLINE_FUNCTION(self, caller_ir, block, i, function, arg_typs)
    # run_untyped_passes sets this on the caller's flags: so does a site served here
    self.flags.enable_ssa = False
    memo = scope.setdefault(__name__, {})
    key = (function, id(self.targetctx), repr(self.flags))
    first = memo.get(key)
    if first is None:
        first = memo[key] = self.run_untyped_passes(function)
    site = copy.copy(first)
    site.func_id = first.func_id.derive()
    return self.inline_ir(caller_ir, block, i, site, function.__code__.co_freevars,
                          arg_typs=arg_typs)


def install() -> None:
    """For numba 0.68, whose inliner this follows; another numba keeps its own way."""
    if compiling.numba_followed() and \
            inline_closurecall.InlineWorker.inline_function is NUMBA_INLINE_FUNCTION:
        inline_closurecall.InlineWorker.inline_function = inline_function
