"""A walker's working memory: one set per worker thread, allocated once per kernel
call and reused by every ray it traces (no ray reads what an earlier one left)."""
from __future__ import annotations

from collections import namedtuple

import numpy as np

from .dispatch import cached_jit
from ..limits import LIM_INSTANCES, LIM_ROWS, LIM_STACK
from .nodes import F_WIDTH, I_WIDTH

IV_WIDTH = 16
CALC_CACHE_SLOTS = 4096      # a power of two
CANDIDATES = 4      # wide operators nested in one interval walk before the next loops over
                    # every operand (walk.candidates)

Scratch = namedtuple("Scratch", [
    "params",   # (2 * stack + 1, n_params) parameter states by slot, and a spare
    "F", "I", "H",          # the first-hit walk's frames (nodes.py columns)
    "Fi", "Ii", "Hi",       # the interval walk's frames
    "iv",       # (interval_rows, IV_WIDTH) interval lists of ∩ and \\ subtrees
    "lists",    # (2 * stack + 3, 2) their [start, count] stack (a union with an operand
                #   tree holds two entries: its candidates' and its list: walk.intervals)
    "stack",    # the expression machine's value stack
    "args",     # T- and paint-node arguments
    "m34",      # a T-node's 3x4 map
    "out8",     # a primitive's hit
    "order", "keys", "hashes", "phases",  # union children sorted by their window, their
                                          # hashes and the PHASE their frames start in
    "ckeys", "cvals",       # the cache of calculated states (nodes.cached_calc)
    "cands",    # operands of the wide unions and differences an interval walk is in
                #   (walk.candidates), as many as CANDIDATES lists of the widest's
    "visits",   # [S-node instances the current ray entered, the most it may]
    "m21",      # a T-node's map with its inverse (nodes.transform_map)
])


@cached_jit(error_model="numpy")
def make_scratch(flat, limits):
    stack_depth = limits[LIM_STACK]
    # a loop, not calc_cache.any(): numba's any() is in numba.np.arraymath, which the cached
    # kernel's environment then imported at every load, 9 ms of every render
    slots = 1
    for cached in flat.calc_cache:
        if cached:
            slots = CALC_CACHE_SLOTS
            break
    return Scratch(
        np.full((2 * stack_depth + 1, flat.n_params), np.nan),    # + the spare (deferred.py)
        np.empty((stack_depth, F_WIDTH)), np.zeros((stack_depth, I_WIDTH), dtype=np.int64),
        np.zeros(stack_depth, dtype=np.uint64),
        np.empty((stack_depth, F_WIDTH)), np.zeros((stack_depth, I_WIDTH), dtype=np.int64),
        np.zeros(stack_depth, dtype=np.uint64),
        np.empty((limits[LIM_ROWS], IV_WIDTH)), np.zeros((2 * stack_depth + 3, 2), dtype=np.int64),
        np.empty(flat.max_stack), np.empty(12), np.empty((3, 4)), np.empty(8),
        np.empty(flat.max_children, dtype=np.int64), np.empty((flat.max_children, 2)),
        np.empty(flat.max_children, dtype=np.uint64), np.empty(flat.max_children, dtype=np.int64),
        np.zeros(slots, dtype=np.uint64), np.empty((slots, flat.n_params)),
        np.empty(CANDIDATES * flat.max_children if flat.tree_skip.shape[0] else 1,
                 dtype=np.int64),
        np.array([0, limits[LIM_INSTANCES]], dtype=np.int64), np.empty(24))
