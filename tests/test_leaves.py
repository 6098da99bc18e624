"""The compiled leaf walk (trace/leafwalk.py) against the Python derivation
(flatten.instances): the same primitives, in the same order, with the same world maps,
paints and materials, and the same errors where the derivation fails."""
import numpy as np
import pytest

from pcsg.compiler import compile_file, compile_text
from pcsg.graph import leaves as leaves_module
from pcsg.graph.flatten import leaf_inverse, nonempty
from pcsg.graph.leaves import leaf_chunks
from pcsg.language.errors import PcsgError
from pcsg.povray import _BodyWriter
from pcsg.trace import leafwalk

from .conftest import GRAMMARS

CSG = GRAMMARS.parent / "tests" / "data" / "csg_export.pcsg"

# every sample at an order whose Python derivation takes well under a second; the
# fractals' primitives are left to the tracer (the export refuses them) but their
# derivation is a derivation all the same
SMALL = {"sierpinski": {"c": 3}, "sympodial_tree": {"cnt": 5}, "carpenter_terrain": {"cnt": 3},
         "growing_tree": {}, "pixel_forest": {}, "table_tower": {},
         "menger_sponge": {}, "glass_and_mirror": {}, "fractal_garden": {}}


def joined(graph, compiled):
    chunks = list(leaf_chunks(graph, compiled))
    names = [graph.nodes[i].name for c in chunks for i in c.node]
    return (names, np.concatenate([c.world for c in chunks]),
            np.concatenate([c.paint for c in chunks]),
            np.concatenate([c.material for c in chunks]), blocks(graph, chunks))


def blocks(graph, chunks):
    """Each primitive's ∩ and \\ blocks as the export reads them, the operator instances
    numbered as they first come (a path prefix keys them in Python, an id compiled)."""
    body = _BodyWriter(graph, None)
    seen = {}
    out = []
    for c in chunks:
        for j in range(len(c)):
            needed = (body.path_blocks(c.paths[j]) if c.paths is not None
                      else body.chain_blocks(c.chain[j, :c.csg[j]]))
            out.append([(seen.setdefault(key, len(seen)), kind, size, k)
                        for key, kind, size, k in needed])
    return out


def assert_same_leaves(graph):
    names, world, paint, material, csg = joined(graph, True)
    names_py, world_py, paint_py, material_py, csg_py = joined(graph, False)
    assert names == names_py and len(names) > 0
    assert csg == csg_py
    # the maps compose in another order of the same products: ulps apart at most
    np.testing.assert_allclose(world, world_py, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(np.isnan(world), np.isnan(world_py))
    np.testing.assert_array_equal(paint, paint_py)
    np.testing.assert_array_equal(material, material_py)


@pytest.mark.parametrize("name", SMALL)
def test_the_compiled_walk_gives_the_python_derivations_primitives(name):
    assert_same_leaves(compile_file(GRAMMARS / f"{name}.pcsg", SMALL[name]))


@pytest.mark.parametrize("path, overrides", [(GRAMMARS / "sympodial_tree.pcsg", {"cnt": 4}),
                                             (CSG, {"n": 4})])
def test_it_goes_on_across_chunks_and_grows_its_stack_and_chains(monkeypatch, path,
                                                                 overrides):
    """Chunks of 7 primitives and a stack of one row to start with: the walk stops and
    goes on again and again, grows its rows, and its chains (four operators long at
    first; the CSG file at 4 nests ten), with the same result."""
    monkeypatch.setattr(leaves_module, "CHUNK", 7)
    real = leafwalk.Walker.__init__
    monkeypatch.setattr(leafwalk.Walker, "__init__",
                        lambda self, flat, levels, cut=None, rows=1: real(self, flat, levels,
                                                                          cut, rows))
    grown = []
    for name in ("grow", "grow_chain"):
        method = getattr(leafwalk.Walker, name)
        monkeypatch.setattr(leafwalk.Walker, name,
                            lambda self, m=method, n=name: grown.append(n) or m(self))
    graph = compile_file(path, overrides)
    chunks = list(leaf_chunks(graph, True))
    sizes = [len(c) for c in chunks]
    assert len(sizes) > 8 and max(sizes) == 7
    assert grown.count("grow") >= 3
    assert grown.count("grow_chain") == (2 if path == CSG else 0)
    assert max(c.csg.max() for c in chunks) == (10 if path == CSG else 3)
    assert_same_leaves(graph)


def test_paints_materials_and_empty_instances_come_as_in_python():
    """A paint and a material above some primitives only, a rand() in a map, a map
    that makes an instance empty (scale 0), and non-finite paint (an empty instance)."""
    graph = compile_text("""
#material gold color=(1, 0.8, 0.2) reflect=0.5
{n = 3} S
S if(n > 0, 2, 1)
1: S → sphere
2: S → paint(n/3, 0.5, rand()) move(rand(), 0, 0) {n = n - 1} S ∪ material(gold) uscale(n - 1) cube ∪
   paint(0/0, 0, 0) sphere
""")
    assert_same_leaves(graph)
    _, world, paint, material, _ = joined(graph, True)
    assert not nonempty(world).all() and nonempty(world).any()
    assert np.isnan(paint[:, 0]).any() and not np.isnan(paint[:, 0]).all()
    assert set(material.tolist()) == {-1, 0}


@pytest.mark.parametrize("text", [
    "{c = 3} S\nS c\n1: S → sphere\n2: S → cube",
    # an invalid selection at the last instance, after 4095 primitives
    "{n = 12; k = 0} S\nS if(n > 0, 2, if(k == 4095, 3, 1))\n1: S → sphere\n"
    "2: S → move(1, 0, 0) {n = n - 1; k = 2*k} S ∪ move(0, 1, 0) {n = n - 1; k = 2*k + 1} S",
    "{n = 0} S\nS 2 - (n > 1e300)\n1: S → sphere\n2: S → {n = n + 1} S",
])
def test_a_derivation_that_fails_raises_what_the_python_one_raises(text):
    graph = compile_text(text)
    errors = []
    for compiled in (True, False):
        with pytest.raises(PcsgError) as e:
            list(leaf_chunks(graph, compiled))
        errors.append(e.value.diagnostics[0])
    assert errors[0].message == errors[1].message, errors[0].message
    assert errors[0].span == errors[1].span and errors[0].span is not None
    assert errors[0].message.startswith(("the selection of module 'S' gives ",
                                         "the derivation is deeper than 10000 levels at 'S'"))


def test_nonempty_is_leaf_inverse_for_a_stack_of_maps():
    rng = np.random.default_rng(5)
    maps = rng.normal(size=(200, 3, 4))
    maps[::7, 2] = 0.0                          # singular
    maps[3::11, 0, 1] = np.nan                  # not finite
    maps[5::13, 1, 3] = np.inf
    maps[6::17, :, :3] *= 1e-110                # a determinant that underflows to 0
    maps[8::19, :, :3] *= 1e120                 # one that overflows
    full = np.zeros((200, 4, 4))
    full[:, :3], full[:, 3, 3] = maps, 1.0
    with np.errstate(all="ignore"):
        expected = [leaf_inverse(m) is not None for m in full]
    assert 0 < sum(expected) < 200
    assert nonempty(maps).tolist() == expected


DEEP = """{c = 300} S
S if(c > 0, 2, 1)
1: S → sphere
2: S → {c = c-1} (uscale(3) cube ∩ (sphere ∪ move(0.3,0,0) uscale(0.999) S))
"""


def test_a_deep_nest_of_blocks_takes_memory_by_its_depth_not_its_square():
    """Blocks nested 2,000 deep: each entry held its whole chain, and each chunk 65,536
    chains as long as the deepest (3 GiB asked at 2,000; at an endless nest, 24 GiB and an
    internal MemoryError). The chains come as Python's, at 300 deep."""
    import tracemalloc
    assert_same_leaves(compile_text(DEEP))
    graph = compile_text(DEEP, overrides={"c": 2000})
    tracemalloc.start()
    try:
        count = depth = 0
        for c in leaf_chunks(graph, True):
            count += len(c)
            depth = max(depth, int(c.csg.max()))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert count == 4001 and depth == 4000
    assert peak < 100 << 20, peak            # the chunk's chains 32 MB, the walk's rows a few
