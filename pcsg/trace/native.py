"""Calculation blocks compiled to machine code, for the systems that run them by the
million (the terrain's bounding walk runs one per instance), and for the systems bounded
instance by instance also the arguments of T- and paint nodes and the selections of
S-nodes (graph/flat.py: one block per node, storing into scratch parameter columns).

The expression machine (vm.py) decodes each row of a block as it runs it: 261 to 414 ns
for one of the terrain's subdivision blocks (105 and 153 rows). A block keeps the same
stack depth at every row, whichever way its jumps go (the jumps of `if`, `&&` and `||`
nest, and both ways leave one value), so its stack slots can be local variables: each
row becomes one statement, the expression the machine evaluates for that opcode (BINARY,
UNARY below), in the machine's order, and each jump an if and else. numba compiles that
to what the arithmetic costs, 21 to 33 ns for those blocks, with the same results to the
bit: the same operations on the same values (tests/test_native.py holds every opcode and
jump to it). A terrain T-node took 56 to 66 ns with its arguments on the machine and its
matrix, 13 to 14 ns with them compiled; an S-node's selection `if(cnt > 0, 2, 1)` took 15 ns
on the machine.

The blocks of a system are written to one module in the user's cache directory, named
after a hash of its source, and compiled into one C callback, which runs the block whose
number it is given, with numba's on-disk cache: 1.5 s for the terrain's 22 blocks the
first time it is rendered, 10 ms to load them after that (30 ms as a callback each). The
kernels call a block through the callback's address and its number (call_block), so the
cached kernels serve every system. Calculation blocks shorter than MIN_ROWS rows stay on
the machine; PCSG_NATIVE=0 keeps every block there."""
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

from ..caches import cache_dir
from . import vm

MIN_ROWS = 24           # shorter blocks cost little more on the machine than a call
# the most blocks and rows one callback compiles, the longest blocks first: its compile grew
# faster than its rows (2,000 modules' arguments, 75 s and 2.8 GB; one axiom block of 3,000
# assignments, 22 s), and the terrain's 22 blocks are 1,312 rows
MAX_BLOCKS, MAX_ROWS = 64, 4096
# the one C callback of a system's blocks: run_blocks(params row, constants, hash, block)
SIGNATURE = "void(CPointer(float64), CPointer(float64), uint64, int64)"


@intrinsic
def call_block(typingctx, address, params, row, consts, inst_hash, block):
    """Run compiled block number `block` of the callback at `address` (an integer) on
    params[row] (a C-contiguous 2-D array) with the constant pool `consts`: a call through
    the address keeps the kernels the same for every system, where a function-typed
    argument would make numba compile and cache them again for each."""
    if not (isinstance(params, types.Array) and params.ndim == 2 and params.layout == "C"
            and isinstance(consts, types.Array) and consts.layout == "C"):
        return None
    sig = types.void(address, params, row, consts, inst_hash, block)

    def codegen(context, builder, signature, args):
        fn_address, p, r, c, h, b = args
        table = context.make_array(signature.args[1])(context, builder, p)
        pool = context.make_array(signature.args[3])(context, builder, c)
        i64 = ir.IntType(64)
        stride = builder.extract_value(table.strides, 0)
        start = builder.add(builder.ptrtoint(table.data, i64), builder.mul(r, stride))
        double_ptr = ir.DoubleType().as_pointer()
        fnty = ir.FunctionType(ir.VoidType(), [double_ptr, double_ptr, i64, i64])
        fn = builder.inttoptr(fn_address, fnty.as_pointer())
        builder.call(fn, [builder.inttoptr(start, double_ptr), pool.data, h,
                          context.cast(builder, b, signature.args[5], types.int64)])
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
    and the salt is its own SALT rows'); the jumps of `if`, `&&` and `||` become if and
    else. None for a jump that does not nest that way, or an opcode it does not know."""
    body = _statements(code, start, end, 0, "    ")
    if body is None:
        return None
    # rand() draws from the instance's hash until a SALT row salts it (vm.py); nd counts
    # the draws since, at run time, since a branch may draw or not
    return "\n".join(["@njit(error_model='numpy', inline='always')",
                      f"def {name}(p, c, h0):", "    h = h0", "    nd = 0", *body[0],
                      "    return"])


def dispatch_source(names: list[str]) -> str:
    """The C callback that runs block number `which` of `names` (compile_blocks): one
    callback, so one library for numba to load (the terrain's 22 blocks loaded as 22
    libraries took 30 ms, as one 10 ms), each block inlined into its branch."""
    lines = ["@cfunc(SIGNATURE, cache=True, error_model='numpy', nopython=True)",
             "def run_blocks(p, c, h0, which):"]
    for k, name in enumerate(names):
        lines += [f"    {'if' if k == 0 else 'elif'} which == {k}:", f"        {name}(p, c, h0)"]
    return "\n".join(lines)


def _statements(code, pc: int, end: int, sp: int, indent: str):
    """(lines, stack depth after) for rows [pc, end) entered with sp values on the stack;
    None where a jump leaves the range or its branches leave different depths."""
    out = []
    inner = indent + "    "
    while pc < end:
        op, arg = int(code[pc, 0]), int(code[pc, 1])
        if op in (vm.JUMP_IF_FALSE, vm.AND_JUMP, vm.OR_JUMP):
            target = pc + arg                   # jumps count from their own row
            if not pc < target <= end:
                return None
            top = f"s{sp - 1}"
            if op == vm.JUMP_IF_FALSE:          # if(c, a, b): [c] JIF [a] JUMP [b]
                then_end = after = target
                if target - 1 > pc and int(code[target - 1, 0]) == vm.JUMP:
                    then_end, after = target - 1, target - 1 + int(code[target - 1, 1])
                    if not target <= after <= end:
                        return None
                yes = _statements(code, pc + 1, then_end, sp - 1, inner)
                no = _statements(code, target, after, sp - 1, inner)
            else:                               # && and ||: the right side or a constant
                after = target
                right = _statements(code, pc + 1, target, sp - 1, inner)
                fixed = ([f"{inner}{top} = {'0.0' if op == vm.AND_JUMP else '1.0'}"], sp)
                yes, no = (right, fixed) if op == vm.AND_JUMP else (fixed, right)
            if yes is None or no is None or yes[1] != no[1]:
                return None
            out += [f"{indent}if truth({top}):", *(yes[0] or [inner + "pass"]),
                    f"{indent}else:", *(no[0] or [inner + "pass"])]
            sp, pc = yes[1], after
            continue
        row = _row(op, arg, sp)
        if row is None:
            return None       # a jump out of an if's shape, or an opcode this does not know
        line, sp = row
        if line:
            out.append(indent + line)
        pc += 1
    return out, sp


def _row(op: int, arg: int, sp: int):
    """(statement, stack depth after) of one row that does not jump."""
    top = f"s{sp - 1}"
    if op in (vm.BIN_LOAD, vm.BIN_CONST):
        pool = "p" if op == vm.BIN_LOAD else "c"
        template = BINARY.get(arg & vm.OP_MASK)
        if template is None:
            return None
        return f"{top} = " + template.format(a=top, b=f"{pool}[{arg >> vm.OP_BITS}]"), sp
    if op == vm.LOAD:
        return f"s{sp} = p[{arg}]", sp + 1
    if op == vm.CONST:
        return f"s{sp} = c[{arg}]", sp + 1
    if op == vm.STORE:
        return f"p[{arg}] = s{sp - 1}", sp - 1
    if op == vm.SALT:
        return f"h = salt(h0, np.uint64({arg})); nd = 0", sp
    if op == vm.RAND:
        return f"s{sp} = hash_to_unit(mix(h, np.uint64(nd))); nd += 1", sp + 1
    if op in BINARY:
        return f"s{sp - 2} = " + BINARY[op].format(a=f"s{sp - 2}", b=top), sp - 1
    if op == vm.CLAMP:
        return f"s{sp - 3} = fmin(fmax(s{sp - 3}, s{sp - 2}), s{sp - 1})", sp - 2
    if op in UNARY:
        return f"{top} = " + UNARY[op].format(a=top), sp
    return None


HEADER = '''"""Calculation blocks of one system, written by pcsg.trace.native: do not edit."""
import math

import numpy as np
from numba import cfunc, njit
from pcsg.trace.native import SIGNATURE
from pcsg.trace.vm import (_DEG, _RAD, fmax, fmin, hash_to_unit, mix, rand_seed,
                           round_half_away, salt, truth)

'''


def native_blocks(code: np.ndarray, blocks: dict[int, tuple[int, int]],
                  n: int) -> tuple[np.ndarray, np.ndarray]:
    """Per node (n of them) the address of the callback that runs its compiled program
    among `blocks` {node: (start, end)}, 0 where it has none (not asked for, a program
    with jumps, PCSG_NATIVE=0, or compiling failed: the machine then runs it, with the
    same results), and the program's number in that callback."""
    address = np.zeros(n, dtype=np.int64)
    number = np.zeros(n, dtype=np.int64)
    if os.environ.get("PCSG_NATIVE", "1") == "0":
        return address, number
    try:
        for node, (a, k) in compile_blocks(code, blocks).items():
            address[node], number[node] = a, k
    except Exception:       # noqa: BLE001 -- only ever a speed-up
        address[:] = 0
    return address, number


def compile_blocks(code: np.ndarray,
                   blocks: dict[int, tuple[int, int]]) -> dict[int, tuple[int, int]]:
    """{node: (address of the callback, number of its block in it)} for the blocks
    {node: (start, end)} that can be compiled, within MAX_BLOCKS and MAX_ROWS; the
    others stay on the machine."""
    sources, rows = {}, 0
    # the longest first: they gain the most a call; the rest are left to the machine
    for node in sorted(blocks, key=lambda node: (blocks[node][0] - blocks[node][1], node)):
        start, end = blocks[node]
        if len(sources) == MAX_BLOCKS or rows + end - start > MAX_ROWS:
            continue
        src = block_source(code, start, end, f"block_{node}")
        if src is not None:
            sources[node] = src
            rows += end - start
    if not sources:
        return {}
    nodes = sorted(sources)
    text = (HEADER + "\n\n".join(sources[n] for n in nodes) + "\n\n"
            + dispatch_source([f"block_{n}" for n in nodes]) + "\n")
    digest = hashlib.sha256((machine_digest() + text).encode()).hexdigest()[:20]
    address = _load(text, f"pcsg_blocks_{digest}").run_blocks.address
    return {node: (address, k) for k, node in enumerate(nodes)}


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
        written = not path.exists() or path.read_text() != text
        if written:
            folder.mkdir(parents=True, exist_ok=True)
            # written whole, then renamed: another process may be importing it
            fd, tmp = tempfile.mkstemp(dir=folder, suffix=".tmp")
            with os.fdopen(fd, "w") as f:
                f.write(text)
            os.replace(tmp, path)
        _bytecode(path, written)
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


def _bytecode(path: Path, stale: bool) -> None:
    """The module's bytecode in its __pycache__, for its import to read: written here
    where it is missing (or `stale`) even where PYTHONDONTWRITEBYTECODE is set, as
    containers often set it and this machine does, since the module is pcsg's own cache.
    Compiled from source at every start, the terrain's 26 kB of blocks took 10 ms of each
    render. py_compile writes it whole, then renames it."""
    cached = importlib.util.cache_from_source(str(path))
    if stale or not os.path.exists(cached):
        import py_compile
        try:
            py_compile.compile(str(path), cfile=cached, doraise=True)
        except (OSError, py_compile.PyCompileError):
            pass        # the import compiles it (and reports an error) as it would have
