"""A whole image: samples per pixel, progress, sRGB PNG (Pillow), alpha, depth."""
from __future__ import annotations

import functools
import io
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..trace.dispatch import cached_jit
from ..output import write_atomic
from .camera import Camera
from .shade import Lighting, shade

ROWS_PER_BATCH = 48
TILE = 16                     # rays are traced in TILE x TILE blocks (see tile_order)
ADAPTIVE_THRESHOLD = 0.06     # sRGB difference to a neighbour that earns extra samples
ADAPTIVE_SAMPLES = 4
JITTER_SEED = 20240607
REFINE_BATCH = 8192           # pixels refined at a time: 32,768 rays, about a batch of rows
# zlib's level 4, not Pillow's 6: half the encoding time (the terrain's 39 ms to 21 ms)
# for files 1 to 5 % larger
PNG_LEVEL = 4
SRGB_BAND = 16              # rows converted to sRGB samples at a time (see pixels)


@dataclass
class Frame:
    rgb: np.ndarray             # (h, w, 3) linear, sky included
    object_rgb: np.ndarray | None   # (h, w, 3) linear, the object's samples only: for
                                    # --alpha, None when the render was not asked for it
    coverage: np.ndarray        # (h, w) fraction of samples that hit the object
    depth: np.ndarray           # (h, w) float32 first-hit distance of the pixel's first
                                #   sample: its centre, but with --samples N jittered
    seconds: float = 0.0
    rays: int = 0
    notes: list[str] = field(default_factory=list)


class Progress:
    """One line on stderr, redrawn; only on a terminal and only after a second."""

    def __init__(self, label: str, total: int, enabled: bool, unit: str = "rays"):
        self.label, self.total, self.unit = label, total, unit
        self.enabled = enabled and sys.stderr.isatty()
        self.start = time.perf_counter()
        self.shown = 0          # the longest line written, for close to clear

    def update(self, done: int, rays: int):
        elapsed = time.perf_counter() - self.start
        if not self.enabled or elapsed < 1.0 or done == 0:
            return
        eta = elapsed * (self.total - done) / done
        rate = rays / elapsed
        # thousands where millions would read 0.01 (an export's primitives)
        speed = f"{rate / 1e6:5.2f} M" if rate >= 1e5 else f"{rate / 1e3:5.1f} k"
        line = (f"{self.label}: {100 * done / self.total:3.0f}%  {elapsed:5.1f} s, "
                f"ETA {eta:5.1f} s, {speed} {self.unit}/s ")
        sys.stderr.write("\r" + line)
        sys.stderr.flush()
        self.shown = max(self.shown, len(line))

    def then(self, what: str, total: int) -> "Progress":
        """The line of a further pass of the same job, timed from now: the first pass's
        line at 100 % while the oversampling went on for longer said "ETA 0.0 s"."""
        after = Progress(f"{self.label} {what}", total, False, self.unit)
        after.enabled = self.enabled
        return after

    def close(self):
        if self.shown:
            sys.stderr.write("\r" + " " * self.shown + "\r")
            sys.stderr.flush()


def _offsets(n: int, rng) -> np.ndarray:
    """n stratified, jittered sub-pixel positions in [0,1)^2."""
    k = int(np.ceil(np.sqrt(n)))
    cells = np.array([(i, j) for j in range(k) for i in range(k)][:n], float)
    return (cells + rng.random((n, 2))) / k


def render_frame(traced, camera: Camera, light: Lighting, width: int, height: int,
                 samples: int = 1, adaptive: bool = True, progress: Progress | None = None,
                 check=None, rows: tuple[int, int] | None = None, alpha: bool = False) -> Frame:
    """`check()` runs between batches of rows (and after each sample's pass of one) and
    may raise to stop the render.
    `rows=(y0, y1)` renders only those rows of the width x height image (a tile), with
    exactly the pixels the whole image has there. `alpha` keeps the object's own colour
    apart (Frame.object_rgb, for a transparent background): 7 MB more at 640x480, whose
    first writes cost the render 3 to 10 ms on this machine's virtual memory."""
    t0 = time.perf_counter()
    light.lod = camera.pixel_angle(height)
    light.rays[0] = 0
    refine = adaptive and samples <= 1
    top, bottom = rows or (0, height)
    # the adaptive pass compares each pixel with its neighbours: a tile renders one row
    # more on each side (its apron) so that it sees the same neighbours as the whole image
    a0, a1 = (max(0, top - 1), min(height, bottom + 1)) if refine else (top, bottom)
    band = a1 - a0
    rgb = np.zeros((band, width, 3))
    cover = np.zeros((band, width))
    depth = np.full((band, width), np.inf, dtype=np.float32)
    rng = np.random.default_rng(JITTER_SEED)     # the same jitter every render
    offs = np.array([[0.5, 0.5]]) if samples <= 1 else _offsets(samples, rng)
    obj = np.zeros((band, width, 3)) if alpha else None
    # a target may batch fewer rows: the reference tracer's Python walk takes seconds a
    # row, and its progress line moved once a batch (QA: none in 12 s)
    batch = getattr(traced, "rows_per_batch", ROWS_PER_BATCH)
    for y0 in range(0, band, batch):       # rows of the band
        y1 = min(band, y0 + batch)
        ys, xs = np.mgrid[a0 + y0:a0 + y1, 0:width]
        order = tile_order(y1 - y0, width)
        ys, xs = ys.ravel()[order], xs.ravel()[order]
        n = (y1 - y0) * width
        # the samples add up in the frame's own rows (views), not in arrays copied there
        acc = rgb[y0:y1].reshape(n, 3)
        acc_obj = obj[y0:y1].reshape(n, 3) if alpha else np.empty((0, 3))   # unused
        hit, band_depth = cover[y0:y1].reshape(n), depth[y0:y1].reshape(n)
        pixels = (ys * width + xs).astype(np.int64)
        for k, (ox, oy) in enumerate(offs):
            o, d = camera.rays(width, height, xs + ox, ys + oy)
            c, t, hits = shade(traced, light, o, d, ids=sample_ids(pixels, k, width, height),
                               check=check)
            _gather(order, c, hits.hit, t, acc, acc_obj, hit, band_depth, k == 0, alpha)
            if len(offs) > 1:
                # each sample's pass, not each batch's: with --samples 1024, --timeout 1
                # stopped after 19 s and the progress line moved every 5 s
                if progress:
                    progress.update(y0 * width + n * (k + 1) // len(offs), light.rays[0])
                if check:
                    check()
        if len(offs) > 1:       # one sample: each division would be by 1, which changes nothing
            if alpha:
                acc_obj /= np.maximum(hit, 1)[:, None]
            acc /= len(offs)
            hit /= len(offs)
        if progress:
            progress.update(y1 * width, light.rays[0])
        if check:
            check()
    if progress:
        progress.close()
    if refine:
        _refine(traced, camera, light, rgb, obj, cover, rng, height, a0, (top - a0, bottom - a0),
                check, progress)
    keep = slice(top - a0, bottom - a0)
    return Frame(rgb[keep], None if obj is None else obj[keep], cover[keep], depth[keep],
                 time.perf_counter() - t0, light.rays[0])


@cached_jit(error_model="numpy", nogil=True)
def _gather(order, c, hit, t, acc, acc_obj, hits, depth, first, alpha):
    """A batch's sample results, in tile order, added to its pixels, row-major: colour,
    with `alpha` colour where the object is hit, hits, and with `first` the depth.
    numpy's scattered += took 3 ms of every batch. Adds 0.0 + x and x * 1.0 or 0.0 as
    numpy did: the same bits."""
    for i in range(order.shape[0]):
        p = order[i]
        h = 1.0 if hit[i] else 0.0
        for a in range(3):
            acc[p, a] += c[i, a]
            if alpha:
                acc_obj[p, a] += c[i, a] * h
        hits[p] += h
        if first:
            depth[p] = t[i] if hit[i] else np.inf


def _refine(traced, camera, light, rgb, obj, cover, rng, height, a0, keep, check=None,
            progress=None):
    """The paper's adaptive oversampling: more samples only where a pixel differs from
    a neighbour, so edges are smooth and flat areas cost nothing extra. The arrays hold
    rows a0... of the image; only the rows `keep` (band rows) are refined. obj None: the
    render keeps no object-only colour (no --alpha)."""
    _, w = cover.shape
    s = to_srgb(rgb)
    diff = np.zeros(cover.shape)
    for axis in (0, 1):
        delta = np.abs(np.diff(s, axis=axis)).max(axis=2)
        pad = [(0, 0), (0, 0)]
        pad[axis] = (0, 1)
        diff = np.maximum(diff, np.pad(delta, pad))
        pad[axis] = (1, 0)
        diff = np.maximum(diff, np.pad(delta, pad))
    diff[:keep[0]] = diff[keep[1]:] = 0
    ys, xs = np.nonzero(diff > ADAPTIVE_THRESHOLD)
    blocks = block_order(ys, xs, TILE)                 # as tile_order, and for its reason
    offs = _offsets(ADAPTIVE_SAMPLES, rng)
    bar = progress.then("oversampling", len(ys)) if progress else None
    rays0 = light.rays[0]
    batch = getattr(traced, "refine_batch", REFINE_BATCH)      # as render_frame's rows
    for c0 in range(0, len(ys), batch):
        chunk = blocks[c0:c0 + batch]
        _oversample(traced, camera, light, rgb, obj, cover, height, a0, offs,
                    ys[chunk], xs[chunk], check)
        if bar:
            bar.update(c0 + len(chunk), light.rays[0] - rays0)
        if check:
            check()
    if bar:
        bar.close()


def _oversample(traced, camera, light, rgb, obj, cover, height, a0, offs, ys, xs,
                check=None):
    """Pixels (ys, xs) of the band get the samples `offs` more, averaged with the one
    they have. A pixel's samples are traced side by side, in one packet: packets of
    sample k alone, with the pixels sparse, took three times as long per ray (the
    terrain at 9: 84,000 pixels refined, more time than the whole first pass)."""
    _, w = cover.shape
    m = len(offs)
    acc = rgb[ys, xs] * 1.0
    hit = cover[ys, xs] * 1.0
    acc_obj = obj[ys, xs] * hit[:, None] if obj is not None else None
    pixels = ((ys + a0) * w + xs).astype(np.int64)
    o, d = camera.rays(w, height, (xs[:, None] + offs[:, 0]).ravel(),
                       (ys[:, None] + a0 + offs[:, 1]).ravel())
    ids = sample_ids(pixels[:, None], 1 + np.arange(m), w, height).ravel()
    c, _, hits = shade(traced, light, o, d, ids=ids, check=check)
    c, covered = c.reshape(len(ys), m, 3), hits.hit.reshape(len(ys), m)
    for k in range(m):          # sample after sample, as they were added before: the same bits
        acc += c[:, k]
        if obj is not None:
            acc_obj += c[:, k] * covered[:, k, None]
        hit += covered[:, k]
    rgb[ys, xs] = acc / (1 + m)
    if obj is not None:
        obj[ys, xs] = acc_obj / np.maximum(hit, 1)[:, None]
    cover[ys, xs] = hit / (1 + m)


def tile_order(rows: int, width: int) -> np.ndarray:
    """The row-major pixel indices of a rows x width band, TILE x TILE block after block.
    Neighbouring rays enter the same patches: traced together they find each other's
    calculated states in a worker's cache, which rows of the whole width would evict
    (the terrain at 9 renders 10 to 15 % faster)."""
    return _blocks(rows, width, TILE)


@functools.lru_cache(maxsize=4)
def _blocks(rows: int, width: int, tile: int) -> np.ndarray:
    ys, xs = np.mgrid[0:rows, 0:width]
    order = block_order(ys.ravel(), xs.ravel(), tile)
    order.flags.writeable = False       # shared by every batch of that shape
    return order


def block_order(ys: np.ndarray, xs: np.ndarray, tile: int) -> np.ndarray:
    """The indices that take pixels given row after row block after block; lexsort is
    stable, so a block keeps their order."""
    return np.lexsort((xs // tile, ys // tile))


def sample_ids(pixels: np.ndarray, k: int, width: int, height: int) -> np.ndarray:
    """Sample k of each pixel, numbered for shade's ambient occlusion pattern: the same
    number whatever the batch or the thread, a different one for every sample."""
    return pixels + np.int64(k) * (width * height)


def to_srgb(linear: np.ndarray) -> np.ndarray:
    # in place where it can be: whole-image temporaries were the peak of a render's memory
    x = np.clip(linear, 0.0, 1.0)
    low = x <= 0.0031308
    out = np.power(x, 1 / 2.4)
    out *= 1.055
    out -= 0.055
    x *= 12.92
    np.copyto(out, x, where=low)
    return out


def pixels(frame: Frame, alpha: bool) -> np.ndarray:
    """The PNG's samples: (h, w, 3) uint8 sRGB, or (h, w, 4) with --alpha."""
    if alpha and frame.object_rgb is None:
        raise ValueError("a transparent background needs the frame rendered with alpha=True")
    linear = frame.object_rgb if alpha else frame.rgb
    srgb = np.empty(linear.shape, np.uint8)
    # a band at a time: whole-image float temporaries are fresh pages for every image
    # (glibc maps blocks this large anew each time), 7.4 MB each at 640x480, and their
    # faults took longer than the arithmetic; a band's stay in the heap and the caches
    for y in range(0, len(linear), SRGB_BAND):
        band = to_srgb(linear[y:y + SRGB_BAND])
        band *= 255
        srgb[y:y + SRGB_BAND] = np.round(band, out=band)
    if not alpha:
        return srgb
    # the background is transparent: colour where the object covers the pixel
    a = np.round(np.clip(frame.coverage, 0, 1) * 255).astype(np.uint8)
    return np.dstack([srgb, a])


def save_png(f, samples: np.ndarray):
    """Encode (h, w, 3|4) uint8 samples to the open binary file f. Pillow writes the
    same bytes to any file object, so a tiled image equals the one written at once."""
    from PIL import Image, PngImagePlugin  # noqa: F401 (registers ".png")
    img = Image.fromarray(samples, "RGBA" if samples.shape[2] == 4 else "RGB")
    # The writer is chosen by the name, not by format="PNG": a format makes Pillow import
    # four more plugins first (preinit: BMP, GIF, JPEG, PPM), 4 of the 23 ms a 640x480
    # PNG took
    buf = io.BytesIO()
    buf.name = "image.png"
    img.save(buf, optimize=False, compress_level=PNG_LEVEL)
    f.write(buf.getbuffer())


def png_bytes(frame: Frame, alpha: bool) -> bytes:
    buf = io.BytesIO()
    save_png(buf, pixels(frame, alpha))
    return buf.getvalue()


def write_png(path: Path, frame: Frame, alpha: bool = False):
    write_atomic(path, png_bytes(frame, alpha))


def depth_bytes(frame: Frame) -> bytes:
    buf = io.BytesIO()
    np.save(buf, frame.depth.astype(np.float32))
    return buf.getvalue()


def write_depth(path: Path, frame: Frame):
    write_atomic(path, depth_bytes(frame))
