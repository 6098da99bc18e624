"""pcsg: PCSG grammars compiled to cyclic CSG graphs, traced with numba.

    import pcsg
    obj = pcsg.load("grammars/sierpinski.pcsg", c=10)
    hits = obj.trace(origins, directions)      # (N, 3) arrays in
    hits.t, hits.normal, hits.material, hits.hit
"""
__all__ = ["PcsgError", "Hits", "Traced", "load", "loads"]
__version__ = "0.1.0"

_HOMES = {"PcsgError": "language.errors", "Hits": "tracer", "Traced": "tracer",
          "load": "tracer", "loads": "tracer"}


def __getattr__(name):
    """The public names, imported when first used (PEP 562): `import pcsg.cli` must not
    import numba, so that the command can import it with the collector off
    (cli.import_kernels)."""
    if name not in _HOMES:
        raise AttributeError(f"module 'pcsg' has no attribute '{name}'")
    from importlib import import_module
    value = getattr(import_module(f".{_HOMES[name]}", __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))
