"""pcsg: PCSG grammars compiled to cyclic CSG graphs, traced with numba.

    import pcsg
    obj = pcsg.load("grammars/sierpinski.pcsg", c=10)
    hits = obj.trace(origins, directions)      # (N, 3) arrays in
    hits.t, hits.normal, hits.material, hits.hit
"""
from .language.errors import PcsgError
from .tracer import Hits, Traced, load, loads

__all__ = ["PcsgError", "Hits", "Traced", "load", "loads"]
__version__ = "0.1.0"
