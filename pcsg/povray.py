"""`pcsg export --pov`: the fully expanded derivation as a POV-Ray 3.7 scene.

The scene has the camera, lights, sky and colours of `pcsg render`, so that the two
renderers can be compared on the same picture and a pcsg object can be taken into
POV-Ray. Primitives are declared once and instanced with their world matrix; flat
triangles (the terrain) go into one mesh2. The instances stream from the derivation
and are written as they come: unions need no block in POV-Ray (its bounding
hierarchy sees every object), so only ∩ and \\ subtrees are held until they close.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .graph.cut import Cut
from .graph.flatten import nonempty
from .graph.leaves import leaf_chunks, leaf_names
from .graph.model import DIFFERENCE, INTERSECTION, PRIMITIVE
from .language.names import FRACTAL_PRIMITIVES
from .output import open_atomic
from .render.camera import Camera
from .render.shade import AMBIENT, DEFAULT_COLOR, Lighting
from .scene import MATERIAL_DEFAULTS

SHAPES = {
    "sphere": "sphere { 0, 1 }",
    "cube": "box { -1, 1 }",
    "cylinder": "cylinder { 0, z, 1 }",
    "cone": "cone { 0, 1, z, 0 }",
    # {p : -v.p <= 1} for the corners v; POV-Ray's plane { n, d } is n.p <= d, n unit
    "tetrahedron": "intersection { " + " ".join(
        f"plane {{ <{-a}, {-b}, {-c}>, {1 / math.sqrt(3):.17g} }}"
        for a, b, c in ((1, 1, 1), (-1, -1, 1), (1, -1, -1), (-1, 1, -1)))
    # planes are unbounded, so POV-Ray would test every tetrahedron on every ray
    + " bounded_by { box { -1, 1 } } }",
    "plane": "plane { z, 0 }",
}
MIN_AXIS = 1e-9         # the shortest axis an exported object gets (_drawable)
# POV-Ray draws nothing of a sphere, cylinder or cone whose shortest axis is under about
# 1e-7 of its longest (a disc scale(1, 1, 1e-8) sphere: 0 pixels at 1e-7, all at 1e-6,
# whatever the size); these get at least this share of their longest axis (_drawable)
QUADRIC_RATIO = 1e-5
QUADRICS = frozenset({"sphere", "cylinder", "cone"})
LINES_AT_ONCE = 1 << 13  # lines formatted at a time: their strings and lists stay few
SKY_STEPS = 12          # colour-map entries for the sky's s**0.6 blend
# POV-Ray takes a camera within 1e-5 of its look_at as none ("Camera location and look_at
# point must be different") and draws nothing of a scene about that size: a scene framed
# from nearer than this is written scaled up (_scale_up)
NEAREST_VIEW = 1e-2


def _num(x: float) -> str:
    return f"{x:.9g}"


def _vec(v) -> str:
    return "<" + ", ".join(_num(float(x)) for x in v) + ">"


# POV-Ray's row-vector matrix: p' = p M, so the columns of our 3x4 become rows (m.T)
_MATRIX = "matrix <" + ", ".join(["%.9g"] * 12) + ">"
# A primitive that a \ subtracts grows by this much of its size, about its centre in its
# own frame, for each \ it is subtracted by: POV-Ray keeps a solid's face where a
# cutter's face lies exactly on it, and pcsg's interval lists do not (a hole through a
# cube was capped over, and `cube \ cube` drew the cube). Nested: a cutter's own cutter
# grows twice as much, past the faces it shares with it.
GROWTH = 1e-4
_CENTRE = {"cylinder": 0.5, "cone": 0.5}    # on z; the other solids' is their origin
_OBJECT = re.compile(r"object \{ P_(\w+) ")


def _grown(line: str, cuts: int) -> str:
    """A primitive's line (or a clipped volume's block) grown for `cuts` subtractions."""
    s = f"{(1 + GROWTH) ** cuts:.12g}"

    def grow(m) -> str:
        name = m.group(1)
        if name == "plane":             # the half-space z <= 0 moves out
            how = f"translate {GROWTH * cuts:.12g}*z"
        elif name in _CENTRE:
            c = _CENTRE[name]
            how = f"translate {-c}*z scale {s} translate {c}*z"
        else:
            how = f"scale {s}"
        return f"object {{ P_{name} {how} "
    return _OBJECT.sub(grow, line)


@dataclass
class _Block:
    key: tuple                  # the path prefix that names this operator instance
    kind: int
    size: int                   # operand count
    k: int                      # which operand of the block above it this one is in
    present: set = field(default_factory=set)   # its operands that drew something
    lines: list = field(default_factory=list)
    count: int = 0              # primitives among its lines


class _Textures:
    """One #declare per distinct paint and material."""

    def __init__(self, graph, lighting: Lighting):
        self.graph = graph
        self.lighting = lighting
        self.names: dict = {}
        self.declares: list[str] = []
        self._finishes: dict = {}
        self.ambient = AMBIENT * (lighting.horizon + lighting.zenith) / 2

    def of(self, paint: np.ndarray, material: np.ndarray, kept: np.ndarray) -> list:
        """The texture name of each primitive of a chunk (None where not kept), declared
        in the order they first come."""
        out = [None] * len(paint)
        rows = np.flatnonzero(kept)
        if not len(rows):
            return out
        p = paint[rows]
        none = np.isnan(p[:, 0])
        keys = np.column_stack([none, np.where(none[:, None], 0.0, p) + 0.0, material[rows]])
        firsts, ids = _distinct(keys)
        js = rows[firsts]
        found = [self.name(None if rgb[0] != rgb[0] else tuple(rgb), m)
                 for rgb, m in zip(paint[js].tolist(), material[js].tolist())]
        for j, u in zip(rows.tolist(), ids.tolist()):
            out[j] = found[u]
        return out

    def name(self, paint: tuple | None, material: int) -> str:
        """The texture of a paint (None: none) under a material (-1: none)."""
        key = (paint, material)
        found = self.names.get(key)
        if found is None:
            found = self.names[key] = f"T{len(self.names)}"
            self.declares.append(f"#declare {found} = {self._texture(paint, material)}")
        return found

    def _texture(self, paint, material: int) -> str:
        fin = self._finishes.get(material)
        if fin is None:
            fin = self._finishes[material] = self._finish(material)
        color, transmit, finish = fin
        if paint is not None:
            color = [max(c, 0.0) for c in paint]
        pigment = ("rgbt <%.9g, %.9g, %.9g, " % tuple(color) + transmit + ">"
                   if transmit else "rgb <%.9g, %.9g, %.9g>" % tuple(color))
        return f"texture {{ pigment {{ {pigment} }} {finish} }}"

    def _finish(self, material: int) -> tuple:
        """A material's colour, its transmit as text ('' for none) and its finish."""
        fin = dict(MATERIAL_DEFAULTS)
        color = DEFAULT_COLOR
        if material >= 0:
            fin = self.graph.scene.materials[self.graph.material_names[material]]
            color = fin["color"]
        if self.lighting.max_bounces == 0:
            # pcsg traces no bounce and keeps the whole of its own colour; POV-Ray's
            # surface kept 1 - reflect - transmit of it and was dark where it reflects
            fin = {**fin, "reflect": 0.0, "transmit": 0.0}
        reflection = f"reflection {_num(fin['reflect'])}"
        if fin["transmit"] > 0:
            # what pcsg reflects: reflect + transmit F, F by Fresnel's equations at the
            # interior's ior; conserve_energy lets through what is not reflected
            most = _num(min(fin["reflect"] + fin["transmit"], 1.0))
            reflection = (f"reflection {{ {_num(fin['reflect'])}, {most} fresnel on }} "
                          "conserve_energy")
        # pcsg's surface keeps 1 - reflect - transmit of its own colour (shade._bounces);
        # POV-Ray adds reflection on top of the whole finish, and scales a transmitting
        # pigment's ambient and diffuse light by 1 - transmit itself, but not its phong
        # highlight (QA: a glass ball's highlight 255 where pcsg's is 161)
        t = fin["transmit"]
        kept = max(1.0 - fin["reflect"] - t, 0.0)
        own = kept / (1.0 - t) if t < 1 else 0.0
        return ([float(c) for c in color], _num(t) if t > 0 else "",
                f"finish {{ ambient rgb {_vec(self.ambient * own)} "
                f"diffuse {_num(fin['diffuse'] * own)} phong {_num(fin['specular'] * kept)} "
                f"phong_size {_num(fin['shininess'])} {reflection} }}")

    def interior(self, material: int) -> str:
        if material < 0:
            return ""
        ior = self.graph.scene.materials[self.graph.material_names[material]]["ior"]
        return f" interior {{ ior {_num(ior)} }}" if ior != 1.0 else ""


class _Mesh:
    """Flat triangles collected into one mesh2 with shared vertices."""

    def __init__(self):
        self.corners: list[np.ndarray] = []     # chunks of (k, 3, 3), rounded
        self.textures: dict[str, int] = {}      # texture_list, as the faces first name them
        self.face_textures: list[np.ndarray] = []
        self.faces = 0

    def add(self, world: np.ndarray, sign: np.ndarray, textures: list[str]):
        """Triangles of world maps (k, 3, 4) of the unit triangle (0,0), (s,0), (0,s)
        with s = sign (tri1: 1, tri2: -1)."""
        t, s = world[:, :, 3], sign[:, None]
        corners = np.stack([t, t + s * world[:, :, 0], t + s * world[:, :, 1]], axis=1)
        # neighbours compute a shared corner in different frames: a few ulps apart
        self.corners.append(_significant(corners, 11))
        self.faces += len(world)
        ids = self.textures
        self.face_textures.append(np.array([ids.setdefault(name, len(ids))
                                            for name in textures], dtype=np.int64))

    def write(self, out):
        if not self.faces:
            return
        corners = np.concatenate(self.corners).reshape(-1, 3)
        self.corners = []
        firsts, ids = _distinct(corners)
        vertices = corners[firsts]
        del corners
        faces = np.column_stack([ids.reshape(-1, 3), np.concatenate(self.face_textures)])
        out.write("mesh2 {\n  vertex_vectors { %d,\n" % len(vertices))
        _write_rows(out, "    <%.9g, %.9g, %.9g>\n", vertices)
        out.write("  }\n  texture_list { %d,\n" % len(self.textures))
        for name in self.textures:
            out.write(f"    texture {{ {name} }}\n")
        out.write("  }\n  face_indices { %d,\n" % len(faces))
        _write_rows(out, "    <%d, %d, %d>, %d\n", faces)
        out.write("  }\n}\n")


def _write_rows(out, line: str, rows: np.ndarray):
    """Each row of `rows` as `line` % row, LINES_AT_ONCE at a time."""
    for b in range(0, len(rows), LINES_AT_ONCE):
        out.write("".join([line % tuple(r) for r in rows[b:b + LINES_AT_ONCE].tolist()]))


def _drawable(world: np.ndarray, quadric: np.ndarray) -> np.ndarray:
    """World maps (k, 3, 4) with every axis shorter than MIN_AXIS lengthened to it (the
    singular values of their linear part), and where `quadric` (k,) says so, shorter than
    QUADRIC_RATIO of the longest: POV-Ray draws an object thinner than about 1e-10 in
    some direction as a large flat face, where pcsg draws a speck (the fern's stem of a
    stem ... at depth 8 is 1e-12 thick), and a flat sphere, cylinder or cone not at all,
    where pcsg draws a disc. Either is still far below any pixel."""
    a = world[:, :, :3]
    with np.errstate(all="ignore"):
        # the least singular value is at least 2 |det| / |a|^2 (Frobenius), and the
        # largest at most |a|: a test that spares the decomposition of nearly every map
        # (0.16 s for 65 536, the test 5 ms)
        det2 = 2 * np.abs(np.einsum("ki,ki->k", a[:, :, 0], np.cross(a[:, :, 1], a[:, :, 2])))
        norm2 = np.einsum("kij,kij->k", a, a)
        sure = (det2 >= MIN_AXIS * norm2) & ~(quadric & ~(det2 >= QUADRIC_RATIO * norm2 ** 1.5))
        maybe = np.flatnonzero(~sure)
        if not len(maybe):
            return world
        u, sv, vt = np.linalg.svd(a[maybe])
    floor = np.where(quadric[maybe], np.maximum(QUADRIC_RATIO * sv[:, 0], MIN_AXIS), MIN_AXIS)
    thin = ((sv > 0.0) & (sv < floor[:, None])).any(axis=1)
    if not thin.any():
        return world
    out = world.copy()
    s = np.where(sv[thin] > 0.0, np.maximum(sv[thin], floor[thin, None]), 0.0)
    out[maybe[thin], :, :3] = (u[thin] * s[:, None, :]) @ vt[thin]
    return out


def _distinct(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distinct rows of keys (n, m), numbered in the order they first come: where each
    first comes, and each row's number. By a stable sort of the rows and a column at a
    time: np.unique(axis=0) took twice the time and the memory of the terrain's million
    and a half corners."""
    order = np.lexsort(keys.T[::-1])
    new = np.zeros(len(keys), dtype=bool)
    new[0] = True
    for c in range(keys.shape[1]):
        col = keys[order, c]
        new[1:] |= col[1:] != col[:-1]
    group = np.cumsum(new) - 1
    firsts = order[new]             # stable: a group's first row is where it first comes
    number = np.empty(len(firsts), dtype=np.int64)
    number[np.argsort(firsts, kind="stable")] = np.arange(len(firsts))
    ids = np.empty(len(keys), dtype=np.int64)
    ids[order] = number[group]
    return np.sort(firsts), ids


def _significant(x: np.ndarray, digits: int) -> np.ndarray:
    """x rounded to `digits` significant decimal digits (0 stays 0, and numbers too
    small for the scale to be a float, below 1e-298, stay as they are)."""
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        e = np.floor(np.log10(np.abs(x)))
        e[~np.isfinite(e)] = 0
        scale = 10.0 ** (digits - 1 - e)
        rounded = np.round(x * scale) / scale
    return np.where(np.isfinite(rounded), rounded, x) + 0.0   # + 0.0: -0 and 0 are one


def _refuse_fractals(graph):
    """POV-Ray has no Mandelbulb, and its julia_fractal is a different slice and
    iteration: an export that drew something else would mislead."""
    from .graph.checks import reachable
    from .language.errors import Diagnostic, PcsgError
    live = reachable(graph)
    for i, n in enumerate(graph.nodes):
        if live[i] and n.kind == PRIMITIVE and n.name in FRACTAL_PRIMITIVES:
            raise PcsgError([Diagnostic(
                "error", f"'{n.name}' cannot be exported: POV-Ray has no primitive that "
                         f"draws the same set", n.span, graph.source, code="export")])


def export_pov(traced, camera: Camera, lighting: Lighting, path: Path,
               size: tuple[int, int], progress=None, compiled: bool = True,
               cut: Cut | None = None) -> tuple[int, int, int]:
    """Write the scene to `path` (atomically); returns the number of primitives written,
    of those left out because they are empty (a singular or non-finite transform, a
    runtime error in the grammar, draws nothing in pcsg, and POV-Ray could not parse a
    matrix of NaNs), and of those dropped with the ∩ or \\ they belonged to: leaving an
    operand out empties an intersection as pcsg's tracer does. progress(n), if given, is
    called after each chunk of the derivation (graph/leaves.py) with how many have come.
    compiled=False: the Python derivation's primitives (leaf_chunks). With a cut
    (graph/cut.py), the derivation ends where the tracer's does at that depth bound."""
    graph = traced.graph
    _refuse_fractals(graph)
    k = _scale_up(camera)
    textures = _Textures(graph, lighting)
    mesh = _Mesh()
    empty = done = 0
    names = leaf_names(graph)
    # the flat triangles' unit triangle (0,0), (s,0), (0,s): their s, 0 for the others
    triangle = np.array([{"tri1": 1, "tri2": -1}.get(name, 0) for name in names])
    # straight into the output (its temporary file beside it, open_atomic): a texture is
    # declared where it is first needed, between the top-level objects; the blocks
    # held in memory (∩, \\ and the mesh) are written after their declarations
    with open_atomic(path, "w") as out:
        out.write(_header(camera, lighting, size, graph, k))
        for name, shape in SHAPES.items():
            out.write(f"#declare P_{name} = {shape}\n")
        body = _BodyWriter(graph, out)
        declared = 0
        for leaves in leaf_chunks(graph, compiled, cut):
            kept = nonempty(leaves.world)
            empty += len(leaves) - int(kept.sum())
            tex = textures.of(leaves.paint, leaves.material, kept)
            for line in textures.declares[declared:]:
                out.write(line + "\n")
            declared = len(textures.declares)
            sign = triangle[leaves.node]
            flat = kept & (sign != 0)
            mesh.add(k * leaves.world[flat], sign[flat],
                     [tex[j] for j in np.flatnonzero(flat)])
            rows = np.flatnonzero(kept & (sign == 0))
            # a block of lines at a time: their strings and lists stay few. A chunk with
            # none leaves the blocks open: the next chunk's primitives may be in them
            for b in range(0, len(rows), LINES_AT_ONCE):
                part = rows[b:b + LINES_AT_ONCE]
                lines = _objects(leaves, part, tex, names, textures, k)
                if leaves.paths is not None:
                    for j, line in zip(part.tolist(), lines):
                        body.add(body.path_blocks(leaves.paths[j]), line)
                elif not leaves.csg[part].any():    # no block to hold a line back
                    body.add_all(lines)
                else:
                    for j, line in zip(part.tolist(), lines):
                        body.add_chain(leaves.chain[j, :leaves.csg[j]], line)
            done += len(leaves)
            if progress is not None:
                progress(done)
        body.close()
        mesh.write(out)
    return body.written + mesh.faces, empty, body.dropped


def _objects(leaves, rows: np.ndarray, tex: list, names: list, textures,
             k: float = 1.0) -> list[str]:
    """The object lines of the primitives `rows` of a chunk, their maps scaled by k; a
    cut graftal instance's volume as an intersection with the volumes that clip it."""
    nodes = leaves.node[rows]
    quadric = np.array([name in QUADRICS for name in names], dtype=bool)[nodes]
    maps = _drawable(k * leaves.world[rows], quadric).transpose(0, 2, 1).reshape(-1, 12).tolist()
    lines = [f"object {{ P_{names[n]} {_MATRIX % tuple(m)} texture {{ {tex[j]} }}"
             f"{textures.interior(mat)} }}"
             for j, n, m, mat in zip(rows.tolist(), nodes.tolist(), maps,
                                     leaves.material[rows].tolist())]
    clipped = [] if leaves.clips is None else [
        (i, j) for i, j in enumerate(rows.tolist()) if leaves.clips[j]]
    if clipped:
        volumes = [v for _, j in clipped for v in leaves.clips[j]]
        maps = iter(_drawable(k * np.array([m[:3] for _, m in volumes]),
                              np.array([name in QUADRICS for name, _ in volumes], dtype=bool))
                    .transpose(0, 2, 1).reshape(-1, 12).tolist())
        for i, j in clipped:
            lines[i] = "intersection { " + " ".join(
                [lines[i]] + [f"object {{ P_{name} {_MATRIX % tuple(next(maps))} "
                              f"texture {{ {tex[j]} }} }}" for name, _ in leaves.clips[j]]
            ) + " }"
    return lines


class _BodyWriter:
    """Objects in derivation order; ∩ and \\ subtrees (and unions inside them) are
    held until they close, then written as one block, or dropped when an operand
    that decides the result is empty."""

    def __init__(self, graph, out):
        self.graph = graph
        self.out = out
        self.open: list[_Block] = []
        self.written = 0            # primitives in the output
        self.dropped = 0            # primitives of ∩ and \\ blocks that came out empty
        # for add_chain: the open blocks' ids, and each node's kind and operand count
        self._ids = np.empty(64, dtype=np.int64)
        self._kinds = np.array([n.kind for n in graph.nodes], dtype=np.int64)
        self._sizes = [len(n.children) for n in graph.nodes]

    def path_blocks(self, path) -> list:
        """The blocks above a primitive from its Instance.path: (key: the path down to the
        operator, kind, operands, k) from the first ∩ or \\ down."""
        needed = []
        inside = False
        for j, (node, k) in enumerate(path):
            g = self.graph.nodes[node]
            inside = inside or g.kind in (INTERSECTION, DIFFERENCE)
            if inside:
                needed.append((path[:j], g.kind, len(g.children), k))
        return needed

    def chain_blocks(self, chain: np.ndarray) -> list:
        """The same from a chain of the compiled walk (trace/leafwalk.py), keyed by the
        operator instance's id."""
        nodes = self.graph.nodes
        return [(op, nodes[node].kind, len(nodes[node].children), k)
                for op, node, k in chain.tolist()]

    def add(self, needed: list, line: str):
        """A primitive's line under the blocks `needed` (path_blocks, chain_blocks)."""
        common = 0
        while (common < min(len(self.open), len(needed))
               and self.open[common].key == needed[common][0]):
            common += 1
        blocks = [(*needed[i][:3], needed[i - 1][3] if i else -1)
                  for i in range(common, len(needed))]
        cuts = sum(kind == DIFFERENCE and k > 0 for _, kind, _, k in needed)
        self._enter(common, blocks, needed[-1][3] if needed else -1, cuts, line)

    def add_chain(self, chain: np.ndarray, line: str):
        """add(chain_blocks(chain), line), the chain compared as an array: a primitive
        under thousands of nested blocks took as many Python steps (6,001 primitives
        3,000 blocks deep: 13.6 s)."""
        n = min(len(self.open), len(chain))
        differ = np.flatnonzero(self._ids[:n] != chain[:n, 0])
        common = int(differ[0]) if len(differ) else n
        cuts = int(np.count_nonzero((self._kinds[chain[:, 1]] == DIFFERENCE) & (chain[:, 2] > 0)))
        above = int(chain[common - 1, 2]) if common else -1   # the operand of the last kept
        blocks = []
        for op, node, k in chain[common:].tolist():
            blocks.append((op, int(self._kinds[node]), self._sizes[node], above))
            above = k
        self._enter(common, blocks, int(chain[-1, 2]) if len(chain) else -1, cuts, line)

    def _enter(self, common: int, blocks: list, k: int, cuts: int, line: str):
        """The line into the innermost of the `common` open blocks that hold it and the
        new `blocks` below them, (key, kind, operand count, operand of the one above)
        each; k: its operand of the innermost; cuts: the differences it is subtracted by."""
        while len(self.open) > common:
            self._close()
        for key, kind, size, above in blocks:
            if isinstance(key, int):
                if len(self.open) == len(self._ids):
                    self._ids = np.concatenate([self._ids, np.empty_like(self._ids)])
                self._ids[len(self.open)] = key
            self.open.append(_Block(key, kind, size, above))
        if self.open:
            # the operand of the innermost block; those above learn of it when it closes
            # with something in it (a ∩ inside a ∩ that came out empty empties its operand)
            self.open[-1].present.add(k)
        self._emit(_grown(line, cuts) if cuts else line, 1)

    def add_all(self, lines: list[str]):
        """Lines with no ∩ or \\ above them."""
        self.close()
        if lines:
            self.out.write("\n".join(lines) + "\n")
            self.written += len(lines)

    def _emit(self, line: str, count: int):
        if self.open:
            self.open[-1].lines.append(line)
            self.open[-1].count += count
        else:
            self.out.write(line + "\n")
            self.written += count

    def _close(self):
        b = self.open.pop()
        if ((b.kind == DIFFERENCE and 0 not in b.present)        # nothing to subtract from
                or (b.kind == INTERSECTION and len(b.present) < b.size)  # an empty operand
                or not b.lines):
            self.dropped += b.count
            return
        if self.open:
            self.open[-1].present.add(b.k)
        # a difference with nothing to subtract is its first operand, and one object needs
        # no block (POV-Ray warns of a CSG block of one object)
        word = {INTERSECTION: "intersection", DIFFERENCE: "difference"}.get(
            b.kind if len(b.present) > 1 else None, "union")
        if len(b.lines) == 1 and word == "union":
            self._emit(b.lines[0], b.count)
            return
        # where operands of a ∩ share a face, POV-Ray shows the last one's texture there
        # and pcsg the first's: written last first (each line is an operand; the order of
        # an intersection's operands changes nothing else)
        lines = b.lines[::-1] if word == "intersection" else b.lines
        self._emit(f"{word} {{\n" + "\n".join(lines) + "\n}", b.count)

    def close(self):
        while self.open:
            self._close()


def _scale_up(camera: Camera) -> float:
    """The factor, a power of two (exact), that a scene framed from nearer than
    NEAREST_VIEW is written scaled by about the origin, its objects, camera and lights
    alike: the same picture. `uscale(1e-6) sphere` gave a scene POV-Ray refused to parse,
    and at 1e-5 one it drew empty. 1 for any other."""
    d = float(np.linalg.norm(np.subtract(camera.eye, camera.at)))
    if not 0.0 < d < NEAREST_VIEW:
        return 1.0
    return 2.0 ** math.ceil(math.log2(1.0 / d))


def _header(camera: Camera, lighting: Lighting, size, graph, scale: float = 1.0) -> str:
    """The scene's settings, camera, lights and sky, its lengths scaled by `scale` (_scale_up)."""
    w, h = size
    aspect = w / h
    hfov = math.degrees(2 * math.atan(aspect * math.tan(math.radians(camera.fov) / 2)))
    lines = [
        # a line break in the file's name ended the comment: POV-Ray read the rest as code
        f"// {Path(graph.source.file).name.encode('unicode_escape').decode('ascii')}: "
        f"exported by pcsg (pcsg export --pov)",
        f"// render: povray +I{{this file}} +W{w} +H{h}",
        "#version 3.7;",
        f"global_settings {{ assumed_gamma 1.0 max_trace_level {lighting.max_bounces + 1} }}",
        # right-handed like pcsg: a negative right vector mirrors POV-Ray's left-handed frame
        f"camera {{ perspective location {_vec(scale * np.asarray(camera.eye))} sky "
        f"{_vec(camera.up)} up y right -x*{_num(aspect)} angle {_num(hfov)} look_at "
        f"{_vec(scale * np.asarray(camera.at))} }}",
    ]
    for lt in lighting.lights:
        area = ""
        if lt.radius > 0 and lighting.shadow_samples > 1:
            s = 2 * lt.radius * scale
            # about as many rays as --shadow-samples: an n x n grid, n at least 2 (it
            # was 3 x 3 whatever the option)
            n = max(2, round(math.sqrt(lighting.shadow_samples)))
            area = f" area_light <{_num(s)}, 0, 0>, <0, {_num(s)}, 0>, {n}, {n} circular orient"
        shadows = "" if lighting.shadows else " shadowless"
        lines.append(f"light_source {{ {_vec(scale * np.asarray(lt.position))} color rgb "
                     f"{_vec(lt.color)}{area}"
                     f"{shadows} }}")
    entries = [f"[0 rgb {_vec(lighting.horizon)}]", f"[0.5 rgb {_vec(lighting.horizon)}]"]
    for k in range(1, SKY_STEPS + 1):
        z = k / SKY_STEPS
        s = z ** 0.6
        color = lighting.horizon * (1 - s) + lighting.zenith * s
        entries.append(f"[{_num(0.5 + z / 2)} rgb {_vec(color)}]")
    # gradient z scaled by 2 and moved down: the pattern is (z + 1) / 2 on the unit sphere
    lines.append("sky_sphere { pigment { gradient z color_map { " + " ".join(entries)
                 + " } scale 2 translate -z } }")
    return "\n".join(lines) + "\n"
