"""The njit expression machine, driven with hand-assembled bytecode."""
import math
import struct

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from pcsg.trace import vm

INF, NAN = math.inf, math.nan
MASK = (1 << 64) - 1


def run(rows, consts=(), params=(), h=0):
    code = np.array(rows, dtype=np.int32).reshape(-1, 2)
    return float(vm.eval_expr(code, np.array(consts, dtype=np.float64), 0, len(code),
                              np.array(params, dtype=np.float64), np.uint64(h),
                              np.empty(8)))


def same(x, y):
    """Equal including the sign of zero, or both nan."""
    if math.isnan(x) or math.isnan(y):
        return math.isnan(x) and math.isnan(y)
    return x == y and math.copysign(1, x) == math.copysign(1, y)


def binary(op, a, b):
    return run([(vm.LOAD, 0), (vm.LOAD, 1), (op, 0)], params=(a, b))


def unary(op, a):
    return run([(vm.LOAD, 0), (op, 0)], params=(a,))


# ---- a pure-Python reference of the hashing contract -----------------------

def ref_splitmix64(x):
    z = (x + 0x9E3779B97F4A7C15) & MASK
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK
    return z ^ (z >> 31)


def ref_unit(h):
    return (h >> 11) / 2.0 ** 53


def ref_mix(h, v):
    return ref_splitmix64(h ^ ref_splitmix64(v))


def ref_rand_seed(seed):
    if math.isnan(seed):
        bits = 0x7FF8000000000000
    elif seed == 0:
        bits = 0
    else:
        bits = struct.unpack('<Q', struct.pack('<d', seed))[0]
    return ref_unit(ref_splitmix64(bits))


# ---- arithmetic ----------------------------------------------------------------

@pytest.mark.parametrize('op,a,b,want', [
    (vm.ADD, 2, 3, 5), (vm.ADD, INF, -INF, NAN),
    (vm.SUB, 2, 3, -1), (vm.SUB, 0.0, 0.0, 0.0),
    (vm.MUL, 2, -3, -6), (vm.MUL, 0, INF, NAN),
    (vm.DIV, 1, 4, 0.25), (vm.DIV, 1, 0, INF), (vm.DIV, -1, 0, -INF),
    (vm.DIV, 1, -0.0, -INF), (vm.DIV, 0, 0, NAN),
    (vm.MOD, 5.5, 2, 1.5), (vm.MOD, -1, 3, 2), (vm.MOD, 1, -3, -2),
    (vm.MOD, -7, -3, -1), (vm.MOD, 1, 0, NAN), (vm.MOD, INF, 2, NAN),
    (vm.POW, 2, 10, 1024), (vm.POW, 2, -1, 0.5), (vm.POW, 0, -1, INF),
    (vm.POW, -8, 1 / 3, NAN), (vm.POW, NAN, 0, 1), (vm.POW, 1, NAN, 1),
    (vm.POW, -2, 3, -8), (vm.POW, 2, 1e10, INF), (vm.POW, -0.0, -1, -INF),
    (vm.MIN, 1, 2, 1), (vm.MIN, 2, -1, -1), (vm.MIN, NAN, 1, NAN), (vm.MIN, 1, NAN, NAN),
    (vm.MAX, 1, 2, 2), (vm.MAX, -INF, -1, -1), (vm.MAX, NAN, 1, NAN), (vm.MAX, 1, NAN, NAN),
    (vm.ATAN2, 1, 1, math.pi / 4), (vm.ATAN2, 0.0, -1, math.pi),
    (vm.ATAN2, -0.0, -1, -math.pi), (vm.ATAN2, 1, 0, math.pi / 2),
    (vm.ATAN2, INF, INF, math.pi / 4),
])
def test_binary_ops(op, a, b, want):
    assert same(binary(op, a, b), want), (vm.OPCODE_NAMES[op], a, b)


@pytest.mark.parametrize('a,b', [(1, 2), (2, 1), (2, 2), (-0.0, 0.0), (NAN, 1), (1, NAN),
                                 (NAN, NAN), (INF, INF), (-INF, 1)])
def test_comparisons_are_ieee(a, b):
    for op, f in [(vm.LT, float.__lt__), (vm.LE, float.__le__), (vm.GT, float.__gt__),
                  (vm.GE, float.__ge__), (vm.EQ, float.__eq__), (vm.NE, float.__ne__)]:
        got = binary(op, a, b)
        assert got == (1.0 if f(float(a), float(b)) else 0.0), (vm.OPCODE_NAMES[op], a, b)


def test_zero_over_zero_compares_false_except_ne():
    nan = run([(vm.CONST, 0), (vm.CONST, 0), (vm.DIV, 0)], consts=[0.0])
    assert math.isnan(nan)
    assert binary(vm.EQ, nan, nan) == 0.0
    assert binary(vm.NE, nan, nan) == 1.0
    assert binary(vm.LT, nan, 1) == binary(vm.GE, nan, 1) == 0.0


@pytest.mark.parametrize('op,a,want', [
    (vm.NEG, 2, -2), (vm.NEG, 0.0, -0.0), (vm.NEG, -INF, INF),
    (vm.ABS, -3, 3), (vm.ABS, -INF, INF), (vm.ABS, -0.0, 0.0),
    (vm.SQRT, 4, 2), (vm.SQRT, -1, NAN), (vm.SQRT, -0.0, -0.0), (vm.SQRT, INF, INF),
    (vm.EXP, 0, 1), (vm.EXP, 1000, INF), (vm.EXP, -INF, 0), (vm.EXP, 1, math.e),
    (vm.LN, 1, 0), (vm.LN, math.e, 1), (vm.LN, 0, -INF), (vm.LN, -0.0, -INF),
    (vm.LN, -1, NAN), (vm.LN, INF, INF),
    (vm.LOG10, 1000, 3), (vm.LOG10, 0, -INF), (vm.LOG10, -1, NAN),
    (vm.SIN, math.pi / 2, 1), (vm.SIN, INF, NAN), (vm.COS, 0, 1), (vm.COS, INF, NAN),
    (vm.TAN, math.pi / 4, math.tan(math.pi / 4)), (vm.TAN, INF, NAN),
    (vm.ASIN, 1, math.pi / 2), (vm.ASIN, 2, NAN), (vm.ACOS, 1, 0), (vm.ACOS, -2, NAN),
    (vm.ATAN, 1, math.pi / 4), (vm.ATAN, INF, math.pi / 2),
    (vm.DEG, math.pi, 180), (vm.DEG, 1, math.degrees(1)), (vm.RAD, 180, math.pi),
    (vm.RAD, 90, math.radians(90)),
    (vm.FLOOR, 2.5, 2), (vm.FLOOR, -2.5, -3), (vm.FLOOR, INF, INF), (vm.FLOOR, NAN, NAN),
    (vm.FLOOR, -0.5, -1), (vm.FLOOR, 1e300, 1e300),
    (vm.CEIL, 2.5, 3), (vm.CEIL, -2.5, -2), (vm.CEIL, -INF, -INF), (vm.CEIL, NAN, NAN),
    (vm.ROUND, 0.5, 1), (vm.ROUND, 1.5, 2), (vm.ROUND, 2.5, 3), (vm.ROUND, -0.5, -1),
    (vm.ROUND, -2.5, -3), (vm.ROUND, 2.4999, 2), (vm.ROUND, 0.49999999999999994, 0),
    (vm.ROUND, 4503599627370497.0, 4503599627370497.0), (vm.ROUND, INF, INF),
    (vm.ROUND, -INF, -INF), (vm.ROUND, NAN, NAN),
])
def test_unary_functions(op, a, want):
    assert same(unary(op, a), want), (vm.OPCODE_NAMES[op], a)


@pytest.mark.parametrize('x,lo,hi,want', [(5, 0, 1, 1), (-5, 0, 1, 0), (0.5, 0, 1, 0.5),
                                          (NAN, 0, 1, NAN), (INF, 0, 1, 1)])
def test_clamp(x, lo, hi, want):
    got = run([(vm.LOAD, 0), (vm.LOAD, 1), (vm.LOAD, 2), (vm.CLAMP, 0)], params=(x, lo, hi))
    assert same(got, want)


@pytest.mark.parametrize('x,truthy', [(0.0, False), (-0.0, False), (1.0, True), (-2.0, True),
                                      (INF, True), (1e-300, True), (NAN, False)])
def test_truth_not_and_jumps(x, truthy):
    assert unary(vm.TRUTH, x) == float(truthy)
    assert unary(vm.NOT, x) == float(not truthy)
    # if(x, 10, 20): x; JUMP_IF_FALSE +3; 10; JUMP +2; 20
    rows = [(vm.LOAD, 0), (vm.JUMP_IF_FALSE, 3), (vm.CONST, 0), (vm.JUMP, 2), (vm.CONST, 1)]
    assert run(rows, consts=[10.0, 20.0], params=(x,)) == (10.0 if truthy else 20.0)


@pytest.mark.parametrize('a,b', [(a, b) for a in (0.0, 2.0, NAN) for b in (0.0, -3.0, NAN)])
def test_and_or_jumps(a, b):
    t = lambda v: v != 0 and v == v      # noqa: E731
    for op, want in [(vm.AND_JUMP, t(a) and t(b)), (vm.OR_JUMP, t(a) or t(b))]:
        rows = [(vm.LOAD, 0), (op, 3), (vm.LOAD, 1), (vm.TRUTH, 0)]
        assert run(rows, params=(a, b)) == float(want)


def test_untaken_branch_is_not_evaluated():
    # if(p, 1, rand()) + rand(): the second rand() is call 0 when the first is skipped.
    rows = [(vm.LOAD, 0), (vm.JUMP_IF_FALSE, 3), (vm.CONST, 0), (vm.JUMP, 2), (vm.RAND, 0),
            (vm.RAND, 0), (vm.ADD, 0)]
    h = 1234
    assert run(rows, [1.0], (1.0,), h) == 1.0 + ref_unit(ref_mix(h, 0))
    assert run(rows, [1.0], (0.0,), h) == ref_unit(ref_mix(h, 0)) + ref_unit(ref_mix(h, 1))


def test_stack_depth_and_large_pool():
    # (p0 + (p1 * (p2 - p3))) needs depth 4; the result is what is left on top
    rows = [(vm.LOAD, 0), (vm.LOAD, 1), (vm.LOAD, 2), (vm.LOAD, 3), (vm.SUB, 0), (vm.MUL, 0),
            (vm.ADD, 0)]
    code = np.array(rows, dtype=np.int32)
    stack = np.full(4, -99.0)
    got = vm.eval_expr(code, np.zeros(0), 0, len(rows), np.array([1.0, 2.0, 5.0, 3.0]),
                       np.uint64(0), stack)
    assert got == 1 + 2 * (5 - 3)


def test_evaluates_a_sub_range():
    code = np.array([(vm.CONST, 0), (vm.CONST, 1), (vm.CONST, 2), (vm.NEG, 0)], dtype=np.int32)
    consts = np.array([7.0, 8.0, 9.0])
    args = (np.zeros(0), np.uint64(0), np.empty(2))
    assert vm.eval_expr(code, consts, 1, 2, *args) == 8.0
    assert vm.eval_expr(code, consts, 2, 4, *args) == -9.0


# ---- hashing and random numbers -------------------------------------------------

@given(st.integers(0, MASK))
def test_splitmix64_matches_reference(x):
    assert int(vm.splitmix64(np.uint64(x))) == ref_splitmix64(x)


@given(st.integers(0, MASK), st.integers(0, 2**31 - 1), st.integers(0, 1000))
def test_mixers_match_reference(h, node, child):
    assert int(vm.mix(np.uint64(h), node)) == ref_mix(h, node)
    assert int(vm.edge_hash(np.uint64(h), node, child)) == ref_mix(ref_mix(h, node), child)
    assert int(vm.salt(np.uint64(h), child)) == ref_mix(h ^ int(vm.SALT_KEY), child)


def test_known_values_are_pinned():
    # The same numbers on every machine: pin a few so a change is noticed.
    assert int(vm.splitmix64(np.uint64(0))) == 0xE220A8397B1DCDAF
    assert vm.rand_seed(0.0) == ref_unit(0xE220A8397B1DCDAF)
    assert vm.rand_seed(1.0) == ref_rand_seed(1.0)


@settings(max_examples=300)
@given(st.floats(allow_nan=True, allow_infinity=True))
def test_rand_seed_is_deterministic_and_in_range(seed):
    r = vm.rand_seed(seed)
    assert 0.0 <= r < 1.0
    assert r == vm.rand_seed(seed) == ref_rand_seed(seed)
    assert unary(vm.RAND_SEED, seed) == r


def test_rand_seed_normalises_zero_and_nan():
    assert vm.rand_seed(-0.0) == vm.rand_seed(0.0)
    neg_nan = struct.unpack('<d', struct.pack('<Q', 0xFFF8000000000001))[0]
    assert vm.rand_seed(neg_nan) == vm.rand_seed(NAN)
    assert vm.rand_seed(1.0) != vm.rand_seed(-1.0)
    assert vm.rand_seed(1.0) != vm.rand_seed(np.nextafter(1.0, 2.0))


def test_rand_seed_is_roughly_uniform():
    rs = np.array([vm.rand_seed(float(i)) for i in range(10_000)])
    assert abs(rs.mean() - 0.5) < 0.02
    counts = np.histogram(rs, bins=10, range=(0, 1))[0]
    assert counts.min() > 850 and counts.max() < 1150
    assert len(set(rs.tolist())) == len(rs)


def test_rand_call_sequence():
    rows = [(vm.RAND, 0)] * 3 + [(vm.ADD, 0), (vm.ADD, 0)]
    for h in (0, 1, 2**63 + 5):
        want = [ref_unit(ref_mix(h, k)) for k in range(3)]
        assert len(set(want)) == 3
        assert run(rows, h=h) == want[0] + (want[1] + want[2])
        assert run([(vm.RAND, 0)], h=h) == want[0]
    assert run([(vm.RAND, 0)], h=1) != run([(vm.RAND, 0)], h=2)


def test_rand_per_instance_is_roughly_uniform():
    rs = np.array([run([(vm.RAND, 0)], h=int(vm.edge_hash(vm.ROOT_HASH, 3, i)))
                   for i in range(5000)])
    assert ((0 <= rs) & (rs < 1)).all()
    assert abs(rs.mean() - 0.5) < 0.02


def test_edge_and_salt_hashes_are_distinct():
    h = vm.ROOT_HASH
    seen = {int(vm.edge_hash(h, n, c)) for n in range(20) for c in range(4)}
    seen |= {int(vm.salt(h, s)) for s in range(10)}
    assert len(seen) == 20 * 4 + 10
    assert vm.edge_hash(vm.edge_hash(h, 1, 0), 1, 1) != vm.edge_hash(vm.edge_hash(h, 1, 1), 1, 0)


# ---- rule selection -------------------------------------------------------------

@pytest.mark.parametrize('x,n,want', [
    (1.0, 2, 1), (2.0, 2, 2), (1.49, 2, 1), (1.5, 2, 2), (0.5, 2, 1), (2.4999, 2, 2),
    (2.5, 2, 0), (2.5, 3, 3), (0.49, 2, 0), (0.0, 2, 0), (-0.5, 2, 0), (-1.0, 5, 0),
    (3.0, 2, 0), (NAN, 2, 0), (INF, 2, 0), (-INF, 2, 0), (1e300, 2, 0), (-1e300, 2, 0),
    (1.0, 0, 0), (0.49999999999999994, 1, 0),
])
def test_select_rule(x, n, want):
    assert vm.select_rule(x, n) == want


# ---- calculation blocks as one program ---------------------------------------------

def test_store_and_salt_run_a_block_like_its_assignments_one_by_one():
    """x = rand(); y = x + rand(); z = 2*y, run as one program (SALT, STORE), equals
    each assignment evaluated on its own with the instance hash salted by its slot."""
    h = 0x1234ABCD
    block = [(vm.SALT, 1), (vm.RAND, 0), (vm.STORE, 0),
             (vm.SALT, 2), (vm.LOAD, 0), (vm.RAND, 0), (vm.ADD, 0), (vm.STORE, 1),
             (vm.CONST, 0), (vm.LOAD, 1), (vm.MUL, 0), (vm.STORE, 2)]
    params = np.full((3, 3), NAN)
    code = np.array(block, dtype=np.int32)
    left = vm.eval_row(code, np.array([2.0]), 0, len(code), params, 1, np.uint64(h), -1,
                       np.empty(4))
    assert math.isnan(left)                      # a block leaves nothing on the stack
    x = ref_unit(ref_mix(ref_mix(h ^ int(vm.SALT_KEY), 1), 0))
    y = x + ref_unit(ref_mix(ref_mix(h ^ int(vm.SALT_KEY), 2), 0))
    assert params[1].tolist() == [x, y, 2.0 * y]
    assert np.isnan(params[[0, 2]]).all()        # only the given row is written
    assert x != y - x
