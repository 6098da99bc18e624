"""Flat.holds: the rules whose boxes hold their S-node's, after which the walks test no
box (a ray's window is inside the S-node's box already). Packets and single rays
follow the same flag (tests/test_packets.py), and the reference holds the walk to
the expansion (tests/test_reference.py); here, which rules get it."""
import numpy as np

import pcsg

from .conftest import GRAMMARS
from .test_spheres import OCTA


def rules(obj, module):
    f, s = obj.flat, obj.graph.modules[module]
    entries = range(f.child_start[s], f.child_start[s] + f.child_count[s])
    return [(f.box[f.children[e]], f.holds[e]) for e in entries], f.box[s]


def test_a_subdivision_whose_box_is_its_modules_is_not_tested_again():
    obj = pcsg.load(GRAMMARS / "carpenter_terrain.pcsg", cnt=4)
    ((leaf, leaf_holds), (split, split_holds)), box = rules(obj, "T1")
    # the four sub-triangles cover the patch and all its heights: the union's box is T1's
    assert np.array_equal(split, box) and split_holds == 1
    # so do the final triangles, bounded by their corners: the terrain's highest and
    # lowest points are corners of final triangles of both types (bounded by the images
    # of their object boxes, T1's own final triangles stayed under the height that those
    # of T2 in its subdivision reached, and this rule was tested)
    assert np.array_equal(leaf, box) and leaf_holds == 1


def test_a_smaller_rule_box_is_tested():
    obj = pcsg.loads("{ n = 3 } S\nS if(n > 0, 2, 1)\n1: S → sphere\n"
                     "2: S → { n = n - 1 } (cube ∪ move(3, 0, 0) S)\n")
    ((small, small_holds), (whole, whole_holds)), box = rules(obj, "S")
    assert small_holds == 0 and small[3] < box[3]
    assert whole_holds == 1
    # entries that are not an S-node's rules never hold
    f = obj.flat
    others = np.ones(len(f.children), dtype=bool)
    for s in np.flatnonzero(f.kind == f.kind[obj.graph.modules["S"]]):
        others[f.child_start[s]:f.child_start[s] + f.child_count[s]] = False
    assert not f.holds[others].any()


def test_no_rule_of_a_module_bounded_by_a_sphere_holds():
    obj = pcsg.loads(OCTA)
    f = obj.flat
    s = obj.graph.modules["O"]
    assert f.sphere[s, 3] >= 0.0        # its sphere won (README, "Level of detail")
    assert not f.holds[f.child_start[s]:f.child_start[s] + f.child_count[s]].any()
