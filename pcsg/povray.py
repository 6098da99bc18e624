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
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .graph.flatten import instances, leaf_inverse
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
TRIANGLES = {"tri1": ((0, 0, 0), (1, 0, 0), (0, 1, 0)),
             "tri2": ((0, 0, 0), (-1, 0, 0), (0, -1, 0))}
SKY_STEPS = 12          # colour-map entries for the sky's s**0.6 blend
PROGRESS_EVERY = 1024    # primitives between progress calls: 0.1 s of the terrain's


def _num(x: float) -> str:
    return f"{x:.9g}"


def _vec(v) -> str:
    return "<" + ", ".join(_num(float(x)) for x in v) + ">"


def _matrix(m: np.ndarray) -> str:
    """POV-Ray's row-vector matrix: p' = p M, so the columns of our 3x4 become rows."""
    return "matrix <" + ", ".join(_num(float(m[r, c])) for c in range(4) for r in range(3)) + ">"


@dataclass
class _Block:
    key: tuple                  # the path prefix that names this operator instance
    kind: int
    size: int                   # operand count
    present: set = field(default_factory=set)
    lines: list = field(default_factory=list)
    count: int = 0              # primitives among its lines


class _Textures:
    """One #declare per distinct paint and material."""

    def __init__(self, graph, lighting: Lighting):
        self.graph = graph
        self.lighting = lighting
        self.names: dict = {}
        self.declares: list[str] = []
        self.ambient = AMBIENT * (lighting.horizon + lighting.zenith) / 2

    def name(self, paint, material) -> str:
        key = (paint, material)
        found = self.names.get(key)
        if found is None:
            found = self.names[key] = f"T{len(self.names)}"
            self.declares.append(f"#declare {found} = {self._texture(paint, material)}")
        return found

    def _texture(self, paint, material) -> str:
        fin = dict(MATERIAL_DEFAULTS)
        color = DEFAULT_COLOR
        if material is not None:
            fin = self.graph.scene.materials[material]
            color = fin["color"]
        if paint is not None:
            color = np.clip(paint, 0.0, None)
        pigment = (f"rgbt <{', '.join(_num(c) for c in color)}, {_num(fin['transmit'])}>"
                   if fin["transmit"] > 0 else f"rgb {_vec(color)}")
        return (f"texture {{ pigment {{ {pigment} }} finish {{ ambient rgb {_vec(self.ambient)} "
                f"diffuse {_num(fin['diffuse'])} phong {_num(fin['specular'])} "
                f"phong_size {_num(fin['shininess'])} reflection {_num(fin['reflect'])} }} }}")

    def interior(self, material) -> str:
        if material is None:
            return ""
        ior = self.graph.scene.materials[material]["ior"]
        return f" interior {{ ior {_num(ior)} }}" if ior != 1.0 else ""


class _Mesh:
    """Flat triangles collected into one mesh2 with shared vertices."""

    def __init__(self):
        self.vertices: dict = {}
        self.faces: list = []
        self.textures: dict = {}

    def add(self, corners, texture: str):
        ids = []
        for p in corners:
            # neighbours compute a shared corner in different frames: a few ulps apart
            key = tuple(float(f"{x:.11g}") for x in p)
            ids.append(self.vertices.setdefault(key, len(self.vertices)))
        t = self.textures.setdefault(texture, len(self.textures))
        self.faces.append((*ids, t))

    def write(self, out):
        if not self.faces:
            return
        out.write("mesh2 {\n  vertex_vectors { %d,\n" % len(self.vertices))
        for v in self.vertices:
            out.write(f"    {_vec(v)}\n")
        out.write("  }\n  texture_list { %d,\n" % len(self.textures))
        for name in self.textures:
            out.write(f"    texture {{ {name} }}\n")
        out.write("  }\n  face_indices { %d,\n" % len(self.faces))
        for a, b, c, t in self.faces:
            out.write(f"    <{a}, {b}, {c}>, {t}\n")
        out.write("  }\n}\n")


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
               size: tuple[int, int], progress=None) -> tuple[int, int, int]:
    """Write the scene to `path` (atomically); returns the number of primitives written,
    of those left out because they are empty (a singular or non-finite transform, a
    runtime error in the grammar, draws nothing in pcsg, and POV-Ray could not parse a
    matrix of NaNs), and of those dropped with the ∩ or \\ they belonged to: leaving an
    operand out empties an intersection as pcsg's tracer does. progress(n), if given, is
    called every PROGRESS_EVERY primitives of the derivation with how many have come."""
    graph = traced.graph
    _refuse_fractals(graph)
    textures = _Textures(graph, lighting)
    mesh = _Mesh()
    empty = 0
    # the body streams to a side file: the declarations it needs are known at its end
    with tempfile.TemporaryFile("w+", encoding="utf-8") as body_file:
        body = _BodyWriter(graph, body_file)
        for done, inst in enumerate(instances(graph), 1):
            if progress is not None and done % PROGRESS_EVERY == 0:
                progress(done)
            if leaf_inverse(inst.matrix) is None:
                empty += 1
                continue
            tex = textures.name(inst.paint, inst.material)
            if inst.primitive in TRIANGLES:
                m = inst.matrix
                mesh.add([m[:3, :3] @ np.array(c, float) + m[:3, 3]
                          for c in TRIANGLES[inst.primitive]], tex)
                continue
            body.add(inst.path, f"object {{ P_{inst.primitive} {_matrix(inst.matrix)} "
                                f"texture {{ {tex} }}{textures.interior(inst.material)} }}")
        body.close()
        body_file.seek(0)
        with open_atomic(path, "w") as out:
            out.write(_header(camera, lighting, size, graph))
            for name, shape in SHAPES.items():
                out.write(f"#declare P_{name} = {shape}\n")
            for line in textures.declares:
                out.write(line + "\n")
            shutil.copyfileobj(body_file, out)
            mesh.write(out)
    return body.written + len(mesh.faces), empty, body.dropped


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

    def add(self, path, line: str):
        needed = []         # (key: the path down to the operator, kind, operands, k)
        inside = False
        for j, (node, k) in enumerate(path):
            g = self.graph.nodes[node]
            inside = inside or g.kind in (INTERSECTION, DIFFERENCE)
            if inside:
                needed.append((path[:j], g.kind, len(g.children), k))
        common = 0
        while (common < min(len(self.open), len(needed))
               and self.open[common].key == needed[common][0]):
            common += 1
        while len(self.open) > common:
            self._close()
        for key, kind, size, _ in needed[common:]:
            self.open.append(_Block(key, kind, size))
        for block, need in zip(self.open, needed):
            block.present.add(need[3])
        self._emit(line, 1)

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
                or (b.kind == INTERSECTION and len(b.present) < b.size)):  # an empty operand
            self.dropped += b.count
            return
        word = {INTERSECTION: "intersection", DIFFERENCE: "difference"}.get(b.kind, "union")
        self._emit(f"{word} {{\n" + "\n".join(b.lines) + "\n}", b.count)

    def close(self):
        while self.open:
            self._close()


def _header(camera: Camera, lighting: Lighting, size, graph) -> str:
    w, h = size
    aspect = w / h
    hfov = math.degrees(2 * math.atan(aspect * math.tan(math.radians(camera.fov) / 2)))
    lines = [
        f"// {Path(graph.source.file).name}: exported by pcsg (pcsg export --pov)",
        f"// render: povray +I{{this file}} +W{w} +H{h}",
        "#version 3.7;",
        f"global_settings {{ assumed_gamma 1.0 max_trace_level {lighting.max_bounces + 1} }}",
        # right-handed like pcsg: a negative right vector mirrors POV-Ray's left-handed frame
        f"camera {{ perspective location {_vec(camera.eye)} sky {_vec(camera.up)} up y "
        f"right -x*{_num(aspect)} angle {_num(hfov)} look_at {_vec(camera.at)} }}",
    ]
    for lt in lighting.lights:
        area = ""
        if lt.radius > 0 and lighting.shadow_samples > 1:
            s = 2 * lt.radius
            area = f" area_light <{_num(s)}, 0, 0>, <0, {_num(s)}, 0>, 3, 3 circular orient"
        shadows = "" if lighting.shadows else " shadowless"
        lines.append(f"light_source {{ {_vec(lt.position)} color rgb {_vec(lt.color)}{area}"
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
