"""The notation's fixed vocabulary: transformations, primitives, functions."""

# name -> number of arguments (notation §4)
TRANSFORMS = {
    "move": 3, "scale": 3, "uscale": 1, "rotx": 1, "roty": 1, "rotz": 1, "rot": 4,
    "zshear": 2, "xshear": 2, "yshear": 2, "flipxy": 0, "flipxz": 0, "flipyz": 0,
    "mirror": 3, "matrix": 12,
}

# notation §5; flat primitives have no inside and may only be combined by union
# Fractals given by a distance estimate take arguments (name -> their names) and, like the
# flat ones, have no interval along a ray: only the first surface, so union only.
FRACTAL_PRIMITIVES = {"mandelbulb": ("power",), "julia": ("cx", "cy", "cz", "cw")}
PRIMITIVES = ("sphere", "cube", "cylinder", "cone", "tetrahedron", "plane", "tri1", "tri2",
              *FRACTAL_PRIMITIVES)
FLAT_PRIMITIVES = frozenset({"tri1", "tri2"})
UNION_ONLY_PRIMITIVES = FLAT_PRIMITIVES | frozenset(FRACTAL_PRIMITIVES)

# read-only, in selections only: the projected size of the instance in pixels (+inf
# where there is no camera: stats, expand, export, the reference)
PIXELS = "pixels"

FUNCTIONS = ("if", "min", "max", "abs", "sqrt", "pow", "exp", "ln", "log", "log10", "sin", "cos",
             "tan", "asin", "acos", "atan", "atan2", "deg", "rad", "floor", "ceil", "round",
             "clamp", "rand")

# pcsg's own words beyond notation §2, which reserves only the above's kinds: a file may
# take them for a module, named expression or parameter of its own, and then they are its
# (the fractals keep their meaning before their arguments, where the lexer reads them)
FREE = frozenset({*FRACTAL_PRIMITIVES, PIXELS})

RESERVED = {
    **{n: "a transformation" for n in TRANSFORMS},
    **{n: "a primitive" for n in PRIMITIVES},
    **{n: "a function" for n in FUNCTIONS},
    "paint": "the paint operator", "material": "the material operator",
    "pi": "a constant", PIXELS: "the instance's size in pixels, read-only",
    "and": "an operator", "or": "an operator", "not": "an operator",
}
