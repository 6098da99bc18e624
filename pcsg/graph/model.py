"""The cyclic CSG graph: S-, C-, T-, operator, primitive and paint/material nodes."""
from __future__ import annotations

from dataclasses import dataclass, field

from ..language.errors import Diagnostic
from ..language.source import Source

SELECT, CALC, TRANSFORM, UNION, INTERSECTION, DIFFERENCE, PRIMITIVE, PAINT, MATERIAL = range(9)
KIND_NAMES = ("select", "calc", "transform", "union", "intersection", "difference",
              "primitive", "paint", "material")
OPERATORS = {"union": UNION, "intersection": INTERSECTION, "difference": DIFFERENCE}
OPERATOR_SYMBOLS = {UNION: "∪", INTERSECTION: "∩", DIFFERENCE: "\\"}


@dataclass(eq=False)
class Node:
    kind: int
    name: str = ""                 # module, transformation, primitive or material name
    children: list[int] = field(default_factory=list)
    exprs: list[int] = field(default_factory=list)   # selection | arguments | assigned values
    targets: list[int] = field(default_factory=list)  # C-node: parameter slot of each value
    span: tuple[int, int] | None = None               # where the node is written
    edge_spans: list = field(default_factory=list)    # where each child edge is written

    @property
    def kind_name(self):
        return KIND_NAMES[self.kind]


@dataclass
class Scene:
    """Scene directives, evaluated (notation §8); empty means renderer defaults."""
    camera: dict = field(default_factory=dict)
    lights: list[dict] = field(default_factory=list)
    sky: dict = field(default_factory=dict)
    occlusion: dict = field(default_factory=dict)
    materials: dict[str, dict] = field(default_factory=dict)
    coloured: set[str] = field(default_factory=set)   # materials with a color= of their own


@dataclass
class Graph:
    source: Source
    nodes: list[Node]
    root: int
    params: dict[str, int]            # parameter name -> slot
    modules: dict[str, int]           # module name -> its S-node
    exprs: object                     # ExprTable
    expr_ast: list                    # the AST of each expression, for positions
    scene: Scene
    material_names: list[str]         # material index -> name
    warnings: list[Diagnostic] = field(default_factory=list)
    axiom_span: tuple[int, int] | None = None
    # `matrix` nodes that graph/fuse.py wrote for runs of T-nodes -> the run's head
    origins: dict[int, int] = field(default_factory=dict)
    # the slot the tracer fills with an instance's size in pixels before a selection that
    # reads `pixels` (names.PIXELS, where the file does not assign it), else -1
    pixels: int = -1

    def constant_args(self, i: int) -> tuple:
        """The arguments of node i, which the builder checked to be constants (fractals)."""
        return tuple(self.exprs.constant(e) for e in self.nodes[i].exprs)

    @property
    def param_names(self) -> list[str]:
        return sorted(self.params, key=self.params.get)
