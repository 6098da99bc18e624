"""Shading: Phong with paint colours and #material finishes, hard shadows by
any-hit rays, soft shadows from area lights, ambient occlusion, mirror reflection
and refraction with Fresnel to a bounded depth, a sky. Works on batches of rays
(numpy); the tracing itself is the numba kernel. Colours are linear; image.py
encodes sRGB."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..scene import MATERIAL_DEFAULTS
from ..trace.jit import threads
from ..trace.shading import (AO_STREAM, EPS, EPS_FAR, GOLDEN, LIGHT_STREAM, M_TRANSMIT,
                             MAX_CROSSINGS, MIN_WEIGHT)
from ..trace.walk import HIT_SHEET, HIT_SHELL
from ..trace.vm import hash_to_unit_array, splitmix64_array
from ..tracer import Hits
from .camera import finite_bounds

FINISH_KEYS = ("diffuse", "specular", "shininess", "reflect", "ior", "transmit")

DEFAULT_COLOR = np.array([0.78, 0.76, 0.72])       # an unpainted object: warm light grey
DEFAULT_HORIZON = np.array([0.86, 0.90, 0.96])
DEFAULT_ZENITH = np.array([0.32, 0.52, 0.84])
SUN_COLOR = np.array([1.0, 0.97, 0.92])            # the default sun's, and --light's
AMBIENT = 0.22
AO_DISTANCE = 0.15          # default --ao-distance, a fraction of the object's box diagonal


@dataclass
class Light:
    position: np.ndarray
    color: np.ndarray
    radius: float = 0.0


@dataclass
class Lighting:
    lights: list[Light]
    horizon: np.ndarray
    zenith: np.ndarray
    # (k, 9): color(3) diffuse specular shininess reflect ior transmit
    materials: np.ndarray
    shadows: bool = True
    shadow_samples: int = 8
    max_bounces: int = 3
    ao_samples: int = 0             # hemisphere rays per shading point; 0: no occlusion
    ao_distance: float = 1.0        # occluders farther than this do not count
    lod: float = 0.0
    packets: bool = True            # neighbouring rays walk the graph together (trace/packet.py)
    # a shaded point moves off its surface by EPS of unit and EPS_FAR of its largest
    # coordinate (off_surface); unit is 1, or the object's size where smaller (with 1,
    # `uscale(1e-12) sphere` was lit from 1e-6 off it, past its light, and drawn dark)
    unit: float = 1.0
    rays: list = field(default_factory=lambda: [0])   # rays traced, for the summary

    def sky(self, d: np.ndarray) -> np.ndarray:
        s = np.clip(d[:, 2:3] / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-300),
                    0.0, 1.0) ** 0.6
        return self.horizon * (1 - s) + self.zenith * s


def make_lighting(traced, camera, shadows=True, shadow_samples=8, max_bounces=3, ao=None,
                  ao_distance=None, light_at=None) -> Lighting:
    """`ao` / `ao_distance` None: the file's #occlusion, else no occlusion and a distance
    of AO_DISTANCE times the object's (finite) box diagonal. `light_at`: one point light
    there, in the default sun's colour, instead of the file's lights (--light)."""
    scene = traced.graph.scene
    sky = scene.sky
    horizon = np.array(sky.get("horizon", sky.get("color", DEFAULT_HORIZON)), float)
    zenith = np.array(sky.get("zenith", sky.get("color", DEFAULT_ZENITH)), float)
    lights = [Light(np.array(l["at"], float),
                    np.array(l.get("color", (1.0, 1.0, 1.0)), float), float(l.get("radius", 0.0)))
              for l in scene.lights]
    if light_at is not None:
        lights = [Light(np.array(light_at, float), SUN_COLOR.copy())]
    elif not lights:
        lights = [default_light(camera)]
    lights = [_within_reach(lt, traced, camera) for lt in lights]
    mats = np.array([[*scene.materials[name]["color"],
                      *(scene.materials[name][k] for k in FINISH_KEYS)]
                     for name in traced.material_names] or np.zeros((0, 9)), float).reshape(-1, 9)
    occ = scene.occlusion
    ao = int(occ.get("samples", 0)) if ao is None else ao
    if ao_distance is None:
        ao_distance = occ.get("distance")
    if ao_distance is None:     # the object's size, where occlusion is on without a distance
        box = finite_bounds(traced) if ao > 0 else np.zeros(6)
        ao_distance = AO_DISTANCE * float(np.linalg.norm(box[3:] - box[:3]))
    return Lighting(lights, horizon, zenith, mats, shadows, max(1, shadow_samples), max_bounces,
                    ao, float(ao_distance), unit=_unit(traced))


def _unit(traced) -> float:
    """Lighting.unit: the diagonal of the object's box without a ground plane's infinite
    part (camera.finite_bounds), where it is below 1. With the plane's infinite box the unit
    stayed 1, and an object of 1e-6 on a plane had its shaded points moved off their
    surfaces by its own size: its shadows were cut short or gone (QA)."""
    box = finite_bounds(traced)
    size = float(np.linalg.norm(box[3:] - box[:3]))
    return size if 0.0 < size < 1.0 else 1.0


# A light farther than REACH times the scene's size (the camera's distance to the point it
# looks at, or the object's box diagonal, the larger) stands that far, in its direction,
# its radius scaled with it: a shadow ray spans the whole way to the light and begins
# 1e-9 of it from the surface, so a light at 1e10 drew no shadows, and past 1e154 the
# squared distance overflowed and it lit nothing. Its direction moves by at most
# 1/REACH of a radian over the scene.
REACH = 1e4


def _within_reach(lt: Light, traced, camera) -> Light:
    to = lt.position - camera.at
    big = float(np.abs(to).max())
    size = float(np.linalg.norm(camera.eye - camera.at))
    if not big > REACH * size:
        return lt
    box = finite_bounds(traced)
    # no floor of 1e-12 under the size: a light 1e-8 from a scene of 1e-20 had its
    # shadow rays begin 1e-17 off the surface, past every occluder (QA)
    reach = REACH * max(size, float(np.linalg.norm(box[3:] - box[:3])), 1e-300)
    unit = to / big                                 # no overflow on the way
    length = float(np.linalg.norm(unit))
    dist = big * length                             # inf past 1.8e308 only
    if dist <= reach:
        return lt
    return Light(camera.at + unit / length * reach, lt.color, lt.radius * reach / dist)


def default_light(camera) -> Light:
    """A sun above and to the left of the camera, so that the picture has form."""
    fwd, right, up = camera.basis()
    dist = np.linalg.norm(camera.at - camera.eye)
    pos = camera.at + (-0.6 * right + 1.1 * up - 0.4 * fwd) * 10 * max(dist, 1.0)
    pos[2] = max(pos[2], camera.at[2] + 5 * max(dist, 1.0))
    return Light(pos, SUN_COLOR.copy(), 0.0)


def _finish(light: Lighting, material: np.ndarray, paint: np.ndarray):
    """Per hit: base colour (paint wins, then the material's colour) and finish columns."""
    n = len(material)
    fin = np.tile([*MATERIAL_DEFAULTS["color"], MATERIAL_DEFAULTS["diffuse"],
                   MATERIAL_DEFAULTS["specular"], MATERIAL_DEFAULTS["shininess"],
                   MATERIAL_DEFAULTS["reflect"], MATERIAL_DEFAULTS["ior"],
                   MATERIAL_DEFAULTS["transmit"]], (n, 1)).astype(float)
    fin[:, :3] = DEFAULT_COLOR
    has = material >= 0
    if has.any():
        fin[has] = light.materials[material[has]]
    painted = ~np.isnan(paint[:, 0])
    fin[painted, :3] = np.clip(paint[painted], 0.0, None)
    return fin


def shade(traced, light: Lighting, origins, directions, depth: int = 0, kernel: bool = True,
          ids=None, weight=None, check=None, cone=None):
    """Linear RGB for each ray, its first-hit distance (inf for the sky) and its hits.
    ids (default 0, 1, ...) name each ray's pixel and sample for the ambient occlusion
    pattern; bounces keep their camera ray's id. weight (default 1): what each ray's
    colour is multiplied by on its way into the pixel. cone (default 0): the width each ray
    starts with; the rays that leave a surface start with the footprint there. The graph
    tracer shades in one numba
    kernel (trace/shading.py), which calls check() every 50 ms and stops if it raises;
    this numpy code is the model it follows, and shades the reference renders."""
    ids = np.arange(len(origins), dtype=np.int64) if ids is None else ids
    weight = np.ones(len(origins)) if weight is None else weight
    if kernel and depth == 0 and hasattr(traced, "flat"):
        return _shade_kernel(traced, light, origins, directions, ids, check)
    cone = np.zeros(len(origins)) if cone is None else cone
    # tmin 0 as the kernel's (trace/shading.py): the eye, or a point moved off its surface
    hits = traced.trace(origins, directions, tmin=0.0, lod=light.lod, cone=cone)
    light.rays[0] += len(origins)
    color = light.sky(directions)
    h = hits.hit
    if not h.any():
        return color, hits.t, hits
    d = directions[h] / np.linalg.norm(directions[h], axis=1, keepdims=True)
    p = origins[h] + hits.t[h, None] * directions[h]
    n = hits.normal[h].copy()
    inside = np.einsum("ij,ij->i", n, d) > 0
    n[inside] = -n[inside]                         # face the viewer
    fin = _finish(light, hits.material[h], hits.paint[h])
    base, kd, ks, shin = fin[:, :3], fin[:, 3:4], fin[:, 4:5], fin[:, 5:6]
    reflect, ior, transmit = fin[:, 6], fin[:, 7], fin[:, 8]
    if hits.what is not None:       # as the kernel's `surfaces`
        ior = np.where(hits.what[h] == HIT_SHEET, 1.0, ior)
        transmit = np.where(hits.what[h] == HIT_SHELL, 0.0, transmit)
    up = np.clip(n[:, 2:3] * 0.5 + 0.5, 0, 1)
    out = AMBIENT * base * (light.horizon * (1 - up) + light.zenith * up)
    lift = off_surface(light.unit, p)
    origin = p + n * lift
    # the pixel's width where it meets the surface, which the rays that leave it start with
    # (as the kernel sums it: trace/shading.py)
    dh = directions[h]
    spot = cone[h] + light.lod * hits.t[h] * np.sqrt(dh[:, 0] * dh[:, 0] + dh[:, 1] * dh[:, 1]
                                                     + dh[:, 2] * dh[:, 2])
    if light.ao_samples > 0:
        out *= _unoccluded(traced, light, origin, n, ids[h], spot)[:, None]
    for li, lt in enumerate(light.lights):
        vis, ldir = _visibility(traced, light, lt, origin, n, ids[h], li, spot)
        ndl = np.clip(np.einsum("ij,ij->i", n, ldir), 0, None)[:, None]
        refl = ldir - 2 * np.einsum("ij,ij->i", ldir, n)[:, None] * n
        spec = np.clip(np.einsum("ij,ij->i", refl, d), 0, None)[:, None] ** shin
        out += vis[:, None] * lt.color * (kd * base * ndl + ks * spec * (ndl > 0))
    if depth < light.max_bounces:
        out = _bounces(traced, light, out, d, n, p, lift, inside, reflect, ior, transmit,
                       depth, ids[h], weight[h], spot)
    color[h] = out
    return color, hits.t, hits


def _shade_kernel(traced, light: Lighting, origins, directions, ids, check=None):
    from ..trace.shading import CHUNK, shade_rays
    from ..trace.nodes import add_events, no_events
    o = np.ascontiguousarray(origins, dtype=np.float64)
    d = np.ascontiguousarray(directions, dtype=np.float64)
    n = len(o)
    lights = np.array([[*lt.position, *lt.color, lt.radius] for lt in light.lights],
                      float).reshape(-1, 7)
    default = np.array([*DEFAULT_COLOR, *(MATERIAL_DEFAULTS[k] for k in FINISH_KEYS)], float)
    materials = light.materials if len(light.materials) else default[None, :]
    rgb = np.empty((n, 3))
    t = np.empty(n)
    hit = np.empty(n, dtype=np.bool_)
    chunks = (n + CHUNK - 1) // CHUNK
    rays = np.zeros(chunks, dtype=np.int64)
    workers = threads()
    events = no_events(len(traced.graph.nodes), workers)
    shade_rays(traced.flat, o, d, lights, np.asarray(light.horizon, float),
               np.asarray(light.zenith, float), np.ascontiguousarray(materials, dtype=float),
               default, bool(light.shadows), int(light.shadow_samples), int(light.max_bounces),
               float(light.lod), int(traced.max_depth), traced.limits, workers,
               AMBIENT, int(light.ao_samples), float(light.ao_distance), float(light.unit),
               np.ascontiguousarray(ids, dtype=np.int64), traced._packets(light.packets), rgb,
               t, hit, rays, events, tick=check)
    add_events(traced.events, events)
    light.rays[0] += int(rays.sum())
    return rgb, t, Hits(t=t, normal=None, paint=None, material=None, hit=hit)


def _visibility(traced, light: Lighting, lt: Light, origin: np.ndarray, n: np.ndarray,
                ids: np.ndarray, li: int, spot: np.ndarray):
    """Fraction of the light seen from each point, and the unit direction to it. Points
    whose normal n turns away from the light get nothing from it, shadowed or not, so
    they send no shadow rays (their fraction is 0). An area light's samples are shifted
    by each point's pixel id (`ids`) in the stream of light li (the kernel's
    trace/shading.disk, which says why). The rays start with the widths `spot`."""
    to = lt.position - origin
    dist = np.linalg.norm(to, axis=1, keepdims=True)
    ldir = to / dist
    if not light.shadows:
        return np.ones(len(origin)), ldir
    samples = light.shadow_samples if lt.radius > 0 else 1
    facing = n[:, 0] * ldir[:, 0] + n[:, 1] * ldir[:, 1] + n[:, 2] * ldir[:, 2] > 0.0
    seen = np.zeros(len(origin))
    o, width = origin[facing], spot[facing]
    shift = _pixel_shift(ids[facing], LIGHT_STREAM + np.uint64(li))
    glass = bool(len(light.materials)) and bool((light.materials[:, M_TRANSMIT] > 0).any())
    for k in range(samples if len(o) else 0):
        # one sample: the light is a point at its centre
        target = lt.position + (_disk(k, samples, lt.radius, shift, ldir[facing])
                                if samples > 1 else 0.0)
        target = np.broadcast_to(target, o.shape)
        hit = traced.trace(o, target - o, tmin=1e-9, tmax=1.0 - 1e-9, any_hit=True,
                           lod=light.lod, cone=width)
        light.rays[0] += len(o)
        passed = (~hit.hit).astype(float)
        if glass and hit.hit.any():
            # what stops light, met first, stops it whatever else is there
            again = hit.hit.copy()
            again[hit.hit] = _passes(light, hit, hit.hit) > 0
            passed[again] = _through_glass(traced, light, o[again], target[again],
                                           width[again])
        seen[facing] += passed
    return seen / samples, ldir


def _passes(light: Lighting, hits: Hits, which: np.ndarray) -> np.ndarray:
    """The share of light the surfaces hit at `which` let through: their material's
    transmit, 0 for a shell."""
    through = _finish(light, hits.material[which], hits.paint[which])[:, M_TRANSMIT]
    if hits.what is not None:
        through = np.where(hits.what[which] == HIT_SHELL, 0.0, through)
    return through


def _through_glass(traced, light: Lighting, o: np.ndarray, target: np.ndarray,
                   width: np.ndarray):
    """The light that comes through to points o from targets on a light, whose shadow
    rays met something: walked again surface by surface, nearest first, each surface of
    a material that transmits letting through its transmit, anything else (or a shell)
    stopping it; past MAX_CROSSINGS surfaces, none. Each ray starts again with its width
    where it left the lit surface (the kernel's)."""
    out = np.zeros(len(o))
    passing = np.ones(len(o))
    origin = o.copy()
    active = np.arange(len(o))
    for _ in range(MAX_CROSSINGS):
        if not len(active):
            break
        d = target[active] - origin[active]
        h = traced.trace(origin[active], d, tmin=1e-9, tmax=1.0 - 1e-9, lod=light.lod,
                         cone=width[active])
        light.rays[0] += len(active)
        out[active[~h.hit]] = passing[active[~h.hit]]
        through = np.zeros(len(active))
        through[h.hit] = _passes(light, h, h.hit)
        go = h.hit & (through > 0)
        active, d, t = active[go], d[go], h.t[go]
        passing[active] *= through[go]
        p = origin[active] + t[:, None] * d
        dn = np.sqrt(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2])
        origin[active] = p + d / dn[:, None] * off_surface(light.unit, p)
    return out


def _pixel_shift(ids: np.ndarray, stream: np.uint64) -> np.ndarray:
    """Each pixel's shift (m, 2) of a sample pattern, from its id in one stream (the
    kernel's trace/shading.pixel_shift)."""
    h = splitmix64_array(ids.astype(np.uint64) ^ stream)
    return np.stack([hash_to_unit_array(h), hash_to_unit_array(splitmix64_array(h))], 1)


def _shifted(k: int, n: int, shift: np.ndarray) -> np.ndarray:
    """Point k of n of the pattern in the unit square for each row of `shift` (the
    kernel's trace/shading.shifted)."""
    uv = np.stack([(k + 0.5) / n + shift[:, 0], k * GOLDEN + shift[:, 1]], 1)
    return uv - np.floor(uv)


def _disk(k: int, n: int, radius: float, shift: np.ndarray, normal: np.ndarray
          ) -> np.ndarray:
    """Sample k of n on a disk of `radius` facing each normal, shifted by each row of
    `shift` mod 1 (the kernel's trace/shading.disk, which says why): the same points
    every render, deterministic soft shadows."""
    uv = _shifted(k, n, shift)
    r = radius * np.sqrt(uv[:, :1])
    a = 2 * math.pi * uv[:, 1:]
    u, v = _basis(normal)
    return r * (np.cos(a) * u + np.sin(a) * v)


def _basis(normal: np.ndarray):
    """Two unit vectors perpendicular to each normal and to each other."""
    helper = np.where(np.abs(normal[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    u = np.cross(normal, helper)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    return u, np.cross(normal, u)


def _unoccluded(traced, light: Lighting, origin, normal, ids, spot) -> np.ndarray:
    """The fraction of ao_samples cosine-weighted hemisphere rays about each normal that
    meet nothing within ao_distance: the ambient light a Lambertian point receives."""
    shift = _pixel_shift(ids, AO_STREAM)
    seen = np.zeros(len(origin))
    for k in range(light.ao_samples):
        hit = traced.trace(origin, _hemisphere(k, light.ao_samples, shift, normal), tmin=0.0,
                           tmax=light.ao_distance, any_hit=True, lod=light.lod, cone=spot)
        light.rays[0] += len(origin)
        seen += ~hit.hit
    return seen / light.ao_samples


def _hemisphere(k: int, n: int, shift: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """Direction k of n about each unit normal, cosine weighted: a pattern stratified in
    elevation with golden-ratio azimuths, shifted by each row of `shift` mod 1 (the
    kernel's trace/shading.hemisphere, which says why)."""
    uv = _shifted(k, n, shift)
    s, c = np.sqrt(uv[:, :1]), np.sqrt(np.clip(1.0 - uv[:, :1], 0.0, None))
    a = 2 * math.pi * uv[:, 1:]
    u, v = _basis(normal)
    return s * np.cos(a) * u + s * np.sin(a) * v + c * normal


def off_surface(unit: float, p: np.ndarray) -> np.ndarray:
    """(n, 1): how far each shaded point moves off its surface, as the kernel's
    off_surface: EPS of the object's size and EPS_FAR of the point's largest coordinate."""
    return EPS * unit + EPS_FAR * np.abs(p).max(axis=1, keepdims=True)


def _bounces(traced, light, out, d, n, p, lift, inside, reflect, ior, transmit, depth, ids,
             weight, spot):
    """Mirror reflection and refraction, traced one level deeper: a surface keeps
    1 - kr - kt of its own colour and passes kr to its reflection, kt to its
    refraction (fresnel_split)."""
    cos_i = -np.einsum("ij,ij->i", d, n)
    eta = np.where(inside, ior, 1.0 / np.maximum(ior, 1e-9))
    k = 1 - eta ** 2 * (1 - cos_i ** 2)
    kr, kt = fresnel_split(cos_i, eta, reflect, transmit)
    want_r = kr * weight > MIN_WEIGHT
    want_t = kt * weight > MIN_WEIGHT
    out = out * (1 - np.where(want_r, kr, 0.0) - np.where(want_t, kt, 0.0))[:, None]
    if want_r.any():
        rd = d[want_r] + 2 * cos_i[want_r, None] * n[want_r]
        c, _, _ = shade(traced, light, p[want_r] + n[want_r] * lift[want_r], rd,
                        depth + 1, ids=ids[want_r], weight=weight[want_r] * kr[want_r],
                        cone=spot[want_r])
        out[want_r] += kr[want_r, None] * c
    if want_t.any():
        e, ci, kk = eta[want_t, None], cos_i[want_t, None], k[want_t, None]
        td = e * d[want_t] + (e * ci - np.sqrt(np.clip(kk, 0, None))) * n[want_t]
        c, _, _ = shade(traced, light, p[want_t] - n[want_t] * lift[want_t], td,
                        depth + 1, ids=ids[want_t], weight=weight[want_t] * kt[want_t],
                        cone=spot[want_t])
        out[want_t] += kt[want_t, None] * c
    return out


def fresnel_split(cos_i, eta, reflect, transmit):
    """(kr, kt): the shares of the light leaving a surface that come by its reflection
    and by its refraction, for a ray meeting it at cos_i with eta = n1 / n2. Fresnel's
    equations for unpolarised light give the share f a dielectric reflects, 1 at total
    internal reflection; kr = reflect + transmit f and kt = transmit (1 - f), at most
    1 together. Schlick's approximation, used before, does not vanish where eta is 1
    (a glass of index 1 showed a dark rim) and took the inner angle leaving glass."""
    c = np.clip(cos_i, 0.0, 1.0)
    sin2 = eta * eta * (1 - c * c)
    total = sin2 >= 1
    cos_t = np.sqrt(np.clip(1 - sin2, 0.0, None))
    with np.errstate(invalid="ignore", divide="ignore"):     # 0/0 only at total reflection
        rs = (eta * c - cos_t) / (eta * c + cos_t)
        rp = (c - eta * cos_t) / (c + eta * cos_t)
    f = np.where(total, 1.0, 0.5 * (rs * rs + rp * rp))
    kr = np.clip(reflect + transmit * f, 0, 1)
    kt = np.where(total, 0.0, np.minimum(transmit * (1 - f), 1 - kr))
    return kr, kt
