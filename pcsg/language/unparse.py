"""Print arithmetic syntax trees back as notation text, with the fewest parentheses.

Binding levels (section 6 of the notation), loosest first:
1 ||   2 &&   3 comparisons   4 + -   5 * / %   6 unary - + !   7 ^   8 operands.
`^` is right-associative and its exponent may be a unary expression, as in
Python: -2^2 is -(2^2) and 2^-1 is 2^(-1). The other binary operators are
left-associative; comparisons are printed as non-associative (a comparison
operand of a comparison is always parenthesised) so the text never depends on
whether the parser chains them.
"""
from __future__ import annotations

import math

from . import ast

_LEVEL = {'||': 1, '&&': 2,
          '<': 3, '<=': 3, '>': 3, '>=': 3, '==': 3, '!=': 3,
          '+': 4, '-': 4, '*': 5, '/': 5, '%': 5, '^': 7}
_UNARY, _ATOM = 6, 8


def unparse_arith(node) -> str:
    return _text(node)[0]


def format_number(v: float) -> str:
    """repr-exact decimal text, without a trailing '.0'; inf and nan as divisions."""
    v = float(v)
    if math.isnan(v):
        return '(0/0)'
    if math.isinf(v):
        return '(1/0)' if v > 0 else '(-1/0)'
    s = repr(v)
    return s[:-2] if s.endswith('.0') else s


def _text(n) -> tuple[str, int]:
    """The text of n and the binding level of its outermost operator."""
    if isinstance(n, ast.Num):
        s = format_number(n.value)
        return s, _UNARY if s.startswith('-') else _ATOM
    if isinstance(n, ast.Var):
        return n.name, _ATOM
    if isinstance(n, ast.Call):
        return f"{n.name}({', '.join(_text(a)[0] for a in n.args)})", _ATOM
    if isinstance(n, ast.Unary):
        s = _operand(n.operand, _UNARY)
        sep = ' ' if n.op in '-+' and s.startswith(n.op) else ''
        return n.op + sep + s, _UNARY
    if isinstance(n, ast.Binary):
        level = _LEVEL[n.op]
        if n.op == '^':
            return f"{_operand(n.left, _ATOM)}^{_operand(n.right, _UNARY)}", level
        right_min = level + 1
        left_min = level + 1 if level == 3 else level
        return f"{_operand(n.left, left_min)} {n.op} {_operand(n.right, right_min)}", level
    raise TypeError(f"not an arithmetic node: {n!r}")


def _operand(n, at_least: int) -> str:
    """n's text, parenthesised unless its level is at least `at_least`."""
    s, level = _text(n)
    return s if level >= at_least else f"({s})"
