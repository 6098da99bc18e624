"""A hypothesis strategy for random but valid PCSG systems: up to three modules with
counter, stochastic, parameter, constant and invalid selections, every T-node, calculation
blocks (some overflowing, dividing 0 by 0, or making a scale singular), paint
and material, the three operators nested at random, and cycles that end (a counter
decremented on the way) or do not (a module that calls itself unchanged)."""
from hypothesis import strategies as st

SOLIDS = ["sphere", "cube", "cylinder", "cone", "tetrahedron"]
FLATS = ["tri1", "tri2"]
MODULES = ["A", "B", "C"]


def _num(draw, lo, hi):
    return f"{draw(st.integers(round(lo * 100), round(hi * 100))) / 100:g}"


@st.composite
def transform(draw):
    n = lambda lo, hi: _num(draw, lo, hi)      # noqa: E731
    kind = draw(st.sampled_from([
        "move", "pmove", "scale", "uscale", "puscale", "rotx", "roty", "rotz", "rot",
        "zshear", "xshear", "yshear", "flip", "mirror", "matrix"]))
    if kind == "move":
        return f"move({n(-1.5, 1.5)}, {n(-1.5, 1.5)}, {n(-1.5, 1.5)})"
    if kind == "pmove":                 # arguments that read the parameters
        return f"move(n * {n(-0.6, 0.6)}, a * {n(-1, 1)}, {n(-1, 1)})"
    if kind == "scale":
        return f"scale({n(-1.2, 1.2)}, {n(0.2, 1.2)}, {n(0.2, 1.2)})"
    if kind == "uscale":
        return f"uscale({n(0.3, 0.8)})"
    if kind == "puscale":          # singular where a = 0, non-finite where a is
        return draw(st.sampled_from(["uscale(0.4 + 0.3 * a)", "scale(1, a, 1)"]))
    if kind in ("rotx", "roty", "rotz"):
        return f"{kind}({n(-180, 180)})"
    if kind == "rot":
        return f"rot({n(-180, 180)}, {n(-1, 1)}, {n(-1, 1)}, 1)"
    if kind.endswith("shear"):
        return f"{kind}({n(-1, 1)}, {n(-1, 1)})"
    if kind == "flip":
        return draw(st.sampled_from(["flipxy", "flipxz", "flipyz"]))
    if kind == "mirror":
        return f"mirror({n(-1, 1)}, {n(-1, 1)}, 1)"
    rows = [[n(0.5, 1) if i == j else n(-0.3, 0.3) for j in range(3)] + [n(-1, 1)]
            for i in range(3)]
    return "matrix(" + ", ".join(x for r in rows for x in r) + ")"


@st.composite
def calc(draw):
    a = draw(st.sampled_from(["a = a * 0.7 + 0.1", "a = 1 - a", "a = clamp(a + rand() - 0.5, 0, 1)",
                              "a = a / (n + 1)",
                              # runtime errors: overflow to inf, 0/0, a singular scale
                              "a = a * 1e300 * 1e300", "a = (a - a) / (a - a)", "a = 0"]))
    return "{ " + a + " }"


@st.composite
def expression(draw, depth, calls, flat_ok, counted):
    """A CSG expression; `calls` the modules it may name, each behind a decrement of n
    when `counted`; `flat_ok` when no ∩ or \\ is above it anywhere in the system."""
    choices = ["leaf", "leaf", "prefix", "binary"] if depth > 0 else ["leaf"]
    what = draw(st.sampled_from(choices))
    if what == "leaf":
        names = SOLIDS + (FLATS if flat_ok else [])
        if calls and draw(st.booleans()):
            m = draw(st.sampled_from(calls))
            return ("{ n = n - 1 } " if counted else "") + m
        return draw(st.sampled_from(names))
    if what == "prefix":
        kind = draw(st.sampled_from(["t", "t", "paint", "material", "calc"]))
        inner = draw(expression(depth - 1, calls, flat_ok, counted))
        if kind == "t":
            head = draw(transform())
        elif kind == "paint":
            head = draw(st.sampled_from(["paint(1, 0.2, 0.1)", "paint(a, 0.5, 1 - a)",
                                         "paint(0.2, 0.8, 0.3)"]))
        elif kind == "material":
            head = "material(shiny)"
        else:
            head = draw(calc())
        return f"{head} ({inner})"
    ops = ["∪"] if flat_ok else ["∪", "∪", "∩", "\\"]
    op = draw(st.sampled_from(ops))
    left = draw(expression(depth - 1, calls, flat_ok, counted))
    right = draw(expression(depth - 1, calls, flat_ok, counted))
    return f"({left} {op} {right})"


SELECTIONS = {
    "counter": ("if(n > 0, 2, 1)", 2),
    "stochastic": ("if(n > 0, if(rand() < a, 2, 3), 1)", 3),
    "parameter": ("if(n > 0 && a < 0.9, 2, 1)", 2),
    "constant": ("1", 1),
    # may name rule 3 or 4, which do not exist, or be nan: a runtime error, that instance empty
    "wild": ("if(n > 0, 1 + floor(a * 4), 1)", 2),
}


@st.composite
def system(draw):
    """The text of a valid system."""
    k = draw(st.integers(1, 3))
    mods = MODULES[:k]
    flat_ok = draw(st.booleans())
    lines = ["#material shiny color=(0.9, 0.8, 0.2) specular=0.8 reflect=0.3"]
    n0 = draw(st.integers(0, 6))
    a0 = _num(draw, 0, 1)
    axiom = draw(expression(2, mods, flat_ok, False))
    op = draw(st.sampled_from(["∪"] if flat_ok else ["∪", "∩", "\\"]))
    lines.append(f"{{ n = {n0}; a = {a0} }} (({axiom}) {op} {mods[0]})")    # A is used
    for m in mods:
        kind = draw(st.sampled_from(list(SELECTIONS)))
        sel, rules = SELECTIONS[kind]
        lines.append(f"{m} {sel}")
        for r in range(1, rules + 1):
            terminal = kind != "constant" and r == 1
            # a constant selection may still call modules: unchanged, that cycle never ends
            counted = kind != "constant" or draw(st.booleans())
            calls = [] if terminal else mods
            body = draw(expression(3, calls, flat_ok, counted))
            lines.append(f"{r}: {m} → {body}")
    return "\n".join(lines) + "\n"
