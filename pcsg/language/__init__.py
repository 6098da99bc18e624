"""The PCSG language: preprocessing, parsing, positions and diagnostics."""
from .errors import Diagnostic, PcsgError
from .parser import parse, parse_file, read_source_text
from .source import Location, Source

__all__ = ["Diagnostic", "PcsgError", "Location", "Source", "parse", "parse_file", "read_source_text"]
