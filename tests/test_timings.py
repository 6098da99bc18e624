"""`pcsg render --timings`: the phases of a render, and the process's start before them."""
import re
import subprocess
import sys
import time

from pcsg.cli import main

from .conftest import GRAMMARS, ROOT

ROW = re.compile(r"^  (\S+) +([\d.]+) s(?:  (.*))?$")


def rows(report: str, name: str) -> list[tuple[str, float, str]]:
    """The rows of the report for file `name`, in order."""
    lines = report.splitlines()
    start = lines.index(f"{name}: where the time went (wall clock)")
    out = []
    for line in lines[start + 1:]:
        m = ROW.match(line)
        if not m:
            break
        out.append((m.group(1), float(m.group(2)), m.group(3) or ""))
    return out


def summary_rays(stdout: str) -> tuple[float, float]:
    """(render seconds, M rays/s) of the summary line."""
    m = re.search(r", ([\d.]+) s, ([\d.]+) M rays/s", stdout)
    return float(m.group(1)), float(m.group(2))


def test_the_command_times_its_start_and_every_phase(tmp_path):
    """In its own process the report begins with the interpreter and the imports, and its
    total is the life of the process: not longer than this test waited for it, nor much
    shorter. The render row repeats the summary line's figures."""
    out = tmp_path / "s.png"
    began = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "pcsg", "render", "grammars/sierpinski.pcsg",
                        "--set", "c=3", "--size", "64x48", "-o", str(out), "--timings", "-q"],
                       cwd=ROOT, capture_output=True, text=True, timeout=600)
    waited = time.perf_counter() - began
    assert r.returncode == 0, r.stderr
    table = rows(r.stderr, "grammars/sierpinski.pcsg")
    labels = [k for k, _, _ in table]
    assert labels[:3] == ["interpreter", "imports", "compile"], labels
    phases = [k for k in labels if k != "other"]
    assert phases == ["interpreter", "imports", "compile", "bounds", "kernels", "render", "PNG",
                      "total"]
    seconds = dict((k, s) for k, s, _ in table)
    assert all(s >= 0 for s in seconds.values())
    # the process's start time in /proc is to the clock tick (10 ms)
    assert seconds["total"] <= waited + 0.02
    assert seconds["total"] >= 0.5 * waited, (seconds["total"], waited)
    assert seconds["imports"] > 0.05        # numpy and numba alone take longer
    _, rate = summary_rays(r.stdout)
    render_note = dict((k, n) for k, _, n in table)["render"]
    assert render_note.endswith(f"{rate:.2f} M rays/s"), (render_note, r.stdout)
    assert out.stat().st_size > 0


def test_in_process_the_report_holds_the_phases_of_each_file(capsys, tmp_path):
    """Called as a function (no process start of its own to time), each file's report
    holds its phases, and its total is their sum."""
    files = [GRAMMARS / "sierpinski.pcsg", GRAMMARS / "menger_sponge.pcsg"]
    code = main(["render", *map(str, files), "--set", "c=2", "--size", "40x30", "-o",
                 str(tmp_path), "--timings", "-q"])
    out, err = capsys.readouterr()
    assert code == 0, err
    for path in files:
        table = rows(err, str(path))
        labels = [k for k, _, _ in table]
        assert "interpreter" not in labels and "imports" not in labels
        assert labels == ["compile", "bounds", "kernels", "render", "PNG", "total"]
        total = table[-1][1]
        assert abs(total - sum(s for _, s, _ in table[:-1])) < 0.002 + 1e-3 * len(table)
    assert out.count("M rays/s") == 2


def test_timings_need_a_render_in_this_process(capsys, tmp_path):
    code = main(["render", str(GRAMMARS / "sierpinski.pcsg"), "--tiles", "2", "--timings",
                 "-o", str(tmp_path / "s.png")])
    _, err = capsys.readouterr()
    assert code == 2
    assert "--timings times renders in this process" in err
