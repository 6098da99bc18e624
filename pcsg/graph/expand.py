"""`pcsg expand`: N parallel derivation steps of the axiom (the paper's §2.1),
printed as PCSG text. Modules not yet rewritten stay as names, preceded by a
calculation block that gives them their parameter values."""
from __future__ import annotations

from .derive import Deriver, State, format_value
from .model import CALC, DIFFERENCE, INTERSECTION, MATERIAL, OPERATOR_SYMBOLS, PAINT, PRIMITIVE, \
    SELECT, TRANSFORM, UNION, Graph
from ..language.source import one_line
from ..recursion import SYNTAX_DEPTH, on_deep_stack, recursion_limit
from .stats import MAX_LEVELS

# Loosest to tightest, as notation §3: ∪, ∩, \, then prefix operators and operands.
_LEVEL = {UNION: 1, INTERSECTION: 2, DIFFERENCE: 3}
_PREFIX = 4


class _Printer:
    def __init__(self, graph: Graph, steps: int, max_chars: int):
        self.g = graph
        self.d = Deriver(graph)
        self.steps = steps
        self.max_chars = max_chars
        self.size = 0
        self.modules_left = 0
        self.left: set[str] = set()     # the modules the word still names

    def out(self, parts: list, text: str):
        parts.append(text)
        self.size += len(text)
        if self.size > self.max_chars:
            raise ExpansionTooLarge(self.max_chars)

    def word(self, node_id: int, state: State, h: int, steps: int, need: int, parts: list):
        """Append the text of node's derivation; parenthesise if looser than `need`."""
        node = self.g.nodes[node_id]
        kind = node.kind
        if kind == SELECT and steps == 0:
            self._module(node, state, parts, need)
        elif kind == SELECT:
            r = self.d.select(node_id, state, h)
            self.word(node.children[r], state, self.d.edge(h, node_id, r), steps - 1, need, parts)
        elif kind == CALC:
            self.word(node.children[0], self.d.calc(node_id, state, h), h, steps, need, parts)
        elif kind == PRIMITIVE:
            args = self.g.constant_args(node_id)
            self.out(parts, node.name + (f"({', '.join(map(format_value, args))})"
                                         if args else ""))
        elif kind in _LEVEL:
            level = _LEVEL[kind]
            wrap = level < need
            if wrap:
                self.out(parts, "(")
            for k, c in enumerate(node.children):
                if k:
                    self.out(parts, f" {OPERATOR_SYMBOLS[kind]} ")
                self.word(c, state, self.d.edge(h, node_id, k), steps, level + (k > 0), parts)
            if wrap:
                self.out(parts, ")")
        else:
            if kind == TRANSFORM:
                args = self.d.args(node_id, state, h)
                head = node.name + (f"({', '.join(map(format_value, args))})" if args else "")
            elif kind == PAINT:
                head = f"paint({', '.join(map(format_value, self.d.args(node_id, state, h)))})"
            else:
                assert kind == MATERIAL
                head = f"material({node.name})"
            self.out(parts, head + " ")
            self.word(node.children[0], state, h, steps, _PREFIX, parts)

    def _module(self, node, state: State, parts: list, need: int):
        self.modules_left += 1
        self.left.add(node.name)
        values = "; ".join(f"{k} = {format_value(v)}" for k, v in state.items(self.g))
        self.out(parts, f"{{{values}}} {node.name}" if values else node.name)


PIXELS_TAKEN = ("selections that read `pixels` took it as +inf (there is no camera here), so "
                "the word is derived as if every instance were large, and a render of it "
                "keeps that detail far away too")
REDRAWN = ("the written word's modules draw other numbers from rand() than the file's: rand() "
           "depends on the path from the axiom, which the word starts anew, so below the "
           "modules it leaves the primitives differ (rand(seed) draws the same)")


GRAFTAL_LEFT = ("the word leaves graftal modules, which a render refines from where they "
                "stand: --max-depth counts from the new axiom, and their shading averages the "
                "boxes on each ray's path from it, so its picture differs a little from the "
                "file's (`stats` and `export --max-depth N` count from the new axiom too)")


def redraws(graph: Graph) -> bool:
    """Whether some expression calls rand() without a seed: its numbers depend on the
    instance's path from the axiom."""
    return any(graph.exprs.uses_rand(i) for i in range(len(graph.exprs)))


class ExpansionTooLarge(Exception):
    def __init__(self, limit: int):
        super().__init__(f"the expansion is longer than {limit:,} "
                         f"character{'' if limit == 1 else 's'}; "
                         f"use fewer steps or --max-chars")


def expand_axiom(graph: Graph, steps: int, max_chars: int = 50_000_000) -> str:
    """The axiom after `steps` parallel derivation steps, as one CSG expression."""
    return _deep(_expand, graph, steps, max_chars)[0]


def _deep(fn, *args):
    """fn(*args) with room for the printer's recursion, a few calls a node: a row of 400
    modules expanded 250 steps deep, or 1,000 nested transformations, raised
    RecursionError (the word, and the file's parse again)."""
    with recursion_limit(SYNTAX_DEPTH + 20 * MAX_LEVELS):
        return on_deep_stack(fn, *args)


def _expand(graph: Graph, steps: int, max_chars: int) -> tuple[str, _Printer]:
    if least_chars(graph, min(steps, MAX_LEVELS)) > max_chars:
        raise ExpansionTooLarge(max_chars)
    p = _Printer(graph, min(steps, MAX_LEVELS), max_chars)
    state, h = p.d.initial()
    parts: list[str] = []
    p.word(graph.root, state, h, p.steps, 0, parts)
    return "".join(parts), p


COUNTED_STATES = 20_000        # least_chars' count: a fraction of a second at most


def least_chars(graph: Graph, steps: int) -> int:
    """At least the characters of the word after `steps` steps: a name for each primitive
    and module it leaves, and an operator (` ∪ `) between two of them, counted without
    deriving it (0 where the count passes COUNTED_STATES states: a system whose rules are
    drawn at random). The printer stops at --max-chars as it goes, but it writes about 2
    million characters a second: Sierpinski at 12 expanded 12 steps was refused after
    24 s and 430 MB."""
    import numpy as np
    from ..language.errors import PcsgError
    from .cut import BOX, Cut, VOLUME_NAMES
    from .stats import count_by_primitive
    n = len(graph.nodes)
    # cut where the word leaves its modules, counted as the cut's boxes: a "cube" may be
    # a module, whose name may be one letter
    cut = Cut(steps, np.array([node.kind == SELECT for node in graph.nodes]),
              np.full(n, -1), np.full(n, BOX), np.zeros((n, 4, 4)))
    try:
        counts = count_by_primitive(graph, COUNTED_STATES, cut)
    except PcsgError:
        return 0
    names = sum((1 if name == VOLUME_NAMES[BOX] else len(name)) * k
                for name, k in counts.items())
    return names + 3 * max(sum(counts.values()) - 1, 0)


def _axiom_head(graph: Graph, d: Deriver) -> str:
    state, h = d.initial()
    i = graph.root
    while graph.nodes[i].kind == CALC:
        state = d.calc(i, state, h)
        i = graph.nodes[i].children[0]
    return "; ".join(f"{k} = {format_value(v)}" for k, v in state.items(graph))


def expand_file(graph: Graph, steps: int, max_chars: int = 50_000_000,
                notes: list[str] | None = None, overrides=()) -> str:
    """The whole file with its axiom replaced by the expansion: a file `pcsg check` accepts.
    Macros are shown expanded, since the axiom is printed from the expanded text. Appends
    to `notes` what the user must know of it: where modules are left that draw `rand()`,
    the file derives other primitives below them (redrawn). `overrides`, the (name, value)
    pairs the graph was compiled with, are named in the header."""
    return _deep(_expand_file, graph, steps, max_chars, notes, overrides)


def _expand_file(graph: Graph, steps: int, max_chars: int, notes: list[str] | None,
                 overrides) -> str:
    axiom, p = _expand(graph, steps, max_chars)
    if notes is not None and p.modules_left and redraws(graph):
        notes.append(REDRAWN)
    if notes is not None and steps > 0 and graph.pixels >= 0:
        notes.append(PIXELS_TAKEN)
    if notes is not None and steps > 0 and p.modules_left:
        from .volumes import graftal_nodes
        if graftal_nodes(graph):
            notes.append(GRAFTAL_LEFT)
    if p.modules_left == 0:
        # The rules stay in the file and read parameters that only the old axiom assigned:
        # keep those assignments, or the file would read undefined names.
        head = _axiom_head(graph, p.d)
        if head:
            axiom = f"{{{head}}} ({axiom})"
    text = graph.source.expanded
    start, end = graph.axiom_span
    # the file's comments are copied as written: the values they tell of ("order 6
    # gives 4096 tetrahedra") may be the ones --set replaced
    given = "".join(f" --set {name}={format_value(value)}" for name, value in overrides)
    header = (f"// {one_line(graph.source.file)}{given} after {steps} derivation "
              f"step{'s' if steps != 1 else ''}"
              f"{'; its comments are as the file wrote them' if given else ''}\n")
    shown = _without_defines(text, graph.source.defines)
    before, after = _unreached_cut(text, shown, graph.source.file, p.left, (start, end))
    return (header + before + axiom + after.rstrip("\n") + "\n").replace(_GONE, "")


_GONE = "\0"      # a character no .pcsg holds (the lexer refuses it)


def _without_defines(text: str, defines: list) -> str:
    """`text` with the lines that held a #define (blank in the expanded text, which keeps
    line numbers for errors) marked _GONE, so the written file does not start with a run
    of empty lines; the same length, so statements' offsets still hold."""
    marks = list(text)
    for a, b in defines:
        first = text.rfind("\n", 0, a) + 1
        last = text.find("\n", b)
        last = len(text) if last < 0 else last + 1
        if not text[first:last].strip():
            marks[first:last] = _GONE * (last - first)
    return "".join(marks)


def _unreached_cut(text: str, shown: str, file: str, left: set[str], axiom: tuple[int, int]):
    """The file before and after its axiom, without the rules, declarations and named
    expressions the word no longer reaches from the modules it names (`left`): the
    written word's file warned that the modules it had expanded were never used, so
    `check --werror` refused it. The file's text is parsed again (the graph keeps no
    statements); the word, which may be large, is not. The pieces are cut from `shown`,
    `text` as it will be written."""
    from ..language import ast
    from ..language.parser import parse
    from ..language.preprocess import line_end
    statements = parse(text, file)[0].statements
    bodies: dict[str, list] = {}
    for st in statements:
        if isinstance(st, ast.Rule):
            bodies.setdefault(st.module, []).append(st.body)
        elif isinstance(st, ast.Named):
            bodies.setdefault(st.name, []).append(st.body)
    reached, todo = set(), set(left)
    while todo:
        name = todo.pop()
        if name not in reached:
            reached.add(name)
            for body in bodies.get(name, ()):
                todo |= _operands(body)
    cut = [st.span for st in statements if isinstance(st, (ast.Rule, ast.ModuleDecl, ast.Named))
           and (st.module if isinstance(st, ast.Rule) else st.name) not in reached]
    before, after = shown[:axiom[0]], shown[axiom[1]:]
    for a, b in sorted(cut, reverse=True):
        # the whole lines of a statement that starts its line, its comment included
        line = text.rfind("\n", 0, a) + 1
        if not text[line:a].strip():
            a = line
            b = min(line_end(text, b) + 1, len(text))   # a comment it opens included
        if b <= axiom[0]:
            before = before[:a] + before[b:]
        elif a >= axiom[1]:
            after = after[:a - axiom[1]] + after[b - axiom[1]:]
    return before, after


def _operands(e) -> set[str]:
    """The names a CSG expression reads as operands."""
    from ..language import ast
    out, stack = set(), [e]
    while stack:
        e = stack.pop()
        if isinstance(e, ast.Ref):
            out.add(e.name)
        elif isinstance(e, ast.CsgOp):
            stack += [e.left, e.right]
        elif isinstance(e, (ast.Transform, ast.Calc, ast.Paint, ast.Material)):
            stack.append(e.operand)
    return out
