"""What an animation's output directory already holds: a manifest records, per frame,
a key of everything the frame's pixels depend on and the hash of the PNG written for it.
A rerun reuses a frame only when both still match, so a truncated or edited PNG, an
edited grammar or a changed option renders the frame again."""
from __future__ import annotations

import dataclasses
import hashlib
import json
from pathlib import Path

from ..output import write_atomic

MANIFEST = "manifest.json"
# options that change whether or how long a frame renders, never its pixels
NOT_IN_KEY = ("quiet", "timeout", "depth")


def frame_key(source_sha: str, opts) -> str:
    """A hash of the grammar text and of every option that shapes the frame (the
    frame's own t and camera included: they are in `opts`)."""
    from .. import __version__
    fields = {k: v for k, v in dataclasses.asdict(opts).items() if k not in NOT_IN_KEY}
    text = json.dumps({"pcsg": __version__, "source": source_sha, "options": fields},
                      sort_keys=True)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def file_sha(path: Path) -> str | None:
    try:
        return hashlib.sha256(path.read_bytes()).hexdigest()
    except OSError:
        return None


class Manifest:
    def __init__(self, directory: Path):
        self.path = directory / MANIFEST
        self.frames: dict[str, dict] = {}
        try:
            data = json.loads(self.path.read_text(encoding="utf-8"))
            self.frames = {str(k): v for k, v in data["frames"].items() if isinstance(v, dict)}
        except (OSError, ValueError, KeyError, TypeError, AttributeError):
            pass                # none yet, or unreadable: every frame renders

    def is_done(self, png: Path, key: str) -> bool:
        entry = self.frames.get(png.name)
        return bool(entry) and entry.get("key") == key and entry.get("png") == file_sha(png)

    def record(self, png: Path, key: str):
        self.frames[png.name] = {"key": key, "png": file_sha(png)}
        self.save()

    def forget_others(self, keep: set[str]) -> list[str]:
        """Drop the entries of frames not in `keep` (a shorter animation than the last
        run's); returns their names, so that their files can go too."""
        stale = sorted(name for name in self.frames if name not in keep)
        for name in stale:
            del self.frames[name]
        if stale:
            self.save()
        return stale

    def save(self):
        write_atomic(self.path, json.dumps({"frames": self.frames}, indent=1,
                                           sort_keys=True).encode("utf-8"))
