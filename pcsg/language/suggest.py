"""'did you mean' for a name that is not known: the known name it most likely stands for."""
from __future__ import annotations

import difflib
from collections.abc import Iterable


# what other CSG tools (POV-Ray, OpenSCAD) call what the notation writes otherwise
# (the operators' words, union(a, b) and the like: mistakes.OPERATOR_WORDS)
ALIASES = {"translate": "move", "rotate": "rot", "color": "paint", "colour": "paint",
           "box": "cube", "ball": "sphere", "pyramid": "tetrahedron",
           # directives' keys as other renderers name them: the first a directive knows
           # (a light's position is its `at`, a camera's its `eye`)
           "location": ("eye", "at"), "position": ("eye", "at"), "from": ("eye",),
           "pos": ("eye", "at"), "refl": ("reflect",), "dist": ("distance",),
           "shine": ("shininess",), "spec": ("specular",)}
# where a camera looks: its `at`, which for a light is where it is, not what it faces
LOOK_AT = frozenset({"look_at", "lookat", "look", "target", "to"})


def closest(name: str, known: Iterable[str]) -> str | None:
    """The known name `name` most likely misspells: the one that differs only in case,
    else one a single typing slip away (a letter left out, added, changed or two swapped:
    `fvo`, `cc`), else the nearest by difflib's ratio, if near enough (0.75: `spher`,
    `tetrahedon`, `usclae` find theirs; `cube` does not become `cone`)."""
    known = [k for k in dict.fromkeys(known) if k != name]
    folded = [k for k in known if k.lower() == name.lower()]
    if folded:
        return folded[0]
    if name.lower() in LOOK_AT and "eye" in known and "at" in known:
        return "at"
    alias = ALIASES.get(name.lower(), ())
    for meant in (alias,) if isinstance(alias, str) else alias:
        if meant in known:
            return meant
    # a slip in either case: `Cub` is `cube`'s (it was no suggestion, `Cube` was)
    slips = [k for k in known if _one_slip(name, k) or _one_slip(name.lower(), k.lower())]
    if slips:
        return slips[0]
    near = difflib.get_close_matches(name, known, n=1, cutoff=0.75)
    return near[0] if near else None


def _one_slip(a: str, b: str) -> bool:
    """a and b differ by one letter left out, added or changed, or two neighbours swapped;
    a changed letter only in names of three letters or more (any one-letter name is one
    change away from every other: 'k' is no slip for 'c')."""
    if abs(len(a) - len(b)) > 1 or (len(a) == len(b) and len(a) < 3 and sorted(a) != sorted(b)):
        return False
    i = 0
    while i < min(len(a), len(b)) and a[i] == b[i]:
        i += 1
    if len(a) == len(b):
        return (a[i + 1:] == b[i + 1:]
                or (i + 1 < len(a) and a[i] == b[i + 1] and a[i + 1] == b[i]
                    and a[i + 2:] == b[i + 2:]))
    longer, shorter = (a, b) if len(a) > len(b) else (b, a)
    return longer[i + 1:] == shorter[i:]


def did_you_mean(name: str, known: Iterable[str]) -> str:
    """'; did you mean 'X'?' to end a message with, or '' where no name is close."""
    best = closest(name, known)
    return f"; did you mean '{best}'?" if best else ""
