"""`pcsg render --timings`: where one render's wall time goes, phase by phase.

The phases are the ones a render runs through in order (compile, bounds, render, PNG),
each timed on the wall clock; a kernel loads from numba's cache in the phase that first
calls it. The command
(cli.run) also notes how long the process took to reach them: the interpreter's own
start and the imports (numpy, numba and pcsg's modules), from the process's start
time in /proc, so on Linux only."""
from __future__ import annotations

import os
import time
from contextlib import contextmanager

STARTUP: tuple[float, float] | None = None     # (interpreter, imports), set by cli.run


def process_age() -> float | None:
    """Seconds since this process started, to the kernel's clock tick (10 ms); None
    where /proc does not say."""
    try:
        with open("/proc/self/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()     # the name may hold spaces
        started = int(fields[19]) / os.sysconf("SC_CLK_TCK")   # field 22, since boot
        return max(0.0, time.clock_gettime(time.CLOCK_BOOTTIME) - started)
    except (OSError, ValueError, IndexError, AttributeError):
        return None


def note_startup(imports_began: float) -> None:
    """Called once by the command before it runs: how long the interpreter took to
    start, and the imports since `imports_began` (a perf_counter reading)."""
    global STARTUP
    age = process_age()
    imports = time.perf_counter() - imports_began
    if age is not None and age >= imports:
        STARTUP = (age - imports, imports)


class Timings:
    """The phases of one file's render, in the order they ran."""

    def __init__(self, startup: bool = False):
        self.rows: list[tuple[str, float, str]] = []
        self.began = time.perf_counter()
        self.startup = STARTUP if startup else None

    @contextmanager
    def phase(self, label: str, note: str = ""):
        t = time.perf_counter()
        try:
            yield
        finally:
            self.rows.append((label, time.perf_counter() - t, note))

    def annotate(self, label: str, note: str) -> None:
        """Set the note of the phase `label` once its figures are known."""
        self.rows = [(k, s, note if k == label else n) for k, s, n in self.rows]

    def report(self, name: str) -> str:
        rows = []
        total = sum(s for _, s, _ in self.rows)
        if self.startup is not None:
            interpreter, imports = self.startup
            rows += [("interpreter", interpreter, "Python's own start"),
                     ("imports", imports, "numpy, numba, pcsg's modules and kernels' helpers")]
            total = interpreter + imports + (time.perf_counter() - self.began)
        rows += self.rows
        other = total - sum(s for _, s, _ in rows)
        if other > 0.0005:
            rows.append(("other", other, "between the phases"))
        rows.append(("total", total, "since the process started" if self.startup else
                     "of the phases above"))
        width = max(len(k) for k, _, _ in rows)
        lines = [f"{name}: where the time went (wall clock)"]
        lines += [f"  {k:<{width}}  {s:7.3f} s" + (f"  {n}" if n else "") for k, s, n in rows]
        return "\n".join(lines)
