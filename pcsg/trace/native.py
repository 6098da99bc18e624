"""Calculation blocks compiled to machine code, for the systems that run them by the
million (the terrain's bounding walk runs one per instance).

The expression machine (vm.py) decodes each row of a block as it runs it: 261 to 414 ns
for one of the terrain's subdivision blocks (105 and 153 rows). A block without jumps (no
`if`, `&&` or `||`) keeps the same stack depth at every row, so its stack slots can be
local variables: each row becomes one statement, the expression the machine evaluates for
that opcode (BINARY, UNARY below), in the machine's order. numba compiles that to what
the arithmetic costs, 21 to 33 ns for those blocks, with the same results to the bit: the
same operations on the same values (tests/test_native.py holds every opcode to it).

The blocks of a system are written to one module in the user's cache directory, named
after a hash of its source, and compiled as C callbacks with numba's on-disk cache: 1.6 s
for the terrain's eleven blocks the first time it is rendered, 27 ms to load them after
that. The kernels call a block through its address (call_block), so the cached kernels
serve every system. Blocks shorter than MIN_ROWS rows stay on the machine, as do blocks
with jumps; PCSG_NATIVE=0 keeps every block there."""
from __future__ import annotations

import functools
import hashlib
import importlib.util
import os
import sys
import tempfile
from pathlib import Path

import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from . import vm

MIN_ROWS = 24           # shorter blocks cost little more on the machine than a call
SIGNATURE = "void(CPointer(float64), CPointer(float64), uint64)"


@intrinsic
def call_block(typingctx, address, params, row, consts, inst_hash):
    """Run the compiled block at `address` (an integer) on params[row] (a C-contiguous
    2-D array) with the constant pool `consts`: a call through the address keeps the
    kernels the same for every system, where a function-typed argument would make numba
    compile and cache them again for each."""
    if not (isinstance(params, types.Array) and params.ndim == 2 and params.layout == "C"
            and isinstance(consts, types.Array) and consts.layout == "C"):
        return None
    sig = types.void(address, params, row, consts, inst_hash)

    def codegen(context, builder, signature, args):
        fn_address, p, r, c, h = args
        table = context.make_array(signature.args[1])(context, builder, p)
        pool = context.make_array(signature.args[3])(context, builder, c)
        i64 = ir.IntType(64)
        stride = builder.extract_value(table.strides, 0)
        start = builder.add(builder.ptrtoint(table.data, i64), builder.mul(r, stride))
        double_ptr = ir.DoubleType().as_pointer()
        fnty = ir.FunctionType(ir.VoidType(), [double_ptr, double_ptr, i64])
        fn = builder.inttoptr(fn_address, fnty.as_pointer())
        builder.call(fn, [builder.inttoptr(start, double_ptr), pool.data, h])
        return context.get_dummy_value()

    return sig, codegen


# each opcode as the expression vm.eval_row evaluates for it (vm.binary for the binary
# ones); tests/test_native.py holds every opcode to the machine's bits
BINARY = {vm.ADD: "{a} + {b}", vm.SUB: "{a} - {b}", vm.MUL: "{a} * {b}", vm.DIV: "{a} / {b}",
          vm.MOD: "{a} - {b} * np.floor({a} / {b})", vm.POW: "{a} ** {b}",
          vm.LT: "1.0 if {a} < {b} else 0.0", vm.LE: "1.0 if {a} <= {b} else 0.0",
          vm.GT: "1.0 if {a} > {b} else 0.0", vm.GE: "1.0 if {a} >= {b} else 0.0",
          vm.EQ: "1.0 if {a} == {b} else 0.0", vm.NE: "1.0 if {a} != {b} else 0.0",
          vm.MIN: "fmin({a}, {b})", vm.MAX: "fmax({a}, {b})", vm.ATAN2: "math.atan2({a}, {b})"}
UNARY = {vm.NEG: "-{a}", vm.NOT: "0.0 if truth({a}) else 1.0",
         vm.TRUTH: "1.0 if truth({a}) else 0.0", vm.ABS: "abs({a})",
         vm.SQRT: "math.sqrt({a})", vm.EXP: "math.exp({a})", vm.LN: "math.log({a})",
         vm.LOG10: "math.log10({a})", vm.SIN: "math.sin({a})", vm.COS: "math.cos({a})",
         vm.TAN: "math.tan({a})", vm.ASIN: "math.asin({a})", vm.ACOS: "math.acos({a})",
         vm.ATAN: "math.atan({a})", vm.DEG: "{a} * _DEG", vm.RAD: "{a} * _RAD",
         vm.FLOOR: "np.floor({a})", vm.CEIL: "np.ceil({a})",
         vm.ROUND: "round_half_away({a})", vm.RAND_SEED: "rand_seed({a})"}


def block_source(code: np.ndarray, start: int, end: int, name: str) -> str | None:
    """Python source of a C callback that runs rows [start, end) of `code` as
    vm.eval_row runs them on a row of parameters (for a block: no value is returned,
    and the salt is its own SALT rows'); None for a block with jumps."""
    lines = ["@cfunc(SIGNATURE, cache=True, error_model='numpy', nopython=True)",
             f"def {name}(p, c, h0):"]
    sp = 0
    h = "h0"          # the hash rand() draws from: the instance's until a SALT row
    draws = 0
    salt_slot = -1
    for pc in range(start, end):
        op, arg = int(code[pc, 0]), int(code[pc, 1])
        top = f"s{sp - 1}"
        if op in (vm.BIN_LOAD, vm.BIN_CONST):
            pool = "p" if op == vm.BIN_LOAD else "c"
            template = BINARY.get(arg & vm.OP_MASK)
            if template is None:
                return None
            line = f"{top} = " + template.format(a=top, b=f"{pool}[{arg >> vm.OP_BITS}]")
        elif op == vm.LOAD:
            line, sp = f"s{sp} = p[{arg}]", sp + 1
        elif op == vm.CONST:
            line, sp = f"s{sp} = c[{arg}]", sp + 1
        elif op == vm.STORE:
            line, sp = f"p[{arg}] = s{sp - 1}", sp - 1
        elif op == vm.SALT:
            salt_slot, draws, line = arg, 0, ""
        elif op == vm.RAND:
            line = ""
            if salt_slot >= 0:
                line = f"h = salt(h0, np.uint64({salt_slot})); "
                h, salt_slot = "h", -1
            line += f"s{sp} = hash_to_unit(mix({h}, np.uint64({draws})))"
            draws, sp = draws + 1, sp + 1
        elif op in BINARY:
            line = f"s{sp - 2} = " + BINARY[op].format(a=f"s{sp - 2}", b=top)
            sp -= 1
        elif op == vm.CLAMP:
            line, sp = f"s{sp - 3} = fmin(fmax(s{sp - 3}, s{sp - 2}), s{sp - 1})", sp - 2
        elif op in UNARY:
            line = f"{top} = " + UNARY[op].format(a=top)
        else:
            return None       # the jumps, or an opcode this module does not know
        if line:
            lines.append("    " + line)
    lines.append("    return")
    return "\n".join(lines)


HEADER = '''"""Calculation blocks of one system, written by pcsg.trace.native: do not edit."""
import math

import numpy as np
from numba import cfunc
from pcsg.trace.native import SIGNATURE
from pcsg.trace.vm import (_DEG, _RAD, fmax, fmin, hash_to_unit, mix, rand_seed,
                           round_half_away, salt, truth)

'''


def cache_dir() -> Path:
    """PCSG_CACHE_DIR, else pcsg under XDG_CACHE_HOME or ~/.cache."""
    if os.environ.get("PCSG_CACHE_DIR"):
        return Path(os.environ["PCSG_CACHE_DIR"])
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "pcsg"


def native_blocks(code: np.ndarray, starts: np.ndarray, ends: np.ndarray,
                  is_calc: np.ndarray) -> np.ndarray:
    """Flat.calc_fn: per node the address of its compiled block, 0 where it has none
    (not a C-node, a short block, a block with jumps, PCSG_NATIVE=0, or compiling
    failed: the machine then runs it, with the same results)."""
    out = np.zeros(len(starts), dtype=np.int64)
    if os.environ.get("PCSG_NATIVE", "1") == "0":
        return out
    blocks = {int(i): (int(starts[i]), int(ends[i])) for i in np.flatnonzero(is_calc)
              if ends[i] - starts[i] >= MIN_ROWS}
    try:
        for node, address in compile_blocks(code, blocks).items():
            out[node] = address
    except Exception:       # noqa: BLE001 -- only ever a speed-up
        out[:] = 0
    return out


def compile_blocks(code: np.ndarray, blocks: dict[int, tuple[int, int]]) -> dict[int, int]:
    """{node: address of its compiled block} for the blocks {node: (start, end)} that
    can be compiled; the others stay on the machine."""
    sources = {}
    for node, (start, end) in blocks.items():
        src = block_source(code, start, end, f"block_{node}")
        if src is not None:
            sources[node] = src
    if not sources:
        return {}
    text = HEADER + "\n\n".join(sources[n] for n in sorted(sources)) + "\n"
    digest = hashlib.sha256((machine_digest() + text).encode()).hexdigest()[:20]
    module = _load(text, f"pcsg_blocks_{digest}")
    return {node: getattr(module, f"block_{node}").address for node in sources}


@functools.cache
def machine_digest() -> str:
    """The machine's own source: a block compiled against another version of vm.py is
    another module. Read once: every flatten (two per render of an instance-walked
    system) asks."""
    return hashlib.sha256(Path(vm.__file__).read_bytes()).hexdigest()


def _load(text: str, name: str):
    if name in sys.modules:
        return sys.modules[name]
    folder = cache_dir() / "blocks"
    path = folder / f"{name}.py"
    try:
        if not path.exists() or path.read_text() != text:
            folder.mkdir(parents=True, exist_ok=True)
            # written whole, then renamed: another process may be importing it
            fd, tmp = tempfile.mkstemp(dir=folder, suffix=".tmp")
            with os.fdopen(fd, "w") as f:
                f.write(text)
            os.replace(tmp, path)
    except OSError:
        folder = Path(tempfile.mkdtemp(prefix="pcsg-blocks-"))
        path = folder / f"{name}.py"
        path.write_text(text)
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[name]       # not half a module for the next flatten to find
        raise
    return module
