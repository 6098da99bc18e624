"""numba's inlining, copying a callee's blocks with one memo per call site.

To inline a call (the `inline="always"` steps of the walks), numba copies the callee's
IR twice, block by block, each block with a deepcopy of its own. Every variable in a
block refers to the function's scope, which holds all of the callee's variables, so
each block's copy copies the whole scope again: blocks times variables per call site.
That was over half of the packet trace's compile (a profile: 118 million deepcopy calls
under 1,126 copies of an IR; numba issue 8989 and numba-cuda issue 688 describe the
same cost). Here the blocks copied during one call site share one memo, so the scope is
copied once and every copied block refers to that one copy, as numba asks next (it
checks that the inlined blocks have a single scope, and renames through it). A block
met a second time starts a fresh memo: a second copy of the same blocks must not share
anything with the first.

numba then copies its copy once more, to return as the callee's IR before inlining,
which neither of numba 0.68's callers of `inline_ir` reads (they take the new blocks):
under numba 0.68 a block copied at the call site is given back as it is, uncopied."""
from __future__ import annotations

import copy
import threading

from numba.core import inline_closurecall, ir

from . import compiling

_memos = threading.local()
_numbas_original_unread = False      # set by install() under numba 0.68


class _Site:
    """One call site's copies: the memo its blocks share, and the copies made."""
    def __init__(self):
        self.memo = {}
        self.made = set()


class _Copy:
    """The `copy` module as numba's inliner sees it."""
    copy = staticmethod(copy.copy)

    @staticmethod
    def deepcopy(x, memo=None):
        stack = getattr(_memos, "stack", None)
        if memo is None and stack and isinstance(x, ir.Block):
            site = stack[-1]
            if id(x) in site.made and _numbas_original_unread:
                return x
            if id(x) in site.memo:
                site.memo = {}
            y = copy.deepcopy(x, site.memo)
            site.made.add(id(y))
            return y
        return copy.deepcopy(x, memo)


NUMBA_INLINE_IR = inline_closurecall.InlineWorker.inline_ir


def inline_ir(self, *args, **kwargs):
    stack = _memos.__dict__.setdefault("stack", [])
    stack.append(_Site())
    try:
        return NUMBA_INLINE_IR(self, *args, **kwargs)
    finally:
        stack.pop()


def install() -> None:
    """Where numba's inliner reaches `copy` through its module, as numba 0.68 does: a
    numba that copies otherwise keeps its own way."""
    global _numbas_original_unread
    if getattr(inline_closurecall, "copy", None) is copy:
        _numbas_original_unread = compiling.numba_followed()
        inline_closurecall.copy = _Copy
        inline_closurecall.InlineWorker.inline_ir = inline_ir
