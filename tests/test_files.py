"""Files and batches: bad inputs and outputs give one clear line each, no partial PNG
is ever left, an earlier good image is never destroyed, and one failure in a batch
never stops the others."""
import os
import resource
import signal
import subprocess
import sys

import pytest

from pcsg.cli import main

from .conftest import ROOT

SPHERE = "sphere\n"
FAST = ["--size", "64x48", "-q", "--no-shadows"]


def _leftovers(directory):
    return [p.name for p in directory.iterdir() if p.name.endswith(".part")]


def test_a_directory_given_as_input_fails_alone(capsys, tmp_path):
    good = tmp_path / "good.pcsg"
    good.write_text(SPHERE, encoding="utf-8")
    (tmp_path / "dir.pcsg").mkdir()
    out = tmp_path / "out"
    code = main(["render", str(tmp_path / "dir.pcsg"), str(good), "-o", f"{out}/", *FAST])
    captured = capsys.readouterr()
    assert code == 1
    assert "dir.pcsg" in captured.err and "is a directory" in captured.err
    assert "Traceback" not in captured.err
    assert (out / "good.png").exists() and not (out / "dir.png").exists()
    assert "rendered 1 of 2 files" in captured.out


def test_an_output_directory_that_is_a_file(capsys, tmp_path):
    src = tmp_path / "s.pcsg"
    src.write_text(SPHERE, encoding="utf-8")
    blocker = tmp_path / "renders"
    blocker.write_text("not a directory", encoding="utf-8")
    code = main(["render", str(src), "-o", f"{blocker}/", *FAST])
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err     # a usage error, said before a render
    assert f"-o {blocker}/: {blocker} is a file, not a directory" in err
    assert blocker.read_text(encoding="utf-8") == "not a directory"


def test_an_output_file_in_a_missing_directory(capsys, tmp_path):
    src = tmp_path / "s.pcsg"
    src.write_text(SPHERE, encoding="utf-8")
    code = main(["render", str(src), "-o", str(tmp_path / "no" / "s.png"), *FAST])
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err      # said before anything is rendered
    assert f"the directory {tmp_path / 'no'} does not exist" in err


def _limit_file_size(limit):
    def apply():
        # a file may not grow past `limit` bytes: a write beyond fails with EFBIG, as it
        # would with ENOSPC on a full disk (SIGXFSZ ignored, or it would kill the process)
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    return apply


def test_a_write_that_fails_midway_keeps_the_earlier_image(tmp_path):
    src = tmp_path / "s.pcsg"
    src.write_text("paint(1, 0.3, 0.2) sphere ∪ move(1.5, 0, 0) cube\n", encoding="utf-8")
    first = tmp_path / "first.pcsg"
    first.write_text(SPHERE, encoding="utf-8")
    out = tmp_path / "out"
    out.mkdir()
    earlier = b"an earlier good image"
    (out / "s.png").write_bytes(earlier)
    # kernels compiled and cached first: the limited process could not write its cache
    assert main(["render", str(first), "-o", str(tmp_path / "warm.png"), *FAST]) == 0
    cmd = [sys.executable, "-m", "pcsg", "render", str(first), str(src), "-o", f"{out}/",
           "--size", "320x240", "-q", "--no-shadows"]
    # PNGs of a plain sphere at 320x240 are a few kB; allow 1 kB
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=600,
                          preexec_fn=_limit_file_size(1024))
    assert proc.returncode == 1, proc.stderr
    assert "Traceback" not in proc.stderr
    assert "s.pcsg: File too large" in proc.stderr and "first.pcsg: File too large" in \
        proc.stderr                         # both tried: the first failure stopped nothing
    assert (out / "s.png").read_bytes() == earlier
    assert not (out / "first.png").exists() and _leftovers(out) == []


def _mount(mnt, options):
    """A real tmpfs at mnt, where this machine lets us mount one (root); else skip."""
    mnt.mkdir()
    if os.geteuid() != 0 or subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs",
                                            str(mnt)], capture_output=True).returncode != 0:
        pytest.skip("cannot mount a tmpfs here (needs root)")
    return mnt


@pytest.fixture
def small_disk(tmp_path):
    yield _mount(tmp_path / "disk", "size=64k")
    subprocess.run(["umount", str(tmp_path / "disk")], check=True)


def test_an_output_directory_that_cannot_be_written(capsys, tmp_path):
    """Read-only (permissions do not stop root, who runs CI here; a read-only mount does)."""
    mnt = _mount(tmp_path / "ro", "size=64k,ro")
    try:
        src = tmp_path / "s.pcsg"
        src.write_text(SPHERE, encoding="utf-8")
        code = main(["render", str(src), "-o", str(mnt / "s.png"), *FAST])
        err = capsys.readouterr().err
        # found before the render, as a usage error (it was exit 1, after the render)
        assert code == 2 and f"-o {mnt / 's.png'}: cannot write in {mnt}: Read-only file " \
                             f"system" in err and "Traceback" not in err
        assert list(mnt.iterdir()) == []
    finally:
        subprocess.run(["umount", str(mnt)], check=True)


def test_a_full_disk_keeps_the_earlier_image(capsys, tmp_path, small_disk):
    src = tmp_path / "s.pcsg"
    src.write_text("paint(1, 0.3, 0.2) sphere ∪ move(1.5, 0, 0) cube\n", encoding="utf-8")
    earlier = small_disk / "s.png"
    earlier.write_bytes(b"an earlier good image")
    (small_disk / "filler").write_bytes(b"\0" * 56 * 1024)      # leaves ~8 kB free
    code = main(["render", str(src), "-o", str(earlier), "--size", "320x240", "-q"])
    err = capsys.readouterr().err
    assert code == 1 and "No space left on device" in err and "Traceback" not in err
    assert earlier.read_bytes() == b"an earlier good image"
    assert _leftovers(small_disk) == []


def test_an_output_through_a_symbolic_link_keeps_the_link(capsys, tmp_path):
    src = tmp_path / "s.pcsg"
    src.write_text(SPHERE, encoding="utf-8")
    real = tmp_path / "real.png"
    real.write_bytes(b"old")
    link = tmp_path / "link.png"
    link.symlink_to(real)
    assert main(["render", str(src), "-o", str(link), *FAST]) == 0
    assert link.is_symlink() and real.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert _leftovers(tmp_path) == []


def test_an_output_into_a_fifo_is_written_into_it(capsys, tmp_path):
    # a rename would leave a plain file where the pipe was, and its reader with nothing:
    # /dev/null, written by root, went the same way
    import threading
    src = tmp_path / "s.pcsg"
    src.write_text(SPHERE, encoding="utf-8")
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    got = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_bytes()), daemon=True)
    reader.start()
    assert main(["graph", str(src), "-o", str(fifo)]) == 0
    reader.join(60)
    assert fifo.is_fifo() and got and b"digraph" in got[0]
    assert _leftovers(tmp_path) == []


def test_an_output_that_is_a_directory_is_named(capsys, tmp_path):
    src = tmp_path / "s.pcsg"
    src.write_text(SPHERE, encoding="utf-8")
    (tmp_path / "adir").mkdir()
    assert main(["graph", str(src), "-o", str(tmp_path / "adir")]) == 2
    err = capsys.readouterr().err
    assert f"-o {tmp_path / 'adir'}: that is a directory; name a file in it" in err
    assert ".part" not in err
    assert _leftovers(tmp_path) == []


def test_two_files_of_one_name_are_not_written_over_each_other(capsys, tmp_path):
    for d in ("a", "b"):
        (tmp_path / d).mkdir()
        (tmp_path / d / "x.pcsg").write_text(SPHERE, encoding="utf-8")
    out = tmp_path / "out"
    a, b = str(tmp_path / "a" / "x.pcsg"), str(tmp_path / "b" / "x.pcsg")
    assert main(["render", a, b, "-o", f"{out}/", *FAST]) == 2
    assert f"{a} and {b} would both be written to {out / 'x.png'}" in capsys.readouterr().err
    assert not out.exists()
    assert main(["render", a, str(tmp_path / "a" / ".." / "a" / "x.pcsg"), "-o", f"{out}/",
                 *FAST]) == 2
    assert "is given twice" in capsys.readouterr().err


def test_an_output_to_dev_stdout_reaches_a_pipe(tmp_path):
    # its real path is /proc/PID/fd/pipe:[N], where no temporary file can be made
    src = tmp_path / "s.pcsg"
    src.write_text(SPHERE, encoding="utf-8")
    r = subprocess.run([sys.executable, "-m", "pcsg", "graph", str(src), "-o", "/dev/stdout"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "digraph" in r.stdout


def test_an_endless_device_or_pipe_is_refused_at_the_size_limit():
    """/dev/zero, or a pipe (`<(...)`), has size 0: the limit was checked against that,
    and the read went on until the system's memory ran out (24 GB, then the OOM killer).
    In a child process held to 1 GiB of memory, so that a regression fails this test
    rather than the machine."""
    program = ("import resource; resource.setrlimit(resource.RLIMIT_AS, (1 << 30, 1 << 30))\n"
               "from pcsg.language.errors import PcsgError\n"
               "from pcsg.language.files import read_source_text\n"
               "try:\n"
               "    read_source_text('/dev/zero')\n"
               "except PcsgError as e:\n"
               "    print(e.diagnostics[0].format())\n")
    p = subprocess.run([sys.executable, "-c", program], capture_output=True, text=True,
                       timeout=120)
    assert p.returncode == 0, p.stderr
    assert "/dev/zero: error: file is more than 8,388,608 bytes" in p.stdout, p.stdout


@pytest.mark.parametrize("command", ["sweep", "animate"])
def test_a_grammar_from_a_pipe_is_read_once(tmp_path, command):
    """sweep and animate read their file twice, checked and then rendered: from a pipe
    the second read was empty, and the images failed as "cannot set 'c': it is not an
    initial parameter" and "no axiom". Each image is the render of the same file read
    from disk (a camera and light of its own: animate's frames keep those of t = 1)."""
    text = ("#camera eye=(0, -6, 3) at=(0, 0, 0) fov=40\n#light at=(3, -2, 8)\n"
            "{t = 1; c = 1 + t} uscale(c / 3) sphere ∪ move(0, 0, -1) plane\n")
    src = tmp_path / "stdin.pcsg"
    src.write_text(text, encoding="utf-8")
    tiny = ["--size", "16x12", "--shadow-samples", "1", "-q"]
    args = ["sweep", "/dev/stdin", "--set", "c=1..2"] if command == "sweep" else \
        ["animate", "/dev/stdin", "--frames", "2"]
    r = subprocess.run([sys.executable, "-m", "pcsg", *args, *tiny, "-o", str(tmp_path / "o")],
                       input=text, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    made = sorted((tmp_path / "o").glob("*_*.png"))
    assert [p.name for p in made] == (["stdin_c=1.png", "stdin_c=2.png"] if command == "sweep"
                                      else ["frame_0000.png", "frame_0001.png"])
    for value, png in zip(("1", "2") if command == "sweep" else ("0", "1"), made):
        again = tmp_path / f"again_{value}.png"
        main(["render", str(src), "--set", f"{'c' if command == 'sweep' else 't'}={value}",
              *tiny, "-o", str(again)])
        assert again.read_bytes() == png.read_bytes()


def test_depths_to_standard_output_and_an_image_named_dash(tmp_path):
    """--depth /dev/stdout was told to name the file stdout.npy (-o /dev/stdout is written
    into), and `-o -` to name it -.png."""
    src = tmp_path / "s.pcsg"
    src.write_text(SPHERE, encoding="utf-8")
    r = subprocess.run([sys.executable, "-m", "pcsg", "render", str(src), "--size", "8x6",
                        "-o", str(tmp_path / "s.png"), "--depth", "/dev/stdout"],
                       capture_output=True, timeout=120)
    assert r.returncode == 0, r.stderr
    # the array itself, as --depth FILE.npy writes it (the summary went to stderr)
    assert main(["render", str(src), "--size", "8x6", "-o", str(tmp_path / "t.png"),
                 "--depth", str(tmp_path / "d.npy"), "-q"]) == 0
    assert r.stdout == (tmp_path / "d.npy").read_bytes() and r.stdout.startswith(b"\x93NUMPY")
    r = subprocess.run([sys.executable, "-m", "pcsg", "render", str(src), "-o", "-"],
                       capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert r.returncode == 2 and "-o -: pcsg writes PNG images to files; to a pipe, give " \
        "-o /dev/stdout" in r.stderr and not (tmp_path / "-.png").exists()
