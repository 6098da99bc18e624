"""The front end in one call: text -> checked cyclic CSG graph."""
from __future__ import annotations

from collections import Counter
from pathlib import Path

from .collector import collector_paused
from .graph.build import build_graph
from .graph.checks import run_checks
from .graph.model import Graph
from .language import prefetch
from .language.errors import Diagnostic, PcsgError
from .language.files import check_text_size, read_source_text
from .language.source import Source
from .recursion import SYNTAX_DEPTH, on_deep_stack, recursion_limit


def compile_text(text: str, file: str = "<string>", overrides: dict[str, float] | None = None
                 ) -> Graph:
    """Parse, build and check; raises PcsgError. Warnings are in graph.warnings."""
    return on_deep_stack(_compile, text, file, overrides)


def _compile(text: str, file: str, overrides: dict[str, float] | None) -> Graph:
    check_text_size(text, file)
    source = None
    try:
        with recursion_limit(SYNTAX_DEPTH), collector_paused():
            parsed = prefetch.take(file, text)
            if parsed is None:
                from .language.parser import parse      # lark: only where it parses here
                parsed = parse(text, file)
            program, source = parsed
            graph = build_graph(program, source, overrides)
            run_checks(graph)
            return graph
    except RecursionError as e:
        # a flat sum nests too: 1+1+...+1 is ((1+1)+1)+..., and 20 000 terms compile
        raise PcsgError([Diagnostic(
            "error", "an expression is nested too deeply to compile (a chain of tens of "
                     "thousands of operators, or brackets as deep): split it, with named "
                     "expressions or parameters for its parts",
            None if source is None else _recursed_in(e), source or Source(file, text),
            code="nesting")]) from None


def _recursed_in(error: RecursionError) -> tuple[int, int] | None:
    """The span of the syntax tree node that the outermost call of the function that
    recursed was given (the most frequent in the traceback), if it was given one: the
    error had no line and column. None where it recursed in the parse, before a tree."""
    frames = []
    tb = error.__traceback__
    while tb is not None:
        frames.append(tb.tb_frame)
        tb = tb.tb_next
    if not frames:
        return None
    recursed = Counter(f.f_code for f in frames).most_common(1)[0][0]
    outermost = next(f for f in frames if f.f_code is recursed)
    for value in outermost.f_locals.values():
        span = getattr(value, "span", None)
        if isinstance(span, tuple) and len(span) == 2 and all(isinstance(x, int) for x in span):
            return span
    return None


def compile_file(path: str | Path, overrides: dict[str, float] | None = None) -> Graph:
    return compile_text(read_source_text(path), str(path), overrides)
