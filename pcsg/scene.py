"""Scene directives (notation §8): #camera, #light, #sky, #material, and #occlusion
(ambient occlusion, a pcsg extension)."""
from __future__ import annotations

import math

from .graph.model import Scene
from .language import ast
from .language.suggest import closest, did_you_mean

# directive -> key -> number of values
DIRECTIVES = {
    "camera": {"eye": 3, "at": 3, "up": 3, "fov": 1},
    "light": {"at": 3, "color": 3, "radius": 1},
    "sky": {"color": 3, "horizon": 3, "zenith": 3},
    "occlusion": {"samples": 1, "distance": 1},
    "material": {"color": 3, "diffuse": 1, "specular": 1, "shininess": 1, "reflect": 1,
                 "ior": 1, "transmit": 1},
}
MATERIAL_DEFAULTS = {"color": (0.8, 0.8, 0.8), "diffuse": 0.7, "specular": 0.3, "shininess": 40.0,
                     "reflect": 0.0, "ior": 1.0, "transmit": 0.0}
DEFAULT_UP = (0.0, 0.0, 1.0)                # #camera's up where it gives none
DEFAULT_FOV = 40.0          # the #camera line of notation §8 shows fov=40, as it shows up=(0,0,1)
# the narrowest view: a pixel of it 480 rows high spans 4e-14 of the distance to what it
# frames, 300 times a double's rounding there; at 1e-11 degrees the rays' origins round
# coarser than a pixel, and --fov 1e-320 put the framed eye at infinity ("the object's box
# is too large to frame")
MIN_FOV = 1e-9
ONCE = ("camera", "sky", "occlusion")       # at most one per file
MAX_AO_SAMPLES = 1024
# (directive, key) -> (test of the value, what the error asks for)
RANGES = {
    ("occlusion", "samples"): (lambda v: 0 <= v <= MAX_AO_SAMPLES and v == int(v),
                               f"a whole number of rays from 0 (off) to {MAX_AO_SAMPLES}"),
    ("occlusion", "distance"): (lambda v: 0 < v < float("inf"), "a positive distance"),
    ("camera", "fov"): (lambda v: MIN_FOV <= v < 180,
                        f"an angle in degrees from {MIN_FOV:g} to under 180"),
}
# lights and finishes: a negative or non-finite one drew black, white or glowing spheres
_AMOUNT = (lambda v: 0 <= v < math.inf, "a finite number, 0 or more")
_FRACTION = (lambda v: 0 <= v <= 1, "a fraction from 0 to 1")
RANGES.update({(d, k): _AMOUNT for d, keys in (
    ("light", ("color", "radius")), ("sky", ("color", "horizon", "zenith")),
    ("material", ("color", "diffuse", "specular", "shininess"))) for k in keys})
RANGES.update({("material", "reflect"): _FRACTION, ("material", "transmit"): _FRACTION,
               ("material", "ior"): (lambda v: 0 < v < math.inf, "a positive finite number")})


FARTHEST = 1e150     # from eye to at: the tracer squares distances and coordinates


def camera_degenerate(eye, at, up) -> str | None:
    """'same' where eye is at, 'zero' where up is, 'parallel' where up lies along the
    view from eye to at, 'far' where eye is FARTHEST or more from at, else None: the one
    test of #camera here and of every camera the renderer places (render/camera.py)."""
    ux, uy, uz = (float(u) for u in up)
    if not (ux or uy or uz):
        return "zero"
    view = [float(a) - float(e) for a, e in zip(at, eye)]
    if not any(view):
        return "same"
    vx, vy, vz = view
    if not math.hypot(vx, vy, vz) < FARTHEST:
        return "far"
    cross = (vy * uz - vz * uy, vz * ux - vx * uz, vx * uy - vy * ux)
    if math.hypot(*cross) <= 1e-12 * math.hypot(*view) * math.hypot(ux, uy, uz):
        return "parallel"
    return None


def _camera_problem(camera: dict) -> tuple[tuple[str, ...], str] | None:
    """What keeps a #camera with both eye and at from being placed, and the keys at fault
    (the error points at the last of them that the directive gives)."""
    if not any(camera.get("up", DEFAULT_UP)):
        return ("up",), "#camera: up is (0, 0, 0), no direction: give one such as (0, 0, 1)"
    if "eye" not in camera or "at" not in camera:
        return None
    what = camera_degenerate(camera["eye"], camera["at"], camera.get("up", DEFAULT_UP))
    if what == "same":
        return ("eye", "at"), "#camera: eye and at are the same point"
    if what == "parallel":
        return ("eye", "at", "up"), ("#camera: up is parallel to the view from eye to at (up "
                                     "defaults to (0, 0, 1)): give another up")
    if what == "far":
        return ("eye", "at"), f"#camera: eye is too far from at (at most {FARTHEST:g} apart)"
    return None


def _known(words) -> str:
    return ", ".join(sorted(words))


def build_scene(directives: list[ast.Directive], constants, report,
                warn=lambda span, message, code: None, locate=None) -> Scene:
    """Evaluate directives; `constants(node)` compiles a parameter-free expression to a float
    (reporting its own errors, and then None); `report(span, message, code)` reports the
    rest, and `warn` what is legal but most likely not meant. `locate(offset)`, if given,
    names where a directive given twice was first given."""
    scene = Scene()
    seen: dict[str, ast.Directive] = {}
    materials: dict[str, ast.Directive] = {}

    def first(d: ast.Directive) -> str:
        return f" (first at {locate(d.kind_span[0])})" if locate is not None else ""
    for d in directives:
        keys = DIRECTIVES.get(d.kind)
        if keys is None:
            best = closest(d.kind, [*DIRECTIVES, "define"])
            hint = f"; did you mean '#{best}'?" if best else ""
            report(d.kind_span, f"unknown directive '#{d.kind}'{hint} (known: "
                                f"{_known('#' + k for k in DIRECTIVES)}, #define)", "directive")
            continue
        if d.kind == "material":
            if d.name is None:
                report(d.kind_span, "#material needs a name: #material NAME color=(r,g,b) ...",
                       "directive")
                continue
        elif d.name is not None:
            report(d.kind_span, f"#{d.kind} takes no name, only key=value pairs", "directive")
        if d.kind in ONCE and d.kind in seen:
            report(d.kind_span, f"a second #{d.kind}; a file has at most one"
                                f"{first(seen[d.kind])}", "directive")
            continue
        seen[d.kind] = d
        values = {}
        for item in d.items:
            want = keys.get(item.key)
            if want is None:
                report(item.key_span, f"unknown key '{item.key}' for #{d.kind}"
                                      f"{did_you_mean(item.key, keys)} (known: {_known(keys)})",
                       "directive")
                continue
            if item.key in values:
                report(item.key_span, f"'{item.key}' is given twice", "directive")
                continue
            parts = item.value.items if isinstance(item.value, ast.Tuple) else [item.value]
            if len(parts) != want:
                shape = "a number" if want == 1 else f"{want} values in parentheses"
                report(item.value.span, f"'{item.key}' takes {shape}, got {len(parts)}", "directive")
                continue
            nums = tuple(constants(p) for p in parts)
            if None in nums:        # said already: 'undefined name', not 'not finite' too
                continue
            if (d.kind, item.key) not in RANGES and not all(math.isfinite(x) for x in nums):
                # a camera's, and a light's at=: one at 1e400 drew every pixel black
                report(item.value.span, f"'{item.key}' takes finite numbers", "directive")
                continue
            check, wanted = RANGES.get((d.kind, item.key), (None, ""))
            bad = [x for x in nums if check is not None and not check(x)]
            if bad:
                each = " each" if want > 1 else ""
                report(item.value.span, f"'{item.key}' takes{each} {wanted}, got {bad[0]:g}",
                       "directive")
                continue
            values[item.key] = nums[0] if want == 1 else nums
        if d.kind == "camera":
            if problem := _camera_problem(values):
                keys, message = problem
                at_fault = [i.span for i in d.items if i.key in keys]
                report(at_fault[-1] if at_fault else d.kind_span, message, "directive")
            scene.camera = values
        elif d.kind == "light":
            if "at" not in values and len(values) == len(d.items):
                # it stood at (0, 0, 10), wherever the object and the camera were (where a
                # key was refused, `position=` say, that error says enough)
                report(d.kind_span, "#light needs at=(x,y,z), where the light stands "
                                    "(without any #light the render places one above left "
                                    "of the camera)", "directive")
            scene.lights.append(values)
        elif d.kind == "sky":
            if {"color", "horizon", "zenith"} <= values.keys():
                # each end is its own key's: the colour was dropped without a word (QA)
                span = next(i.key_span for i in d.items if i.key == "color")
                warn(span, "#sky: 'color' colours nothing where 'horizon' and 'zenith' "
                           "are both given (each end is its own key's); leave one out",
                     "directive")
            scene.sky = values
        elif d.kind == "occlusion":
            scene.occlusion = values
        elif d.name in materials:
            report(d.kind_span, f"material '{d.name}' is defined twice"
                                f"{first(materials[d.name])}", "directive")
        else:
            materials[d.name] = d
            scene.materials[d.name] = m = {**MATERIAL_DEFAULTS, **values}
            if "color" in values:
                scene.coloured.add(d.name)
            if m["reflect"] + m["transmit"] > 1:
                # shade.fresnel_split: reflection takes its share first
                warn(d.kind_span, f"material '{d.name}': reflect + transmit is "
                                  f"{m['reflect'] + m['transmit']:g}, over 1: it reflects "
                                  f"{m['reflect']:g} and more, and lets through what is left",
                     "material")
    return scene
