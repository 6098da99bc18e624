"""Compiled calculation blocks (trace/native.py) give the expression machine's bits,
opcode by opcode and through the walks, and a second start loads them compiled."""
import importlib.util
import itertools
import os
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from numba import njit

import pcsg
from pcsg.compiler import compile_file
from pcsg.graph.flat import flatten_graph
from pcsg.graph.model import CALC, PAINT, SELECT, TRANSFORM
from pcsg.trace import native, vm
from pcsg.trace.boxwalk import walk_boxes

from .conftest import GRAMMARS, ROOT

SPECIAL = [0.0, -0.0, 1.0, -1.0, 0.5, -1.5, 2.0, 3.0, -7.25, 1e-5, 1e300, -1e-300, 255.0,
           np.inf, -np.inf, np.nan]
WIDTH = 6                   # parameter slots of the test programs: a, b, out, c, d, e
CONSTS = np.array([0.75, -3.0, np.nan, 1e-3])


@njit
def run_native(address, block, params, consts, h):
    native.call_block(address, params, 1, consts, h, block)


def bits(a):
    return np.ascontiguousarray(a).view(np.uint64)


def programs():
    """(name, rows) of small blocks covering every opcode the compiler takes."""
    out = []
    for op in native.BINARY:
        name = vm.OPCODE_NAMES[op]
        out.append((name, [(vm.LOAD, 0), (vm.LOAD, 1), (op, 0), (vm.STORE, 2)]))
        out.append((f"{name} fused with a load", [(vm.LOAD, 0), (vm.BIN_LOAD, op | 1 << 6),
                                                  (vm.STORE, 2)]))
        out.append((f"{name} fused with a constant",
                    [(vm.LOAD, 0), (vm.BIN_CONST, op | 1 << 6), (vm.STORE, 2)]))
    for op in native.UNARY:
        out.append((vm.OPCODE_NAMES[op], [(vm.LOAD, 0), (op, 0), (vm.STORE, 2)]))
    out.append(("CLAMP", [(vm.LOAD, 0), (vm.LOAD, 1), (vm.LOAD, 3), (vm.CLAMP, 0),
                          (vm.STORE, 2)]))
    out.append(("CONST", [(vm.CONST, 2), (vm.STORE, 2), (vm.CONST, 0), (vm.STORE, 3)]))
    # rand() before any SALT draws from the instance hash itself; each SALT restarts the
    # count of draws from a salted hash
    out.append(("RAND and SALT", [(vm.RAND, 0), (vm.STORE, 2), (vm.SALT, 1), (vm.RAND, 0),
                                  (vm.STORE, 3), (vm.RAND, 0), (vm.STORE, 4), (vm.SALT, 2),
                                  (vm.RAND, 0), (vm.LOAD, 0), (vm.ADD, 0), (vm.STORE, 5)]))
    out.append(("a block's worth", [(vm.LOAD, 0), (vm.LOAD, 1), (vm.ADD, 0),
                                    (vm.BIN_CONST, vm.MUL | 0 << 6), (vm.STORE, 3),
                                    (vm.LOAD, 3), (vm.RAND_SEED, 0), (vm.LN, 0),
                                    (vm.BIN_LOAD, vm.SUB | 1 << 6), (vm.STORE, 2),
                                    (vm.LOAD, 2), (vm.LOAD, 3), (vm.LOAD, 0), (vm.CLAMP, 0),
                                    (vm.NEG, 0), (vm.STORE, 4)]))
    # the jumps of if(a, b, 0.75), a && b, a || b: if and else in the compiled block
    out.append(("if", [(vm.LOAD, 0), (vm.JUMP_IF_FALSE, 3), (vm.LOAD, 1), (vm.JUMP, 2),
                       (vm.CONST, 0), (vm.STORE, 2)]))
    out.append(("&&", [(vm.LOAD, 0), (vm.AND_JUMP, 3), (vm.LOAD, 1), (vm.TRUTH, 0),
                       (vm.STORE, 2)]))
    out.append(("||", [(vm.LOAD, 0), (vm.OR_JUMP, 3), (vm.LOAD, 1), (vm.TRUTH, 0),
                       (vm.STORE, 2)]))
    # a branch that draws: the draws after it count from where that branch left them
    out.append(("if drawing", [(vm.SALT, 3), (vm.LOAD, 0), (vm.JUMP_IF_FALSE, 3), (vm.RAND, 0),
                               (vm.JUMP, 2), (vm.CONST, 0), (vm.STORE, 2), (vm.RAND, 0),
                               (vm.STORE, 3)]))
    # if(a, if(b, 0.75, -3), b && a), nested both ways
    out.append(("nested ifs", [(vm.LOAD, 0), (vm.JUMP_IF_FALSE, 7), (vm.LOAD, 1),
                               (vm.JUMP_IF_FALSE, 3), (vm.CONST, 0), (vm.JUMP, 2),
                               (vm.CONST, 1), (vm.JUMP, 5), (vm.LOAD, 1), (vm.AND_JUMP, 3),
                               (vm.LOAD, 0), (vm.TRUTH, 0), (vm.STORE, 2)]))
    return out


@pytest.fixture(scope="module")
def compiled():
    rows, blocks, names = [], {}, {}
    for k, (name, prog) in enumerate(programs()):
        blocks[k] = (len(rows), len(rows) + len(prog))
        names[k] = name
        rows += prog
    code = np.array(rows, dtype=np.int32)
    limits = native.MAX_BLOCKS, native.MAX_ROWS
    native.MAX_BLOCKS = native.MAX_ROWS = 10 ** 6      # every opcode's program in one callback
    try:
        addresses = native.compile_blocks(code, blocks)
    finally:
        native.MAX_BLOCKS, native.MAX_ROWS = limits
    assert sorted(addresses) == sorted(blocks), "a program was not compiled"
    assert len({a for a, _ in addresses.values()}) == 1      # one callback runs them all
    return code, blocks, names, addresses


def test_every_opcode_gives_the_machines_bits(compiled):
    code, blocks, names, addresses = compiled
    rng = np.random.default_rng(7)
    values = SPECIAL + list(rng.normal(size=6) * 10.0 ** rng.integers(-3, 4, size=6))
    stack = np.zeros(16)
    checked = 0
    for k, (start, end) in blocks.items():
        for a, b in itertools.product(values, repeat=2):
            state = np.array([a, b, -1.0, rng.normal(), 0.25, 4.0])
            mine = np.tile(state, (2, 1))
            theirs = mine.copy()
            h = np.uint64(rng.integers(0, 2 ** 63))
            run_native(np.int64(addresses[k][0]), np.int64(addresses[k][1]), mine, CONSTS, h)
            vm.eval_row(code, CONSTS, start, end, theirs, 1, h, -1, stack)
            assert np.array_equal(bits(mine), bits(theirs)), (names[k], a, b, mine[1],
                                                              theirs[1])
            checked += 1
    assert checked == len(blocks) * len(values) ** 2


def test_jumps_that_do_not_nest_stay_on_the_machine():
    code = np.array([(vm.JUMP, 2), (vm.CONST, 0), (vm.CONST, 1), (vm.STORE, 2)],
                    dtype=np.int32)
    assert native.block_source(code, 0, len(code), "b") is None
    assert native.compile_blocks(code, {0: (0, len(code))}) == {}
    # a jump past the end of its block
    code = np.array([(vm.LOAD, 0), (vm.JUMP_IF_FALSE, 9), (vm.CONST, 0), (vm.STORE, 2)],
                    dtype=np.int32)
    assert native.block_source(code, 0, len(code), "b") is None


def terrain(order):
    return compile_file(GRAMMARS / "carpenter_terrain.pcsg", {"cnt": order})


def test_the_terrains_long_blocks_are_compiled_and_the_switch_turns_them_off(monkeypatch):
    graph = terrain(3)
    n = len(graph.nodes)
    flat = flatten_graph(graph, np.zeros((n, 6)), native_args=True)
    long = (flat.kind == CALC) & (flat.calc_end - flat.calc_start >= native.MIN_ROWS)
    assert long.sum() >= 8                      # the eight subdivision blocks at least
    assert np.all((flat.calc_fn != 0) == long)
    # the arguments of the final triangles' move(0,0,z1) and zshear(...), of any length
    dynamic = np.isin(flat.kind, (TRANSFORM, PAINT)) & (flat.fixed == 0)
    assert dynamic.sum() >= 4
    # and every S-node's selection, `if(cnt > 0, 2, 1)` with its jumps among them
    assert np.all((flat.arg_fn != 0) == (dynamic | (flat.kind == SELECT)))
    assert flat.n_params == len(graph.params) + 3 == flat.arg_base + 3
    # only asked for: a system bounded by its states would load them for nothing
    plain = flatten_graph(graph, np.zeros((n, 6)))
    assert not plain.arg_fn.any() and plain.n_params == len(graph.params)
    monkeypatch.setenv("PCSG_NATIVE", "0")
    off = flatten_graph(graph, np.zeros((n, 6)), native_args=True)
    assert not off.calc_fn.any() and not off.arg_fn.any()


def test_one_callback_compiles_the_longest_blocks_within_its_limits(monkeypatch):
    """2,000 modules' arguments compiled in one callback took 75 s and 2.8 GB, an axiom
    block of 3,000 assignments 22 s (QA): the longest blocks go first, up to MAX_BLOCKS
    blocks and MAX_ROWS rows, and the others run on the machine."""
    graph = terrain(3)
    n = len(graph.nodes)
    everything = flatten_graph(graph, np.zeros((n, 6)), native_args=True)
    rows = np.where(everything.calc_fn != 0, everything.calc_end - everything.calc_start, 0)
    longest = np.sort(rows)[::-1]
    monkeypatch.setattr(native, "MAX_BLOCKS", 3)
    capped = flatten_graph(graph, np.zeros((n, 6)), native_args=True)
    compiled = (capped.calc_fn != 0) | (capped.arg_fn != 0)
    assert compiled.sum() == 3
    assert np.sort(capped.calc_end - capped.calc_start)[::-1][:3].tolist() == \
        longest[:3].tolist() == sorted((capped.calc_end - capped.calc_start)[capped.calc_fn != 0],
                                       reverse=True)
    monkeypatch.setattr(native, "MAX_BLOCKS", 64)
    monkeypatch.setattr(native, "MAX_ROWS", int(longest[0]))       # the longest, no other
    one = flatten_graph(graph, np.zeros((n, 6)), native_args=True)
    assert ((one.calc_fn != 0) | (one.arg_fn != 0)).sum() == 1
    assert (one.calc_end - one.calc_start)[one.calc_fn != 0].tolist() == [longest[0]]


def test_the_walks_give_the_same_bits_with_compiled_blocks(monkeypatch):
    """The bounding walk's boxes and table, and every ray's hit, with the terrain's blocks
    compiled and on the machine."""
    from pcsg.render.camera import make_camera
    results = []
    for switch in ("1", "0"):
        monkeypatch.setenv("PCSG_NATIVE", switch)
        graph = terrain(4)
        boxes, complete, table, depth = walk_boxes(graph, 64, instances=True)
        obj = pcsg.Traced(graph)
        assert (obj.flat.calc_fn != 0).any() == (switch == "1")
        assert (obj.flat.arg_fn != 0).any() == (switch == "1")
        cam = make_camera(obj, 4 / 3)
        ys, xs = np.mgrid[0:48, 0:64]
        o, d = cam.rays(64, 48, xs.ravel() + 0.5, ys.ravel() + 0.5)
        hits = obj.trace(o, d)
        results.append((boxes, table, hits))
    (b1, t1, h1), (b0, t0, h0) = results
    assert np.array_equal(bits(b1), bits(b0))
    for x, y in zip(t1, t0):
        assert np.array_equal(x, y)
    assert h1.hit.sum() > 1000
    for field in ("t", "normal", "paint"):
        assert np.array_equal(bits(getattr(h1, field)), bits(getattr(h0, field))), field


# rand() in arguments draws from the instance hash salted per argument (vm.py), and
# a compiled argument list must draw the same numbers
RANDOM_ARGS = """{ n = 4 } S
S if(n > 0 && rand() < 0.9, 2, 1)
1: S → paint(rand(), 0.5, rand()) sphere
2: S → sphere ∪
       { n = n - 1 } move(2 + rand(), rand() - 0.5, n * 0.1) rotz(40 * rand()) scale(0.8, 0.8, 0.8) S ∪
       { n = n - 1 } move(-2, rand(), 0) uscale(0.5 + 0.2 * rand()) S
"""


def test_random_arguments_give_the_same_bits_compiled(monkeypatch):
    from pcsg.graph import bounds
    from pcsg.render.camera import make_camera
    monkeypatch.setattr(bounds, "MAX_STATES", 0)    # bounded instance by instance
    results = []
    for switch in ("1", "0"):
        monkeypatch.setenv("PCSG_NATIVE", switch)
        obj = pcsg.loads(RANDOM_ARGS)
        assert obj.bounds_method == "every instance"
        assert (obj.flat.arg_fn != 0).sum() == (6 if switch == "1" else 0)   # and S's
        cam = make_camera(obj, 4 / 3)
        ys, xs = np.mgrid[0:96, 0:128]
        o, d = cam.rays(128, 96, xs.ravel() + 0.5, ys.ravel() + 0.5)
        results.append((obj.boxes, obj.trace(o, d)))
    (b1, h1), (b0, h0) = results
    assert np.array_equal(bits(b1), bits(b0))
    assert h1.hit.sum() > 200 and len(np.unique(h1.paint[h1.hit], axis=0)) > 3
    for field in ("t", "normal", "paint"):
        assert np.array_equal(bits(getattr(h1, field)), bits(getattr(h0, field))), field


LOADS = """
import numpy as np, sys
from pcsg.compiler import compile_file
from pcsg.graph.flat import flatten_graph
g = compile_file("grammars/carpenter_terrain.pcsg", {"cnt": 2})
flatten_graph(g, np.zeros((len(g.nodes), 6)))
module = [m for name, m in sys.modules.items() if name.startswith("pcsg_blocks_")][0]
blocks = [k for k in dir(module) if k.startswith("block_")]
print(len(blocks), module.run_blocks.cache_hits)
"""


def test_a_second_start_loads_the_compiled_blocks(tmp_path):
    """The second process loads the blocks' callback from numba's cache, and their module
    from its bytecode, written beside it though PYTHONDONTWRITEBYTECODE is set: a pyc that
    records the source's size and time, which is what makes the import read it."""
    env = {**os.environ, "PCSG_CACHE_DIR": str(tmp_path), "PYTHONDONTWRITEBYTECODE": "1"}
    counts = []
    for _ in range(2):
        r = subprocess.run([sys.executable, "-c", LOADS], cwd=ROOT, env=env,
                           capture_output=True, text=True, timeout=600)
        assert r.returncode == 0, r.stderr
        counts.append(tuple(map(int, r.stdout.split())))
    (blocks, first_hits), (again, second_hits) = counts
    assert blocks == again >= 8
    assert first_hits == 0 and second_hits == 1        # one callback runs them all
    source, = (tmp_path / "blocks").glob("pcsg_blocks_*.py")
    pyc = Path(importlib.util.cache_from_source(str(source))).read_bytes()
    assert pyc[:4] == importlib.util.MAGIC_NUMBER
    flags, mtime, size = struct.unpack("<3I", pyc[4:16])
    stat = source.stat()
    assert flags == 0 and mtime == int(stat.st_mtime) & 0xFFFFFFFF and size == stat.st_size
