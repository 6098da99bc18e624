"""What an output directory already holds, so that a rerun of an interrupted batch,
sweep or animation renders only what is missing.

A manifest beside the PNGs records, per file, a key (a hash of pcsg's own sources, the
grammar's text and every option that changes pixels) and the hash of the bytes
written. A file counts as done only when both still match and Pillow reads it in
full, so a truncated or edited PNG, an edited grammar or a changed option renders
again. The PNG itself stays byte for byte what a plain render writes (no text chunk
in it)."""
from __future__ import annotations

import contextlib
import dataclasses
import functools
import hashlib
import json
import os
import time
from pathlib import Path

from .output import write_atomic

MANIFEST = ".pcsg-done.json"
NOT_PIXELS = ("quiet", "timeout", "depth")      # options that never change the PNG's bytes
SAVE_EVERY = 1.0                # seconds between the manifest's writes while records come


def output_key(source: str, opts) -> str:
    """The key of what a render of the grammar text `source` with options `opts` writes
    (an animation frame's t and camera are in its options)."""
    fields = {k: v for k, v in dataclasses.asdict(opts).items() if k not in NOT_PIXELS}
    blob = json.dumps([code_digest(), source, fields], sort_keys=True, default=str)
    return hashlib.sha256(blob.encode("utf-8")).hexdigest()


@functools.cache
def code_digest(package: Path = Path(__file__).resolve().parent) -> str:
    """A hash of every source file of pcsg: frames an older pcsg rendered are rendered
    again after an upgrade or a change, where its version number, which no commit moves,
    kept them (the gallery's animation needed --force)."""
    h = hashlib.sha256()
    for path in sorted(package.rglob("*.py")):
        h.update(path.relative_to(package).as_posix().encode() + b"\0" + path.read_bytes())
    return h.hexdigest()


def _sha(path: Path) -> str | None:
    try:
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()
    except OSError:
        return None


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
        # what keeps it from being written (a directory of its name), said before rendering
        self.problem = (f"{self.path} is not a file: the list of images made goes there; "
                        f"move it away" if self.path.exists() and not self.path.is_file()
                        else None)
        self.entries = self._read()
        # what this run changed, merged into the file as it is at each save: two sweeps
        # into one directory each wrote the entries they had read, and the last to save
        # dropped the other's (its images were rendered again)
        self._recorded: dict[str, dict] = {}
        self._dropped: set[str] = set()
        self._saved, self._unsaved = time.monotonic(), False

    def _read(self) -> dict[str, dict]:
        try:
            entries = json.loads(self.path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            entries = {}                # none yet, or unreadable: everything renders
        return {str(k): v for k, v in entries.items() if isinstance(v, dict)} \
            if isinstance(entries, dict) else {}

    def complete(self, out: Path, key: str) -> bool:
        entry = self.entries.get(Path(out).name)
        return (entry is not None and entry.get("key") == key
                and entry.get("sha256") == _sha(out) and _valid_png(out))

    def record(self, out: Path, key: str):
        """Saved with the first record SAVE_EVERY seconds after the last save, and at
        the end (flush, on every way out but a kill): the whole file written after every
        frame took 137 ms a frame at 20,000 entries, and a long animation's parent fell
        behind its workers. A record a kill loses (one that came within the second, with
        none after it) only renders its file again."""
        name = Path(out).name
        self.entries[name] = self._recorded[name] = {"key": key, "sha256": _sha(out)}
        self._dropped.discard(name)
        self._unsaved = True
        if time.monotonic() - self._saved >= SAVE_EVERY:
            self.save()

    def flush(self):
        if self._unsaved:
            self.save()

    def forget_others(self, keep: set[str], mine=lambda name: True) -> list[str]:
        """Drop the entries of files not in `keep` (an animation shorter than the last
        run's) of those that `mine(name)` says the caller made; returns their names, so
        that the files can go too. The others are another command's (a sweep's or a
        batch's into the same directory: an animation deleted them)."""
        stale = sorted(name for name in self.entries if name not in keep and mine(name))
        for name in stale:
            del self.entries[name]
            self._recorded.pop(name, None)
            self._dropped.add(name)
        if stale:
            self.save()
        return stale

    def save(self):
        """This run's records and drops over the file as another run may have left it,
        the read and the write one step under a lock of the directory where there is
        flock (POSIX)."""
        self._saved, self._unsaved = time.monotonic(), False
        with _locked(self.path.parent):
            entries = self._read()
            for name in self._dropped:
                entries.pop(name, None)
            entries.update(self._recorded)
            write_atomic(self.path, json.dumps(entries, indent=1, sort_keys=True)
                         .encode("utf-8"))
        self.entries = entries
        self._recorded, self._dropped = {}, set()


@contextlib.contextmanager
def _locked(directory: Path):
    try:
        import fcntl
        fd = os.open(directory, os.O_RDONLY)
    except (ImportError, OSError):      # no flock (Windows), or a directory we cannot open
        yield
        return
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)
