"""Operand fusion for the tracer's bytecode: LOAD p or CONST c followed by a binary
operator becomes one BIN_LOAD / BIN_CONST row (vm.py), so the machine dispatches
about a third fewer rows. Jumps are relative, so their distances are remapped;
a row that a jump lands on, or that starts a range, is never folded into the row
before it."""
from __future__ import annotations

import numpy as np

from ..trace import vm

JUMPS = (vm.JUMP, vm.JUMP_IF_FALSE, vm.AND_JUMP, vm.OR_JUMP)
_MAX_OPERAND = 1 << (31 - vm.OP_BITS)


def fuse_operands(code: np.ndarray, range_starts) -> tuple[np.ndarray, np.ndarray]:
    """The fused code and, for every old row index 0..len(code), its new index."""
    n = len(code)
    ops = code[:, 0].tolist()
    args = code[:, 1].tolist()
    fixed = set(range_starts)
    fixed.update(r + args[r] for r in range(n) if ops[r] in JUMPS)
    fusable = set(vm.FUSABLE)
    new_ops, new_args, jumps = [], [], []
    remap = np.zeros(n + 1, dtype=np.int64)
    r = 0
    while r < n:
        remap[r] = len(new_ops)
        op, arg = ops[r], args[r]
        if (op in (vm.LOAD, vm.CONST) and r + 1 < n and ops[r + 1] in fusable
                and r + 1 not in fixed and arg < _MAX_OPERAND):
            remap[r + 1] = len(new_ops)
            new_ops.append(vm.BIN_LOAD if op == vm.LOAD else vm.BIN_CONST)
            new_args.append((arg << vm.OP_BITS) | ops[r + 1])
            r += 2
            continue
        if op in JUMPS:
            jumps.append((len(new_ops), r + arg))
        new_ops.append(op)
        new_args.append(arg)
        r += 1
    remap[n] = len(new_ops)
    for row, target in jumps:
        new_args[row] = int(remap[target]) - row
    out = np.empty((len(new_ops), 2), dtype=np.int32)
    out[:, 0] = new_ops
    out[:, 1] = new_args
    return out, remap
