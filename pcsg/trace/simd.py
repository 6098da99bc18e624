"""One ray against four boxes at once, in LLVM's 4-wide vector instructions.

A union of the terrain or of the Sierpinski tetrahedron has four children, each with
its box; the packets test every ray of a frame against all four (packet.split_quad),
which took about a third of the terrain's camera rays' time as four scalar tests. numba compiles the four slab tests
written out in Python to scalar code, even side by side (LLVM's SLP vectoriser leaves
them: the boxes are read through array strides), so this writes them as vector IR: the
same comparisons and selects as windows._slab and Python's max and min as numba lowers
them (ordered compares, then select), so the windows are the same to the bit."""
from __future__ import annotations

from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from .windows import FAR

LANES = 4


@intrinsic
def quad_windows(typingctx, boxes, ox, oy, oz, ix, iy, iz, w0, w1):
    """(entry 0..3, exit 0..3): the window [w0, w1] of the ray at (ox, oy, oz) with
    inverse direction (ix, iy, iz) narrowed to each of the four boxes whose rows x0, y0,
    z0, x1, y1, z1 are the rows of `boxes` (a C-contiguous (6, 4) float64 array), as
    max(w0, t0), min(w1, t1) of windows.slabs; the window is empty where entry > exit."""
    if not (isinstance(boxes, types.Array) and boxes.ndim == 2 and boxes.layout == "C"
            and boxes.dtype == types.float64):
        return None
    sig = types.UniTuple(types.float64, 2 * LANES)(boxes, *[types.float64] * 8)

    def codegen(context, builder, signature, args):
        table, *scalars = args
        array = context.make_array(signature.args[0])(context, builder, table)
        double = ir.DoubleType()
        vec = ir.VectorType(double, LANES)
        i8 = ir.IntType(8).as_pointer()
        row_bytes = builder.extract_value(array.strides, 0)
        base = builder.bitcast(array.data, i8)

        def row(a):
            at = builder.gep(base, [builder.mul(row_bytes, ir.Constant(row_bytes.type, a))])
            return builder.load(builder.bitcast(at, vec.as_pointer()), align=8)

        def splat(x):
            one = builder.insert_element(ir.Constant(vec, ir.Undefined), x,
                                         ir.Constant(ir.IntType(32), 0))
            return builder.shuffle_vector(one, ir.Constant(vec, ir.Undefined),
                                          ir.Constant(ir.VectorType(ir.IntType(32), LANES),
                                                      None))

        def pick(pred, a, b):               # a where pred, else b
            return builder.select(pred, a, b)

        o = [splat(v) for v in scalars[0:3]]
        inv = [splat(v) for v in scalars[3:6]]
        t0 = splat(ir.Constant(double, -FAR))
        t1 = splat(ir.Constant(double, FAR))
        for axis in range(3):               # windows._slab
            ta = builder.fmul(builder.fsub(row(axis), o[axis]), inv[axis])
            tb = builder.fmul(builder.fsub(row(axis + 3), o[axis]), inv[axis])
            swap = builder.fcmp_ordered(">", ta, tb)
            lo, hi = pick(swap, tb, ta), pick(swap, ta, tb)
            t0 = pick(builder.fcmp_ordered(">", lo, t0), lo, t0)
            t1 = pick(builder.fcmp_ordered("<", hi, t1), hi, t1)
        lo_w, hi_w = splat(scalars[6]), splat(scalars[7])
        e0 = pick(builder.fcmp_ordered(">", lo_w, t0), lo_w, t0)     # max(t0, w0)
        e1 = pick(builder.fcmp_ordered("<", hi_w, t1), hi_w, t1)     # min(t1, w1)
        lanes = [builder.extract_element(v, ir.Constant(ir.IntType(32), k))
                 for v in (e0, e1) for k in range(LANES)]
        return context.make_tuple(builder, signature.return_type, lanes)

    return sig, codegen
