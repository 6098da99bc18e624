"""Numbered frames to one animated file: an animated PNG (lossless, shown by browsers),
or a GIF for tools that show no APNG."""
from __future__ import annotations

import io
from pathlib import Path

from ..output import write_atomic


def _load(frames: list[Path]):
    from PIL import Image
    images = []
    for p in frames:
        with Image.open(p) as im:
            images.append(im.copy())
    return images


def write_apng(frames: list[Path], out: Path, fps: float):
    images = _load(frames)
    buf = io.BytesIO()
    images[0].save(buf, format="PNG", save_all=True, append_images=images[1:],
                   duration=1000 / fps, loop=0)
    write_atomic(out, buf.getvalue())


def write_gif(frames: list[Path], out: Path, fps: float):
    """One palette for all frames (from all of them), so colours do not flicker from
    frame to frame; dithered, since a tree against a sky gradient has more than 256."""
    from PIL import Image
    images = [im.convert("RGB") for im in _load(frames)]
    w, h = images[0].size
    scale = max(1, int((w * h * len(images) / 2_000_000) ** 0.5))  # a bounded sample
    small = [im.reduce(scale) for im in images]
    sheet = Image.new("RGB", (small[0].width, small[0].height * len(small)))
    for i, im in enumerate(small):
        sheet.paste(im, (0, i * small[0].height))
    palette = sheet.quantize(colors=256, method=Image.Quantize.MEDIANCUT)
    indexed = [im.quantize(palette=palette, dither=Image.Dither.FLOYDSTEINBERG) for im in images]
    buf = io.BytesIO()
    indexed[0].save(buf, format="GIF", save_all=True, append_images=indexed[1:],
                    duration=round(1000 / fps), loop=0)
    write_atomic(out, buf.getvalue())
