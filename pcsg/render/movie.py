"""Numbered frames to one animated file: an animated PNG (lossless, shown by browsers),
or a GIF for tools that show no APNG."""
from __future__ import annotations

import io
import struct
import zlib
from fractions import Fraction
from pathlib import Path

from ..output import open_atomic, write_atomic

SIGNATURE = b"\x89PNG\r\n\x1a\n"
# chunks an APNG writes itself, or that belong to one frame's image data
OWN = {b"IHDR", b"acTL", b"fcTL", b"fdAT", b"IDAT", b"IEND"}


class FrameMismatch(ValueError):
    """A frame that an APNG cannot hold beside the first (another size or pixel format)."""


def _chunks(path: Path):
    """(type, body) of each chunk of a PNG file."""
    data = path.read_bytes()
    if not data.startswith(SIGNATURE):
        raise FrameMismatch(f"{path} is not a PNG file")
    at = len(SIGNATURE)
    while at + 8 <= len(data):
        length, kind = struct.unpack(">I4s", data[at:at + 8])
        yield kind, data[at + 8:at + 8 + length]
        at += 12 + length


def _chunk(kind: bytes, body: bytes) -> bytes:
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))


def frame_delay(fps: float) -> tuple[int, int]:
    """An APNG frame's delay, numerator and denominator of seconds (16 bits each)."""
    delay = Fraction(1 / fps).limit_denominator(65535)
    return min(delay.numerator, 65535), delay.denominator


def write_apng(frames: list[Path], out: Path, fps: float):
    """Each frame's compressed image data copied as it is, one frame in memory at a
    time: Pillow's writer held every frame decoded (10,000 frames of 640x480: 9 GB) and
    encoded each again."""
    num, den = frame_delay(fps)
    with open_atomic(out, "wb") as f:
        f.write(SIGNATURE)
        first = None
        sequence = 0
        for i, path in enumerate(frames):
            chunks = list(_chunks(path))
            kinds = [k for k, _ in chunks]
            if b"IDAT" not in kinds or kinds[0] != b"IHDR":
                raise FrameMismatch(f"{path} is not a PNG file")
            data = kinds.index(b"IDAT")
            head = [(k, b) for k, b in chunks[:data] if k == b"IHDR" or k not in OWN]
            if first is None:
                first = head
                f.write(_chunk(*head[0]))
                f.write(_chunk(b"acTL", struct.pack(">II", len(frames), 0)))   # 0: loop
                f.writelines(_chunk(k, b) for k, b in head[1:])   # gAMA, pHYs, ... (PLTE)
            elif [x for x in head if x[0] in (b"IHDR", b"PLTE")] != \
                    [x for x in first if x[0] in (b"IHDR", b"PLTE")]:
                raise FrameMismatch(f"{path} has another size or pixel format than "
                                    f"{frames[0]}")
            width, height = struct.unpack(">II", head[0][1][:8])
            f.write(_chunk(b"fcTL", struct.pack(">IIIIIHHBB", sequence, width, height, 0, 0,
                                                num, den, 0, 0)))
            sequence += 1
            for kind, body in chunks[data:]:
                if kind != b"IDAT":
                    continue
                if i == 0:
                    f.write(_chunk(b"IDAT", body))
                else:
                    f.write(_chunk(b"fdAT", struct.pack(">I", sequence) + body))
                    sequence += 1
        f.write(_chunk(b"IEND", b""))


def _load(frames: list[Path]):
    from PIL import Image
    images = []
    for p in frames:
        with Image.open(p) as im:
            images.append(im.copy())
    return images


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
