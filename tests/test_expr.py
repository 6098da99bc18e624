"""Expression compiler (pcsg.graph.expr) and printer (pcsg.language.unparse)."""
import math
import struct

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from pcsg.compiler import compile_text
from pcsg.graph.expr import FUNCTIONS, ExprTable
from pcsg.graph.peephole import fuse_operands
from pcsg.language.errors import PcsgError
from pcsg.language.ast import Binary, Call, Num, Unary, Var
from pcsg.language.unparse import unparse_arith
from pcsg.trace import vm

INF, NAN = math.inf, math.nan
S = (0, 0)


def N(v):
    return Num(v, S)


def V(name):
    return Var(name, S)


def B(op, a, b):
    return Binary(op, a, b, S)


def U(op, a):
    return Unary(op, a, S)


def C(name, *args, span=S, name_span=S):
    return Call(name, list(args), span, name_span)


def table(*names):
    errors = []
    t = ExprTable({n: i for i, n in enumerate(names)},
                  lambda span, msg, code: errors.append((span, msg, code)))
    return t, errors


def same(x, y):
    if math.isnan(x) or math.isnan(y):
        return math.isnan(x) and math.isnan(y)
    return x == y and math.copysign(1, x) == math.copysign(1, y)


def both_ways(node_of, values):
    """node_of(leaf) builds the expression; evaluate it with the inputs folded
    as constants and hidden behind parameters. Both must agree; return the value."""
    folded, e1 = table()
    i = folded.add(node_of(*[N(v) for v in values]))
    names = [f"x{k}" for k in range(len(values))]
    hidden, e2 = table(*names)
    j = hidden.add(node_of(*[V(n) for n in names]))
    assert not e1 and not e2
    assert folded.constant(i) is not None
    a = folded.evaluate(i, [])
    b = hidden.evaluate(j, values)
    assert same(a, b), (a, b)
    return a


# ---- values of operators and functions ------------------------------------------

@pytest.mark.parametrize('op,a,b,want', [
    ('+', 1, 2, 3), ('-', 1, 2, -1), ('*', 3, 4, 12), ('/', 1, 8, 0.125),
    ('/', 1, 0, INF), ('/', -1, 0, -INF), ('/', 0, 0, NAN), ('%', 7, 3, 1), ('%', -7, 3, 2),
    ('%', 7, -3, -2), ('%', 7, 0, NAN), ('^', 2, 3, 8), ('^', 2, -2, 0.25), ('^', 0, -1, INF),
    ('^', -8, 1 / 3, NAN),
    ('<', 1, 2, 1), ('<', 2, 1, 0), ('<=', 2, 2, 1), ('>', 2, 1, 1), ('>=', 1, 2, 0),
    ('==', 2, 2, 1), ('==', 0.0, -0.0, 1), ('!=', 2, 2, 0), ('!=', 1, 2, 1),
    ('==', NAN, NAN, 0), ('!=', NAN, NAN, 1), ('<', NAN, 1, 0), ('>=', NAN, NAN, 0),
    ('&&', 1, 2, 1), ('&&', 0, 2, 0), ('&&', 2, 0, 0), ('&&', NAN, 1, 0), ('&&', -3, INF, 1),
    ('||', 0, 0, 0), ('||', 0, 5, 1), ('||', 5, 0, 1), ('||', NAN, 0, 0), ('||', NAN, 2, 1),
])
def test_binary_operators(op, a, b, want):
    assert same(both_ways(lambda x, y: B(op, x, y), [a, b]), want)


@pytest.mark.parametrize('op,a,want', [('-', 2, -2), ('-', 0.0, -0.0), ('+', -3, -3),
                                       ('!', 0, 1), ('!', -0.0, 1), ('!', 2, 0), ('!', NAN, 1),
                                       ('!', INF, 0)])
def test_unary_operators(op, a, want):
    assert same(both_ways(lambda x: U(op, x), [a]), want)


CASES = [
    ('min', [3, 1], 1), ('min', [3, 1, -2, 5], -2), ('min', [1, NAN], NAN),
    ('max', [3, 1], 3), ('max', [3, 1, 7, 5], 7), ('max', [NAN, 1, 2], NAN),
    ('abs', [-2.5], 2.5), ('sqrt', [9], 3), ('sqrt', [-1], NAN), ('pow', [2, 0.5], math.sqrt(2)),
    ('pow', [0, -1], INF), ('exp', [0], 1), ('exp', [1000], INF), ('ln', [1], 0), ('ln', [0], -INF),
    ('ln', [-1], NAN), ('log', [math.e], 1), ('log', [0], -INF), ('log10', [100], 2),
    ('log10', [0], -INF), ('sin', [0], 0), ('cos', [0], 1), ('tan', [0], 0),
    ('asin', [1], math.pi / 2), ('asin', [1.5], NAN), ('acos', [1], 0), ('acos', [-1.5], NAN),
    ('atan', [1], math.pi / 4), ('atan2', [1, 0], math.pi / 2), ('atan2', [0, -1], math.pi),
    ('atan2', [-1, 0], -math.pi / 2), ('deg', [math.pi / 2], 90), ('rad', [180], math.pi),
    ('floor', [-1.5], -2), ('floor', [INF], INF), ('ceil', [-1.5], -1), ('ceil', [NAN], NAN),
    ('round', [2.5], 3), ('round', [-2.5], -3), ('round', [0.5], 1), ('round', [1.4999], 1),
    ('clamp', [5, 0, 2], 2), ('clamp', [-5, 0, 2], 0), ('clamp', [1, 0, 2], 1),
    ('if', [1, 10, 20], 10), ('if', [0, 10, 20], 20), ('if', [NAN, 10, 20], 20),
    ('if', [-0.0, 10, 20], 20), ('if', [0.001, 10, 20], 10),
]


@pytest.mark.parametrize('name,args,want', CASES)
def test_functions(name, args, want):
    assert same(both_ways(lambda *xs: C(name, *xs), args), want)


def test_every_function_is_covered():
    assert {name for name, _, _ in CASES} | {'rand'} == set(FUNCTIONS)


def test_pi():
    t, errors = table()
    assert t.constant(t.add(V('pi'))) == math.pi
    t, errors = table('pi')          # a parameter takes precedence over the constant
    assert t.instructions(t.add(V('pi'))) == [('LOAD', 0)]


# ---- short-circuit ------------------------------------------------------------------

@pytest.mark.parametrize('c', [1.0, -2.0, 0.0, NAN])
def test_if_untaken_branch_does_not_matter(c):
    t, _ = table('c', 'q')
    taken = c != 0 and c == c
    for bad in [B('/', N(1), N(0)), B('/', N(0), N(0)), C('ln', N(-1))]:
        i = t.add(C('if', V('c'), V('q'), bad) if taken else C('if', V('c'), bad, V('q')))
        j = t.add(C('if', U('!', V('c')), bad, V('q')) if taken
                  else C('if', U('!', V('c')), V('q'), bad))
        assert t.evaluate(i, [c, 7.0]) == t.evaluate(j, [c, 7.0]) == 7.0


def test_if_counts_only_executed_rand_calls():
    t, _ = table('c')
    i = t.add(B('+', C('if', V('c'), C('rand'), N(0)), C('rand')))
    h = 99
    r = [vm.hash_to_unit(vm.mix(np.uint64(h), k)) for k in range(2)]
    assert t.evaluate(i, [1.0], h) == r[0] + r[1]
    assert t.evaluate(i, [0.0], h) == 0 + r[0]


def test_and_or_short_circuit():
    t, _ = table('a')
    first = vm.hash_to_unit(vm.mix(np.uint64(5), 0))
    # (a && rand() < 2) + rand(): the right operand of && runs only when a is true
    i = t.add(B('+', B('&&', V('a'), B('<', C('rand'), N(2))), C('rand')))
    second = vm.hash_to_unit(vm.mix(np.uint64(5), 1))
    assert t.evaluate(i, [1.0], 5) == 1 + second
    assert t.evaluate(i, [0.0], 5) == 0 + first
    j = t.add(B('+', B('||', V('a'), B('<', C('rand'), N(2))), C('rand')))
    assert t.evaluate(j, [1.0], 5) == 1 + first
    assert t.evaluate(j, [0.0], 5) == 1 + second
    # the value of && / || is 1 or 0 whatever the operands
    k = t.add(B('&&', V('a'), B('/', N(1), V('a'))))
    assert t.evaluate(k, [0.0]) == 0.0 and t.evaluate(k, [4.0]) == 1.0


# ---- rand -----------------------------------------------------------------------------

def test_rand_seed_folds_and_matches_vm():
    t, _ = table('s')
    i = t.add(C('rand', N(3)))
    assert t.instructions(i) == [('CONST', 0)]
    assert t.constant(i) == vm.rand_seed(3.0)
    j = t.add(C('rand', V('s')))
    assert t.evaluate(j, [3.0]) == vm.rand_seed(3.0)
    assert t.evaluate(j, [-0.0], 1) == t.evaluate(j, [0.0], 2)
    assert t.reads(j) == {'s'} and not t.uses_rand(j)


def test_rand_depends_on_instance_and_call_index():
    t, _ = table()
    i = t.add(B('-', C('rand'), C('rand')))
    assert t.constant(i) is None and t.uses_rand(i) and t.reads(i) == frozenset()
    r = lambda h, k: vm.hash_to_unit(vm.mix(np.uint64(h), k))   # noqa: E731
    assert t.evaluate(i, [], 1) == r(1, 0) - r(1, 1) != 0
    assert t.evaluate(i, [], 1) != t.evaluate(i, [], 2)
    one = t.add(C('rand'))
    values = {t.evaluate(one, [], int(vm.salt(vm.ROOT_HASH, s))) for s in range(100)}
    assert len(values) == 100 and all(0 <= v < 1 for v in values)


# ---- folding -------------------------------------------------------------------------

def test_constant_expression_is_one_instruction():
    t, _ = table('p')
    e = B('+', B('*', N(2), C('sin', V('pi'))), C('max', N(1), N(2), C('sqrt', N(16))))
    i = t.add(e)
    assert t.instructions(i) == [('CONST', 0)]
    assert t.constant(i) == 2 * math.sin(math.pi) + 4
    assert t.reads(i) == frozenset()


def test_if_with_constant_condition_keeps_the_branch():
    t, _ = table('p', 'q')
    i = t.add(C('if', N(1), V('p'), B('/', N(1), N(0))))
    assert t.instructions(i) == [('LOAD', 0)]
    j = t.add(C('if', B('>', N(0), N(1)), V('p'), B('*', V('q'), N(2))))
    assert t.instructions(j) == [('LOAD', 1), ('CONST', 0), ('MUL', 0)]
    assert t.reads(j) == {'q'}
    k = t.add(C('if', B('/', N(0), N(0)), V('p'), V('q')))       # nan is false
    assert t.instructions(k) == [('LOAD', 1)]


def test_logic_with_constant_left_side_folds():
    t, _ = table('p')
    assert t.constant(t.add(B('&&', N(0), V('p')))) == 0.0
    assert t.constant(t.add(B('||', N(3), V('p')))) == 1.0
    assert t.instructions(t.add(B('&&', N(3), V('p')))) == [('LOAD', 0), ('TRUTH', 0)]
    assert t.instructions(t.add(B('||', N(0), B('<', V('p'), N(1))))) == \
        [('LOAD', 0), ('CONST', 1), ('LT', 0)]


def test_partial_folding():
    t, _ = table('p')
    i = t.add(B('+', V('p'), B('*', N(2), N(3))))
    assert t.instructions(i) == [('LOAD', 0), ('CONST', 0), ('ADD', 0)]
    assert t.arrays()['consts'][0] == 6.0
    # p*0 is not 0 (p may be inf or nan): no algebraic simplification
    j = t.add(B('*', V('p'), N(0)))
    assert t.reads(j) == {'p'}
    assert math.isnan(t.evaluate(j, [INF]))


HEAD = """
{ s = 2; a = 3; b = a * 2; d = 1 / s; e = d + 1; s = s + 0 } S
S if(s > 0, 2, 1)
1: S → move(0, 0, d) sphere
2: S → move(b, e, d) cube ∪ {s = s - 1} S
"""


def head_constants(text, **overrides):
    """The parameters whose reads fold to a constant, with their values."""
    g = compile_text(text, "t.pcsg", overrides)
    return {name: g.exprs.constant(g.exprs.add(V(name))) for name in g.params
            if g.exprs.constant(g.exprs.add(V(name))) is not None}


def test_the_axiom_head_folds_what_it_computes():
    """A parameter assigned once in the axiom's head block from constants reads as
    that constant everywhere: also from parameters assigned before it in the head
    (b from a), and from one assigned again later (d from s, which the rules change:
    at the head s is 2 on every path)."""
    assert head_constants(HEAD) == {"a": 3.0, "b": 6.0, "d": 0.5, "e": 1.5}
    assert head_constants(HEAD, a=5) == {"a": 5.0, "b": 10.0, "d": 0.5, "e": 1.5}


def test_a_read_before_the_assignment_stays_an_error():
    """Folding q's later value into d would hide the read that checks.py reports."""
    text = HEAD.replace("d = 1 / s;", "d = 1 / s + q; q = 1;")
    with pytest.raises(PcsgError, match="'q' may be read before it is assigned"):
        compile_text(text, "t.pcsg")


def test_constant_pool_is_shared_and_keeps_signed_zero():
    t, _ = table('p')
    a = t.add(B('+', V('p'), N(1)))
    b = t.add(B('-', V('p'), N(1)))
    c = t.add(B('+', V('p'), U('-', N(0.0))))
    arr = t.arrays()
    assert list(arr['consts']) == [1.0, -0.0]
    assert math.copysign(1, arr['consts'][1]) == -1
    assert t.instructions(a)[1] == t.instructions(b)[1] == ('CONST', 0)
    assert t.instructions(c)[1] == ('CONST', 1)


# ---- folded and unfolded evaluation agree ----------------------------------------------

LEAF_VALUES = [0.0, -0.0, 0.5, 1.0, 2.0, -3.0, 1.5, 10.0, 1e300, 0.1, INF, NAN]
BINOPS = ['+', '-', '*', '/', '%', '^', '<', '<=', '>', '>=', '==', '!=', '&&', '||']
FUNCS = [(name, lo, hi if hi is not None else 4) for name, (_, lo, hi) in FUNCTIONS.items()]


def trees():
    leaf = st.one_of(st.sampled_from(LEAF_VALUES).map(N), st.just(V('p')),
                     st.just(V('pi')))

    def extend(sub):
        unary = st.builds(U, st.sampled_from(['-', '+', '!']), sub)
        binary = st.builds(B, st.sampled_from(BINOPS), sub, sub)

        @st.composite
        def call(draw):
            name, lo, hi = draw(st.sampled_from(FUNCS))
            n = draw(st.integers(lo, hi))
            return C(name, *[draw(sub) for _ in range(n)])
        return st.one_of(unary, binary, call())
    return st.recursive(leaf, extend, max_leaves=12)


def hide_constants(node, values):
    """A copy of node with every number replaced by a parameter holding it."""
    if isinstance(node, Num):
        values.append(float(node.value))
        return V(f"k{len(values) - 1}")
    if isinstance(node, Var):
        return node
    if isinstance(node, Unary):
        return U(node.op, hide_constants(node.operand, values))
    if isinstance(node, Binary):
        return B(node.op, hide_constants(node.left, values), hide_constants(node.right, values))
    return C(node.name, *[hide_constants(a, values) for a in node.args])


def bits(x):
    return struct.pack('<d', x)


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(trees(), st.sampled_from([0.0, 1.0, -2.5, 0.5, NAN, INF]), st.integers(0, 2**64 - 1))
def test_folding_never_changes_a_value(tree, p, h):
    folded, e1 = table('p')
    i = folded.add(tree)
    values = []
    hidden_tree = hide_constants(tree, values)
    names = ['p'] + [f"k{k}" for k in range(len(values))]
    hidden, e2 = table(*names)
    j = hidden.add(hidden_tree)
    assert not e1 and not e2
    a = folded.evaluate(i, [p], h)
    b = hidden.evaluate(j, [p] + values, h)
    assert bits(a) == bits(b) or (math.isnan(a) and math.isnan(b)), (unparse_arith(tree), a, b)
    if folded.reads(i) == frozenset() and not folded.uses_rand(i):
        assert [op for op, _ in folded.instructions(i)] == ['CONST']
        assert folded.constant(i) is not None
    # max_stack is enough: evaluate with a stack of exactly that size
    arr = folded.arrays()
    stack = np.full(arr['max_stack'], 12345.0)
    c = vm.eval_expr(arr['code'], arr['consts'], arr['start'][i], arr['end'][i],
                     np.array([p]), np.uint64(h), stack)
    assert bits(c) == bits(a) or (math.isnan(a) and math.isnan(c))
    # the tracer's fused bytecode gives the same bits, folded or not
    for t, k, vals in ((folded, i, [p]), (hidden, j, [p] + values)):
        arr = t.arrays()
        code, remap = fuse_operands(arr['code'], arr['start'])
        f = vm.eval_expr(code, arr['consts'], remap[arr['start'][k]], remap[arr['end'][k]],
                         np.array(vals), np.uint64(h), np.empty(arr['max_stack']))
        assert bits(f) == bits(a) or (math.isnan(a) and math.isnan(f)), unparse_arith(tree)


# ---- reads, uses_rand, arrays ---------------------------------------------------------

def test_reads_and_uses_rand():
    t, _ = table('a', 'b', 'c')
    i = t.add(B('+', V('a'), C('if', V('b'), N(1), C('rand'))))
    assert t.reads(i) == {'a', 'b'} and t.uses_rand(i)
    j = t.add(C('if', B('<', N(1), N(2)), V('c'), V('a')))
    assert t.reads(j) == {'c'} and not t.uses_rand(j)
    k = t.add(B('*', N(0), C('rand', N(1))))
    assert t.reads(k) == frozenset() and not t.uses_rand(k) and t.constant(k) == 0.0
    assert len(t) == 3


def test_arrays_layout_and_stack_depth():
    t, _ = table('p')
    left = t.add(B('+', B('+', B('+', V('p'), V('p')), V('p')), V('p')))
    right = t.add(B('+', V('p'), B('+', V('p'), B('+', V('p'), V('p')))))
    arr = t.arrays()
    assert arr['code'].dtype == np.int32 and arr['code'].shape == (14, 2)
    assert arr['consts'].dtype == np.float64
    assert list(arr['start']) == [0, 7] and list(arr['end']) == [7, 14]
    assert arr['start'].dtype == arr['end'].dtype == np.int32
    assert arr['max_stack'] == 4
    assert t.evaluate(left, [2.0]) == t.evaluate(right, [2.0]) == 8.0
    t2, _ = table('p')
    t2.add(B('+', B('+', V('p'), V('p')), V('p')))
    assert t2.arrays()['max_stack'] == 2
    # min over many arguments stays shallow; if() takes the deepest branch
    t3, _ = table('p')
    t3.add(C('min', V('p'), V('p'), V('p'), V('p'), V('p')))
    assert t3.arrays()['max_stack'] == 2
    t3.add(C('if', V('p'), V('p'), B('-', V('p'), B('*', V('p'), V('p')))))
    assert t3.arrays()['max_stack'] == 3
    assert len(t3) == 2


def test_empty_table():
    t, _ = table()
    arr = t.arrays()
    assert arr['code'].shape == (0, 2) and len(arr['start']) == 0 and arr['max_stack'] >= 1


# ---- errors ---------------------------------------------------------------------------

def test_unknown_function():
    t, errors = table('p')
    i = t.add(B('+', V('p'), C('sqr', V('p'), span=(4, 10), name_span=(4, 7))))
    (span, msg, code), = errors
    assert code == 'unknown-function' and span == (4, 7)
    assert "'sqr'" in msg and 'sqrt' in msg and 'atan2' in msg
    assert math.isnan(t.evaluate(i, [1.0]))


@pytest.mark.parametrize('name,n,msg', [
    ('pow', 3, "'pow' takes 2 arguments, got 3"),
    ('sqrt', 0, "'sqrt' takes 1 argument, got 0"),
    ('min', 1, "'min' takes at least 2 arguments, got 1"),
    ('rand', 2, "'rand' takes 0 or 1 arguments, got 2"),
    ('if', 2, "'if' takes 3 arguments, got 2"),
    ('clamp', 4, "'clamp' takes 3 arguments, got 4"),
])
def test_arity(name, n, msg):
    t, errors = table()
    i = t.add(C(name, *[N(1)] * n, span=(3, 9), name_span=(3, 5)))
    assert errors == [((3, 9), msg, 'arity')]
    assert math.isnan(t.evaluate(i, []))


def test_undefined_name_and_collecting_all_errors():
    t, errors = table('p')
    e = B('+', Var('x', (0, 1)), C('foo', Var('y', (8, 9)), span=(4, 10), name_span=(4, 7)))
    i = t.add(B('*', V('p'), e))
    assert [(s, c) for s, _, c in errors] == [((0, 1), 'undefined-name'),
                                              ((8, 9), 'undefined-name'),
                                              ((4, 7), 'unknown-function')]
    assert errors[0][1] == "undefined name 'x'"
    assert i == 0 and len(t) == 1
    assert math.isnan(t.evaluate(i, [1.0]))
    j = t.add(V('p'))              # the table stays usable
    assert t.evaluate(j, [4.0]) == 4.0


# ---- unparse -------------------------------------------------------------------------

a, b, c = V('a'), V('b'), V('c')


@pytest.mark.parametrize('node,text', [
    (U('-', B('^', N(2), N(2))), '-2^2'),
    (B('^', U('-', N(2)), N(2)), '(-2)^2'),
    (B('^', N(-2), N(2)), '(-2)^2'),
    (B('^', N(2), U('-', N(1))), '2^-1'),
    (B('^', N(2), N(-1)), '2^-1'),
    (B('^', N(2), B('^', N(3), N(2))), '2^3^2'),
    (B('^', B('^', N(2), N(3)), N(2)), '(2^3)^2'),
    (B('-', a, B('-', b, c)), 'a - (b - c)'),
    (B('-', B('-', a, b), c), 'a - b - c'),
    (B('/', a, B('*', b, c)), 'a / (b * c)'),
    (B('*', B('/', a, b), c), 'a / b * c'),
    (B('*', B('+', a, b), c), '(a + b) * c'),
    (B('+', a, B('*', b, c)), 'a + b * c'),
    (B('%', a, B('%', b, c)), 'a % (b % c)'),
    (U('!', B('&&', a, b)), '!(a && b)'),
    (B('&&', U('!', a), b), '!a && b'),
    (B('||', B('&&', a, b), c), 'a && b || c'),
    (B('&&', B('||', a, b), c), '(a || b) && c'),
    (B('&&', a, B('&&', b, c)), 'a && (b && c)'),
    (B('<', B('<', a, b), c), '(a < b) < c'),
    (B('==', a, B('<', b, c)), 'a == (b < c)'),
    (B('<', B('+', a, N(1)), B('*', b, N(2))), 'a + 1 < b * 2'),
    (U('-', U('-', a)), '- -a'),
    (U('-', N(-2)), '- -2'),
    (U('-', B('+', a, b)), '-(a + b)'),
    (B('-', a, U('-', b)), 'a - -b'),
    (B('^', U('!', a), b), '(!a)^b'),
    (B('^', C('sqrt', a), B('+', b, c)), 'sqrt(a)^(b + c)'),
    (C('if', B('>', a, N(0)), N(2), N(1)), 'if(a > 0, 2, 1)'),
    (C('rand'), 'rand()'),
    (C('min', B('||', a, b), N(0.5)), 'min(a || b, 0.5)'),
    (N(1.0), '1'), (N(0.1), '0.1'), (N(1e300), '1e+300'), (N(2.5e-7), '2.5e-07'),
    (N(-0.0), '-0'), (N(123456789.0), '123456789'), (N(1 / 3), '0.3333333333333333'),
    (N(INF), '(1/0)'), (N(-INF), '(-1/0)'), (N(NAN), '(0/0)'),
    (B('^', N(INF), N(2)), '(1/0)^2'), (U('-', N(NAN)), '-(0/0)'),
])
def test_unparse(node, text):
    assert unparse_arith(node) == text


@given(st.floats(allow_nan=False, allow_infinity=False))
def test_numbers_round_trip(x):
    text = unparse_arith(Num(x, S))
    assert float(text) == x and math.copysign(1, float(text)) == math.copysign(1, x)
    assert not text.endswith('.0')
