"""The PCSG language: preprocessing, parsing, positions and diagnostics.

The parser (and lark with it) is imported when it is first asked for: a command whose
file was parsed beside its imports (language/prefetch.py) never needs it."""
from .errors import Diagnostic, PcsgError
from .files import read_source_text
from .source import Location, Source

__all__ = ["Diagnostic", "PcsgError", "Location", "Source", "parse", "parse_file", "read_source_text"]


def __getattr__(name: str):
    if name in ("parse", "parse_file"):
        from . import parser
        return getattr(parser, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
