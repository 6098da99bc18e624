"""Renders on a real Dask cluster: two worker processes on loopback (LocalCluster).

Every output is compared byte for byte with the same render in this one process."""
import os
import signal
from pathlib import Path

import pytest

pytest.importorskip("distributed")
from distributed import Client, LocalCluster  # noqa: E402

from pcsg.cli import main  # noqa: E402
from pcsg.distributed.batch import Batch, Job  # noqa: E402
from pcsg.distributed.cluster import DaskRunner  # noqa: E402
from pcsg.distributed.sweep import sweep_outputs  # noqa: E402
from pcsg.render.job import Options  # noqa: E402

from .conftest import GRAMMARS, sigint_reaches_children  # noqa: E402

pytestmark = pytest.mark.cluster
SAMPLES = sorted(str(p) for p in GRAMMARS.glob("*.pcsg"))
SIERPINSKI = str(GRAMMARS / "sierpinski.pcsg")


def local_cluster():
    return LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                        dashboard_address=":0", env={"NUMBA_NUM_THREADS": "1"})


@pytest.fixture(scope="module")
def scheduler():
    with local_cluster() as cluster:
        yield cluster.scheduler_address


def render_here(tmp_path: Path, files, *options) -> Path:
    out = tmp_path / "here"
    out.mkdir(exist_ok=True)
    for f in files:
        assert main(["render", f, "-o", str(out / (Path(f).stem + ".png")), "-q",
                     *options]) == 0
    return out


def test_batch_of_the_samples(capsys, tmp_path, scheduler):
    bad = tmp_path / "broken.pcsg"
    bad.write_text("sphere ∪\n∪ cube\n")
    out = tmp_path / "cluster"
    code = main(["render", *SAMPLES, str(bad), "-o", str(out), "--size", "64x48",
                 "--scheduler", scheduler])
    captured = capsys.readouterr()
    assert code == 1                         # the broken file fails; the others are written
    assert captured.err.count(f"{bad}:2:1: error") == 1
    assert f"rendered {len(SAMPLES)} of {len(SAMPLES) + 1} files" in captured.out
    per_worker = captured.err.split("tasks per worker: ")[1].splitlines()[0]
    assert sum(int(w.rsplit(" ", 1)[1]) for w in per_worker.split(", ")) == len(SAMPLES) + 1
    here = render_here(tmp_path, SAMPLES, "--size", "64x48")
    for f in SAMPLES:
        name = Path(f).stem + ".png"
        assert (out / name).read_bytes() == (here / name).read_bytes(), name

    # restarted: nothing left to do but the broken file
    assert main(["render", *SAMPLES, "-o", str(out), "--size", "64x48", "-q",
                 "--scheduler", scheduler]) == 0
    assert f"skipped {len(SAMPLES)} already complete" in capsys.readouterr().out


def test_tiled_image_equals_the_single_process_render(capsys, tmp_path, scheduler):
    for f, extra in ((SIERPINSKI, []), (str(GRAMMARS / "fractal_garden.pcsg"), ["--alpha"])):
        out = tmp_path / "tiled.png"
        assert main(["render", f, "-o", str(out), "--size", "96x72", "--tiles", "9", "-q",
                     "--scheduler", scheduler, "--force", *extra]) == 0
        here = render_here(tmp_path, [f], "--size", "96x72", *extra)
        assert out.read_bytes() == (here / (Path(f).stem + ".png")).read_bytes(), f
        assert "9 tiles" in capsys.readouterr().out
    assert not list(tmp_path.glob(".*.tiles"))        # no scratch file left behind


class KillingRunner(DaskRunner):
    """Kills (SIGKILL) a worker process that holds tasks, as soon as the first result
    is in: the scheduler must run its tasks elsewhere, and the nanny starts a new one."""
    killed = None

    def run(self, fn, items):
        pids = self.client.run(os.getpid)
        for n, result in enumerate(super().run(fn, items)):
            if n == 0:
                busy = [w for w, tasks in self.client.processing().items() if tasks]
                assert busy, "the batch was over before a worker could be killed"
                self.killed = busy[0]
                os.kill(pids[self.killed], signal.SIGKILL)
            yield result


def test_a_worker_killed_mid_batch_loses_nothing(capsys, tmp_path):
    out = tmp_path / "sweep"
    out.mkdir()
    values = [float(c) for c in range(1, 11)]
    outputs = sweep_outputs(SIERPINSKI, out, "c", values)
    jobs = [Job(SIERPINSKI, o, Options(size=(160, 120), overrides={"c": c}, quiet=True))
            for c, o in zip(values, outputs)]
    with local_cluster() as cluster, Client(cluster) as client:
        runner = KillingRunner(client)
        batch = Batch(manifest=True)
        batch.run(runner, batch.plan(jobs))
    assert runner.killed is not None
    assert batch.failed == [] and batch.done == len(jobs)
    assert "a lost worker" not in capsys.readouterr().err
    here = tmp_path / "here"
    assert main(["sweep", SIERPINSKI, "--set", "c=1..10", "--size", "160x120",
                 "-o", str(here), "-q"]) == 0
    for o in outputs:
        assert o.read_bytes() == (here / o.name).read_bytes(), o.name


def test_sweep_on_a_local_cluster_of_its_own(capfd, tmp_path):
    # --workers starts and stops its own cluster; nothing of Dask's logging reaches the
    # user, not even from worker processes racing the shutdown (capfd: their stderr too)
    out = tmp_path / "sweep"
    assert main(["sweep", SIERPINSKI, "--set", "c=1..4", "--size", "48x36", "-o", str(out),
                 "--workers", "2"]) == 0
    captured = capfd.readouterr()
    assert "rendered 4 of 4 images" in captured.out
    assert "Traceback" not in captured.err and "distributed." not in captured.err
    assert captured.err.count("[") == 4 and "tasks per worker: tcp://127.0.0.1:" in captured.err
    assert main(["render", SIERPINSKI, "--set", "c=3", "--size", "48x36", "-q",
                 "-o", str(tmp_path / "c3.png")]) == 0
    assert (out / "sierpinski_c=3.png").read_bytes() == (tmp_path / "c3.png").read_bytes()


def test_ctrl_c_at_a_terminal_stops_a_cluster_render_without_the_workers_tracebacks(tmp_path):
    """A terminal's Ctrl-C reaches the whole process group: each worker of --workers
    printed the traceback of its KeyboardInterrupt beside `pcsg: interrupted`."""
    import subprocess
    import sys
    import time
    # (a suite started by a script's `cmd &` ignores SIGINT, and so would the sweep)
    with sigint_reaches_children():
        proc = subprocess.Popen(
            [sys.executable, "-m", "pcsg", "sweep", SIERPINSKI, "--set", "c=1..40", "--size",
             "320x240", "--samples", "16", "-q", "-o", str(tmp_path / "s"), "--workers",
             "2"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True,
            text=True)
    deadline = time.monotonic() + 120
    while not list((tmp_path / "s").glob("*.png")) and time.monotonic() < deadline:
        time.sleep(0.1)                 # the cluster is up and rendering
    os.killpg(proc.pid, signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "pcsg: interrupted" in err and "Traceback" not in err, err


def test_animation_frames_on_the_cluster(capsys, tmp_path, scheduler):
    """`pcsg animate --scheduler`: each frame a task; the frames and the animated PNG are
    byte for byte those of the frames rendered here, and a rerun reuses them all."""
    src = tmp_path / "ball.pcsg"
    src.write_text("#camera eye=(0,-6,3) at=(0,0,0.6) fov=40\n#light at=(3,-2,8)\n"
                   "{t = 1; r = 0.3 + 0.7*t} (paint(0.9,0.3,0.2) move(0,0,1) uscale(r) sphere ∪"
                   " paint(0.8,0.8,0.8) plane)\n")
    tiny = ["--size", "32x24", "--shadow-samples", "1", "-q", "--frames", "4"]
    here, there = tmp_path / "here", tmp_path / "there"
    assert main(["animate", str(src), "-o", str(here), "--jobs", "1", *tiny]) == 0
    assert main(["animate", str(src), "-o", str(there), "--scheduler", scheduler, *tiny]) == 0
    out = capsys.readouterr().out
    assert "4 rendered with 2 workers" in out
    names = sorted(p.name for p in here.glob("*.png"))
    assert len(names) == 5                      # four frames and the animation
    for name in names:
        assert (here / name).read_bytes() == (there / name).read_bytes(), name
    assert main(["animate", str(src), "-o", str(there), "--scheduler", scheduler, *tiny]) == 0
    assert "4 reused, 0 rendered" in capsys.readouterr().out
