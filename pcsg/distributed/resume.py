"""Restarting a batch: outputs already made from the same text and options are skipped.

A manifest beside the outputs records, per PNG, a key (hash of the pcsg version, the
grammar's text and every option that changes pixels) and the hash of the bytes written.
A PNG is skipped only when both match and Pillow reads it in full; the PNG itself stays
byte for byte what a single-machine render writes (no text chunk in it)."""
from __future__ import annotations

import dataclasses
import hashlib
import json
from pathlib import Path

from ..output import write_atomic

MANIFEST = ".pcsg-done.json"
NOT_PIXELS = ("quiet", "timeout", "depth")      # options that never change the PNG's bytes


def job_key(source: str, opts) -> str:
    from .. import __version__
    fields = {k: v for k, v in dataclasses.asdict(opts).items() if k not in NOT_PIXELS}
    blob = json.dumps([__version__, source, fields], sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()


def _valid_png(path: Path) -> bool:
    from PIL import Image
    try:
        with Image.open(path) as im:
            im.verify()
        with Image.open(path) as im:        # verify() leaves the image unusable: load anew
            im.load()
        return True
    except Exception:   # noqa: BLE001 -- whatever Pillow dislikes, the image is rendered again
        return False


class Manifest:
    def __init__(self, directory: Path):
        self.path = Path(directory) / MANIFEST
        try:
            self.entries = json.loads(self.path.read_text())
            if not isinstance(self.entries, dict):
                self.entries = {}
        except (OSError, ValueError):
            self.entries = {}

    def complete(self, out: Path, key: str) -> bool:
        entry = self.entries.get(Path(out).name)
        if not isinstance(entry, dict) or entry.get("key") != key:
            return False
        try:
            data = Path(out).read_bytes()
        except OSError:
            return False
        return hashlib.sha256(data).hexdigest() == entry.get("sha256") and _valid_png(out)

    def record(self, out: Path, key: str):
        digest = hashlib.sha256(Path(out).read_bytes()).hexdigest()
        self.entries[Path(out).name] = {"key": key, "sha256": digest}
        write_atomic(self.path, json.dumps(self.entries, indent=1, sort_keys=True).encode())
