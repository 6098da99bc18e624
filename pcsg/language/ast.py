"""Syntax tree of a .pcsg file.

Every node carries `span`, a (start, end) pair of character offsets into the
*expanded* text (after #define); `Source.locate` maps them back to the file,
and through macros to both the place of use and the place of definition.
"""
from __future__ import annotations

from dataclasses import dataclass, field

Span = tuple[int, int]


# ---- arithmetic ---------------------------------------------------------

@dataclass(eq=False)
class Num:
    value: float
    span: Span


@dataclass(eq=False)
class Var:
    name: str
    span: Span


@dataclass(eq=False)
class Call:
    name: str
    args: list
    span: Span
    name_span: Span


@dataclass(eq=False)
class Unary:
    op: str          # '-', '+', '!'
    operand: object
    span: Span


@dataclass(eq=False)
class Binary:
    op: str          # + - * / % ^ < <= > >= == != && ||
    left: object
    right: object
    span: Span


def arithmetic_nodes(node):
    """The nodes of an arithmetic AST, each before its operands, left to right."""
    stack = [node]
    while stack:
        n = stack.pop()
        yield n
        if isinstance(n, Call):
            stack.extend(reversed(n.args))
        elif isinstance(n, Unary):
            stack.append(n.operand)
        elif isinstance(n, Binary):
            stack.extend([n.right, n.left])


def reads_of(node, name):
    """The reads of the name `name` in an arithmetic AST, in order."""
    return [n for n in arithmetic_nodes(node) if isinstance(n, Var) and n.name == name]


# ---- CSG expressions ----------------------------------------------------

@dataclass(eq=False)
class Ref:
    """A module, named expression or primitive, resolved by the graph builder."""
    name: str
    span: Span


@dataclass(eq=False)
class Fractal:
    """A primitive with arguments: mandelbulb(power), julia(cx, cy, cz, cw)."""
    name: str
    args: list
    span: Span


@dataclass(eq=False)
class CsgOp:
    op: str          # 'union', 'intersection', 'difference'
    left: object
    right: object
    span: Span
    op_span: Span


@dataclass(eq=False)
class Transform:
    name: str        # move, scale, ..., matrix
    args: list
    operand: object
    span: Span
    head_span: Span  # the name and its argument list


@dataclass(eq=False)
class Assign:
    name: str
    value: object
    span: Span
    name_span: Span


@dataclass(eq=False)
class Calc:
    assigns: list[Assign]
    operand: object
    span: Span
    head_span: Span  # the { ... } block


@dataclass(eq=False)
class Paint:
    args: list
    operand: object
    span: Span
    head_span: Span


@dataclass(eq=False)
class Material:
    name: str
    operand: object
    span: Span
    head_span: Span
    name_span: Span


# ---- statements ---------------------------------------------------------

@dataclass(eq=False)
class Axiom:
    expr: object
    span: Span


@dataclass(eq=False)
class ModuleDecl:
    name: str
    selection: object
    span: Span
    name_span: Span


@dataclass(eq=False)
class Rule:
    number: int
    module: str
    body: object
    span: Span
    number_span: Span
    module_span: Span


@dataclass(eq=False)
class Named:
    name: str
    body: object
    span: Span
    name_span: Span


@dataclass(eq=False)
class Tuple:
    """A directive's parenthesised list of values, e.g. eye=(3,-4,2)."""
    items: list
    span: Span


@dataclass(eq=False)
class DirectiveItem:
    key: str
    value: object    # an arithmetic node or a Tuple
    span: Span
    key_span: Span


@dataclass(eq=False)
class Directive:
    kind: str        # 'camera', 'light', 'sky', 'material'
    name: str | None
    items: list[DirectiveItem]
    span: Span
    kind_span: Span


@dataclass(eq=False)
class Program:
    statements: list = field(default_factory=list)

    def of(self, cls):
        return [s for s in self.statements if isinstance(s, cls)]
