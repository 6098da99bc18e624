"""graph/hashes.py computes trace/vm.py's hashes and rule selection bit for bit: the
derivation and the bounds' state keys must name the instances the tracer names."""
import math

import numpy as np
from hypothesis import given, settings, strategies as st

from pcsg.graph import hashes
from pcsg.trace import vm

U64 = st.integers(0, 2**64 - 1)
FLOATS = st.one_of(st.floats(allow_nan=True, allow_infinity=True),
                   st.sampled_from([0.0, -0.0, math.nan, -math.nan, 0.5, -0.5, 1.5, 2.5,
                                    -2.5, 1e300, -1e300, 5e-324]),
                   st.integers(-8, 8).map(lambda k: k / 2))


@settings(max_examples=400, deadline=None)
@given(U64, U64, U64)
def test_the_hashes_are_vms(h, a, b):
    assert hashes.splitmix64(h) == int(vm.splitmix64(np.uint64(h)))
    assert hashes.mix(h, a) == int(vm.mix(np.uint64(h), np.uint64(a)))
    assert hashes.edge_hash(h, a, b) == int(vm.edge_hash(np.uint64(h), np.uint64(a),
                                                         np.uint64(b)))
    assert hashes.salt(h, a) == int(vm.salt(np.uint64(h), np.uint64(a)))


@settings(max_examples=400, deadline=None)
@given(FLOATS, st.integers(1, 9))
def test_float_bits_and_rule_selection_are_vms(x, nrules):
    assert hashes.float_bits(x) == int(vm.float_bits(x))
    assert hashes.select_rule(x, nrules) == int(vm.select_rule(x, nrules))


def test_the_cases_that_differ_from_plain_python():
    assert hashes.float_bits(-0.0) == hashes.float_bits(0.0) == 0
    assert hashes.float_bits(-math.nan) == hashes.float_bits(math.nan) == 0x7FF8000000000000
    # halves round away from zero (Python's round() would give 2 and -2)
    assert [hashes.select_rule(x, 9) for x in (2.5, 1.4999999999999998, 0.5, 9.5)] == [3, 1, 1, 0]
    assert hashes.select_rule(-0.5, 9) == 0
