"""`pcsg animate`: frames over t and a Bezier camera path, the same bytes as `pcsg render`
of each frame at any job count, resuming without re-rendering finished frames."""
import json
import os
import re
import shutil
import signal
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from pcsg.cli import main
from pcsg.render.path import bezier, parse_points

from .conftest import GRAMMARS, ROOT, sigint_reaches_children

# a ball that grows with t, and its shadow
BALL = """#camera eye=(0,-6,3) at=(0,0,0.6) fov=40
#light at=(3,-2,8)
{t = 1; r = 0.3 + 0.7*t} (paint(0.9,0.3,0.2) move(0,0,1) uscale(r) sphere ∪
                          paint(0.8,0.8,0.8) plane)
"""
# a quadratic control polygon whose de Casteljau points are exact binary fractions
PATH = "0,-8,2 4,-8,2 4,-4,2"
EYES = ["0,-8,2", "3,-7,2", "4,-4,2"]           # at t = 0, 1/2, 1
TINY = ["--size", "32x24", "--shadow-samples", "1", "-q"]


@pytest.fixture
def ball(tmp_path):
    p = tmp_path / "ball.pcsg"
    p.write_text(BALL, encoding="utf-8")
    return p


def animate(capsys, src, out, *extra):
    code = main(["animate", str(src), "-o", str(out), *TINY, *extra])
    stdout, stderr = capsys.readouterr()
    return code, stdout, stderr


def frames(out):
    return sorted(out.glob("frame_*.png"))


def test_bezier_ends_at_the_first_and_last_control_points_and_follows_bernstein():
    rng = np.random.default_rng(3)
    for k in range(1, 7):
        pts = rng.normal(size=(k, 3)) * 10
        assert np.array_equal(bezier(pts, 0.0), pts[0])
        assert np.array_equal(bezier(pts, 1.0), pts[-1])
        s, n = 0.3, k - 1
        from math import comb
        bernstein = sum(comb(n, i) * s ** i * (1 - s) ** (n - i) * pts[i] for i in range(k))
        assert np.allclose(bezier(pts, s), bernstein, atol=1e-12)


def test_parse_points():
    assert parse_points(" 1,2,3  4,5,6;7,8,9 ").tolist() == [[1, 2, 3], [4, 5, 6], [7, 8, 9]]
    for bad in ("1,2", "1,2,x", "", "1,2,nan"):
        with pytest.raises(ValueError):
            parse_points(bad)


def test_each_frame_is_the_render_of_its_t_and_eye(capsys, tmp_path, ball):
    out = tmp_path / "a"
    code, stdout, stderr = animate(capsys, ball, out, "--frames", "3", "--path=" + PATH,
                                   "--jobs", "1")
    assert code == 0, stderr
    shots = frames(out)
    assert [p.name for p in shots] == ["frame_0000.png", "frame_0001.png", "frame_0002.png"]
    assert "3 of 3 frames (0 reused, 3 rendered with 1 job)" in stdout
    data = [p.read_bytes() for p in shots]
    assert len(set(data)) == 3
    for i, (t, eye) in enumerate(zip(("0", "0.5", "1"), EYES)):
        still = tmp_path / f"still{i}.png"
        assert main(["render", str(ball), "-o", str(still), "--set", f"t={t}",
                     f"--eye={eye}", *TINY]) == 0
        assert still.read_bytes() == data[i], f"frame {i}"


@pytest.mark.parametrize("name", ["frame_0001.png", "ball.png"])
def test_a_frame_or_animation_whose_name_is_a_directory_is_refused_first(capsys, tmp_path,
                                                                         ball, name):
    """That frame failed after the others had rendered, and no animation was written (QA)."""
    out = tmp_path / "anim"
    (out / name).mkdir(parents=True)
    code, stdout, stderr = animate(capsys, ball, out, "--frames", "3")
    assert code == 2 and frames(out) == ([] if name == "ball.png" else [out / name])
    assert f"{out / name} is a directory, where an image of the animation goes" in stderr


def test_the_ball_grows_with_t(capsys, tmp_path, ball):
    out = tmp_path / "a"
    assert animate(capsys, ball, out, "--frames", "2", "--jobs", "1")[0] == 0
    first, last = (np.asarray(Image.open(p).convert("RGB"), float) for p in frames(out))
    red = [((im[..., 0] - im[..., 1]) > 40).sum() for im in (first, last)]
    assert 0 < red[0] < red[1] / 3      # the radius grows from 0.3 to 1: area about 11x


def test_jobs_give_the_same_bytes(capsys, tmp_path, ball):
    one, two = tmp_path / "one", tmp_path / "two"
    assert animate(capsys, ball, one, "--frames", "4", "--path=" + PATH, "--jobs", "1")[0] == 0
    code, stdout, stderr = animate(capsys, ball, two, "--frames", "4", "--path=" + PATH,
                                   "--jobs", "2")
    assert code == 0, stderr
    assert "rendered with 2 jobs" in stdout
    assert [p.read_bytes() for p in frames(one)] == [p.read_bytes() for p in frames(two)]
    # --threads: each frame process's threads instead of its share of the cores
    three = tmp_path / "three"
    code, _, stderr = animate(capsys, ball, three, "--frames", "4", "--path=" + PATH,
                              "--jobs", "2", "--threads", "1")
    assert code == 0, stderr
    assert [p.read_bytes() for p in frames(one)] == [p.read_bytes() for p in frames(three)]


def test_a_frame_process_has_its_share_of_the_cores_or_threads_at_most_the_cores():
    from pcsg.render.animate import cores, worker_threads
    assert worker_threads(None, 1) == cores()
    assert worker_threads(None, cores() + 1) == 1
    assert worker_threads(1, 2) == 1
    assert worker_threads(300, 2) == cores()      # each worker started 300 threads


def test_jobs_are_at_most_the_cores(capsys, tmp_path, ball):
    """--jobs 1000 started a process per frame on two cores (17 s against 2.6 s)."""
    from pcsg.render.animate import cores
    code = main(["animate", str(ball), "-o", str(tmp_path / "a"), "--size", "32x24",
                 "--shadow-samples", "1", "--frames", "4", "--path=" + PATH, "--jobs", "1000",
                 "-q"])
    stdout, stderr = capsys.readouterr()
    n = min(4, cores())
    assert code == 0, stderr
    # a note, which -q keeps (it hid it, and no other note)
    assert f"note: --jobs 1000: {cores()} cores here, so {n} worker process" in stderr
    assert f"rendered with {n} job" in stdout


def test_resume_renders_only_missing_or_broken_frames(capsys, tmp_path, ball):
    out = tmp_path / "a"
    args = ("--frames", "4", "--path=" + PATH, "--jobs", "1")
    assert animate(capsys, ball, out, *args)[0] == 0
    before = {p.name: (p.read_bytes(), p.stat().st_mtime_ns) for p in frames(out)}
    broken, gone = out / "frame_0001.png", out / "frame_0002.png"
    broken.write_bytes(broken.read_bytes()[:100])           # an interrupted copy, say
    gone.unlink()
    code, stdout, stderr = animate(capsys, ball, out, *args)
    assert code == 0, stderr
    assert "4 of 4 frames (2 reused, 2 rendered with 1 job)" in stdout
    after = {p.name: (p.read_bytes(), p.stat().st_mtime_ns) for p in frames(out)}
    assert {k: v[0] for k, v in after.items()} == {k: v[0] for k, v in before.items()}
    for name in ("frame_0000.png", "frame_0003.png"):
        assert after[name][1] == before[name][1], f"{name} was written again"
    # nothing changed: nothing renders, but with --force (accepted and ignored before)
    code, stdout, _ = animate(capsys, ball, out, *args)
    assert "(4 reused, 0 rendered)" in stdout
    code, stdout, _ = animate(capsys, ball, out, *args, "--force")
    assert "(0 reused, 4 rendered" in stdout
    assert [p.read_bytes() for p in frames(out)] == [v[0] for _, v in sorted(after.items())]


def test_an_animation_removes_only_its_own_earlier_frames(capsys, tmp_path, ball):
    """The directory's list of outputs made (.pcsg-done.json) is shared with sweeps and
    batches: an animation deleted every file in it that was not one of its frames (a
    sweep's two images into the same directory, say). Its own surplus frames still go."""
    out = tmp_path / "a"
    assert main(["sweep", str(ball), "--set", "r=1..2", "-o", str(out), *TINY]) == 0
    swept = sorted(p.name for p in out.glob("ball_r=*.png"))
    assert swept == ["ball_r=1.png", "ball_r=2.png"]
    assert animate(capsys, ball, out, "--frames", "3", "--jobs", "1")[0] == 0
    assert animate(capsys, ball, out, "--frames", "2", "--jobs", "1")[0] == 0
    assert [p.name for p in frames(out)] == ["frame_0000.png", "frame_0001.png"]
    assert sorted(p.name for p in out.glob("ball_r=*.png")) == swept
    # and a rerun of the sweep still finds them complete
    assert main(["sweep", str(ball), "--set", "r=1..2", "-o", str(out), *TINY[:-1]]) == 0
    assert "rendered 0 of 2 images" in capsys.readouterr().out


def test_changed_options_or_source_render_again(capsys, tmp_path, ball):
    out = tmp_path / "a"
    args = ("--frames", "3", "--jobs", "1")
    assert animate(capsys, ball, out, *args)[0] == 0
    shadowed = [p.read_bytes() for p in frames(out)]
    code, stdout, _ = animate(capsys, ball, out, *args, "--no-shadows")
    assert "(0 reused, 3 rendered" in stdout
    assert [p.read_bytes() for p in frames(out)] != shadowed
    ball.write_text(BALL.replace("0.3 + 0.7*t", "0.3 + 0.6*t"), encoding="utf-8")
    code, stdout, _ = animate(capsys, ball, out, *args, "--no-shadows")
    assert "(0 reused, 3 rendered" in stdout
    # two frames: t = 0 is still what it was, t = 1 is new, and the third frame goes
    code, stdout, _ = animate(capsys, ball, out, "--frames", "2", "--jobs", "1",
                              "--no-shadows")
    assert "(1 reused, 1 rendered" in stdout
    assert [p.name for p in frames(out)] == ["frame_0000.png", "frame_0001.png"]


@pytest.mark.parametrize("mode", ["RGB", "RGBA"])
def test_the_animated_png_copies_each_frame_as_it_is(tmp_path, mode):
    """Written a frame at a time from the frames' own image data (Pillow's writer held
    every frame decoded); read back by Pillow, every frame and its delay are the same."""
    from pcsg.render.movie import FrameMismatch, write_apng
    rng = np.random.default_rng(7)
    paths, pixels = [], []
    for i in range(40):
        a = rng.integers(0, 256, size=(9, 13, len(mode)), dtype=np.uint8)
        paths.append(tmp_path / f"f{i}.png")
        Image.fromarray(a).save(paths[-1])
        pixels.append(a)
    out = tmp_path / "movie.png"
    write_apng(paths, out, 24.0)
    with Image.open(out) as apng:
        apng.verify()           # every chunk's CRC
    with Image.open(out) as apng:
        assert apng.n_frames == 40 and apng.info.get("loop") == 0
        for i in range(40):
            apng.seek(i)
            assert apng.info["duration"] == pytest.approx(1000 / 24)
            assert np.array_equal(np.asarray(apng.convert(mode)), pixels[i])
    Image.fromarray(pixels[0][:5]).save(paths[3])
    with pytest.raises(FrameMismatch, match="f3.png has another size or pixel format"):
        write_apng(paths, out, 24.0)
    with Image.open(out) as apng:       # the earlier file stays whole
        assert apng.n_frames == 40


def test_animated_png_and_gif_hold_every_frame(capsys, tmp_path, ball):
    out = tmp_path / "a"
    code, stdout, stderr = animate(capsys, ball, out, "--frames", "4", "--path=" + PATH,
                                   "--jobs", "1", "--gif", "--fps", "5")
    assert code == 0, stderr
    assert f"animation {out / 'ball.png'} and {out / 'ball.gif'}" in stdout   # both paths whole
    with Image.open(out / "ball.png") as apng:
        assert apng.format == "PNG" and apng.is_animated and apng.n_frames == 4
        assert apng.info.get("loop") == 0 and apng.info.get("duration") == 200
        apng.seek(2)
        same = Image.open(out / "frame_0002.png").convert("RGB")
        assert np.array_equal(np.asarray(apng.convert("RGB")), np.asarray(same))
    with Image.open(out / "ball.gif") as gif:
        assert gif.n_frames == 4 and gif.info.get("loop") == 0
    # a run without --gif takes the earlier one's away, as it does that run's extra frames,
    # and leaves a GIF it did not write
    code, stdout, stderr = animate(capsys, ball, out, "--frames", "3", "--jobs", "1")
    assert code == 0, stderr
    assert not (out / "ball.gif").exists() and (out / "ball.png").exists()
    (out / "ball.gif").write_bytes(b"GIF89a, the user's")
    code, stdout, stderr = animate(capsys, ball, out, "--frames", "2", "--jobs", "1")
    assert code == 0, stderr
    assert (out / "ball.gif").read_bytes() == b"GIF89a, the user's"


def test_an_output_named_as_an_image_is_refused(capsys, tmp_path, ball):
    # it made a directory named an8.png, where sweep and render refuse such a name
    for name in ("an8.png", "an8.GIF"):
        code, _, stderr = animate(capsys, ball, tmp_path / name, "--frames", "2")
        assert code == 2 and "animate writes its frames and the animation into a " \
            f"directory; name it, e.g. -o {tmp_path / 'an8'}/" in stderr
        assert not (tmp_path / name).exists()


def test_animate_has_no_tiles(capsys, tmp_path, ball):
    # its help listed --tiles, which it then refused: it sends whole frames to the workers
    with pytest.raises(SystemExit) as e:
        main(["animate", str(ball), "--tiles", "3"])
    assert e.value.code == 2 and "unrecognized arguments: --tiles" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["animate", "--help"])
    assert "--tiles" not in capsys.readouterr().out


def test_a_t_that_nothing_reads_is_a_still_animation(capsys, tmp_path):
    """`{t = 0} sphere` rendered the same frame again and again, without a word; a t read
    only through a macro or another parameter counts, and a moving camera needs none."""
    src = tmp_path / "unread.pcsg"
    src.write_text("{t = 0} sphere\n", encoding="utf-8")
    out = tmp_path / "a"
    code, _, stderr = animate(capsys, src, out, "--frames", "2", "--jobs", "1")
    assert code == 2 and "assigns t in its axiom but reads it nowhere" in stderr
    assert not out.exists()
    code, _, stderr = animate(capsys, src, out, "--frames", "2", "--jobs", "1", "--size",
                              "24x18", "--path=3,3,3 3,4,3")
    assert code == 0, stderr
    for text in ("#define T t\n{t = 0} move(T, 0, 0) sphere\n",
                 "{t = 0; c = 1 - t} paint(c, 0.5, 0.5) sphere\n"):
        src.write_text(text, encoding="utf-8")
        moved = tmp_path / "b"
        code, _, stderr = animate(capsys, src, moved, "--frames", "2", "--jobs", "1",
                                  "--size", "24x18")
        assert code == 0, stderr
        first, last = sorted(moved.glob("*.png"))[:2]
        assert first.read_bytes() != last.read_bytes()
        shutil.rmtree(moved)


def test_camera_only_when_the_file_has_no_t(capsys, tmp_path):
    src = tmp_path / "still.pcsg"
    src.write_text(BALL.replace("{t = 1; r = 0.3 + 0.7*t}", "{r = 0.6}"), encoding="utf-8")
    out = tmp_path / "a"
    code, stdout, stderr = animate(capsys, src, out, "--frames", "3", "--jobs", "1")
    assert code == 2 and "assigns no t in its axiom" in stderr and not out.exists()
    for still in ("3,3,3", "3,3,3 3,3,3"):         # a path that stays at one point
        code, stdout, stderr = animate(capsys, src, out, "--frames", "3", "--path", still)
        assert code == 2 and "a path of one point stays there" in stderr
        assert not out.exists()
    code, stdout, stderr = animate(capsys, src, out, "--frames", "3", "--jobs", "1",
                                   "--path=" + PATH)
    assert code == 0, stderr
    assert len({p.read_bytes() for p in frames(out)}) == 3


def test_the_default_sun_stays_put_while_the_camera_moves(capsys, tmp_path):
    """A file without #light: every frame has the sun of the unmoved camera, and the
    summary names it, so each frame is the render of its eye with that --light."""
    src = tmp_path / "nolight.pcsg"
    src.write_text(BALL.replace("#light at=(3,-2,8)\n", ""), encoding="utf-8")
    out = tmp_path / "a"
    code, stdout, stderr = animate(capsys, src, out, "--frames", "3", "--jobs", "1",
                                   "--path=" + PATH)
    assert code == 0, stderr
    sun = re.search(r"the default sun stood at --light=(\S+)", stdout).group(1)
    data = [p.read_bytes() for p in frames(out)]
    for i, t in enumerate(("0", "0.5", "1")):
        common = [str(src), "--set", f"t={t}", f"--eye={EYES[i]}", *TINY]
        fixed, moving = tmp_path / f"fixed{i}.png", tmp_path / f"moving{i}.png"
        assert main(["render", *common, "-o", str(fixed), f"--light={sun}"]) == 0
        assert fixed.read_bytes() == data[i], f"frame {i}"
        assert main(["render", *common, "-o", str(moving)]) == 0
        # the path never passes the file's camera: a sun placed from the frame's own
        # camera stands elsewhere and lights the ball otherwise
        assert moving.read_bytes() != data[i], f"frame {i}"
    capsys.readouterr()


@pytest.mark.parametrize("extra, message", [
    (["--set", "t=0.5"], "animate sets t itself"),
    (["--eye", "1,2,3", "--path", "1,1,1 2,2,2"], "--eye and --path both"),
    (["--at", "1,2,3", "--at-path", "1,1,1 2,2,2"], "--at and --at-path both"),
    (["--frames", "0"], "--frames 0"),
    (["--gif", "--alpha"], "--gif cannot keep --alpha"),
    (["--fps", "inf"], "--fps inf: give a number from 0.01 to below 1000"),
    # a GIF's delay is 16 bits of hundredths: an internal error (OverflowError)
    (["--fps", "0.001", "--gif"], "--fps 0.001: give a number from 0.01"),
    # a delay of whole hundredths: 200 fps wrote 0, which players show as 0.1 s
    (["--fps", "200", "--gif"], "--fps 200 with --gif: a GIF plays at most 50 frames a second"),
    # planned for 27 s in silence
    (["--frames", "100000"], "--frames 100,000: give 1 to 10,000"),
    # a GIF is made from every frame at once (the animated PNG a frame at a time)
    (["--frames", "2000", "--gif", "--size", "640x480"], "--gif: 2,000 frames of 640x480"),
    (["--path", "0,0,0.6 0,0,0.6", "--at", "0,0,0.6"], "frame 0 (t = 0): the camera's eye"),
    # --jobs was dropped without a word
    (["-j", "2", "--workers", "2"], "--jobs counts local processes and --workers renders"),
    (["-j", "2", "--scheduler", "tcp://127.0.0.1:1"], "and --scheduler renders the frames"),
])
def test_usage_errors(capsys, tmp_path, ball, extra, message):
    code, stdout, stderr = animate(capsys, ball, tmp_path / "a", *extra)
    assert code == 2 and message in stderr and "Traceback" not in stderr


@pytest.mark.parametrize("lit, extra, message", [
    # without #light, default_light asked the camera's basis outside the try: an internal
    # error (exit 3)
    (False, ["--eye", "1e200,0,0"], ": the camera's eye is too far from at"),
    (True, ["--eye", "1e200,0,0"], ": the camera's eye is too far from at"),
    # the point looked at is the file's: render says this with exit 1, animate said 2
    (True, ["--path", "1e200,0,0 0,1e200,0"], ": frame 0 (t = 0): the camera's eye is too far"),
])
def test_a_camera_that_cannot_look_at_the_file_is_an_error_in_it(capsys, tmp_path, ball,
                                                                   lit, extra, message):
    if not lit:
        ball.write_text(BALL.replace("#light at=(3,-2,8)\n", ""), encoding="utf-8")
        assert "#light" not in ball.read_text(encoding="utf-8")
    code, stdout, stderr = animate(capsys, ball, tmp_path / "a", *extra)
    assert code == 1 and stderr.startswith(f"pcsg animate: {ball}{message}")
    assert "Traceback" not in stderr and "internal error" not in stderr


def test_a_bad_path_is_an_argument_error(capsys, tmp_path, ball):
    with pytest.raises(SystemExit) as e:
        main(["animate", str(ball), "--path", "1,2 3,4,5"])
    assert e.value.code == 2 and "'1,2' is not a point X,Y,Z" in capsys.readouterr().err


def test_the_growing_tree_grows(capsys):
    """The sample's derivation gains primitives at every step of t (levels, then leaves)."""
    counts = []
    for t in (0, 0.25, 0.5, 0.75, 1):
        assert main(["stats", str(GRAMMARS / "growing_tree.pcsg"), "--set", f"t={t}",
                     "--json"]) == 0
        counts.append(json.loads(capsys.readouterr().out)["primitives"])
    assert counts == sorted(set(counts)) and counts[0] < 100 < 50_000 < counts[-1]


# frame 0 (t = 0) is one tetrahedron a few pixels wide; frame 1 a Sierpinski tetrahedron
# of order 6 with 64 samples and 32 occlusion rays a pixel: about 20 s on its one core
SLOW_LAST_FRAME = """{t = 0; n = floor(6 * t)} S
S if(n > 0, 2, 1)
1: S → uscale(max(t, 0.001)) tetrahedron
2: S → {n = n - 1} (move(0.5,0.5,0.5) uscale(0.5) S ∪ move(-0.5,-0.5,0.5) uscale(0.5) S ∪
                    move(0.5,-0.5,-0.5) uscale(0.5) S ∪ move(-0.5,0.5,-0.5) uscale(0.5) S)
"""


@pytest.mark.parametrize("signum, code, said", [
    (signal.SIGTERM, 143, "pcsg: terminated (SIGTERM)"), (signal.SIGINT, 130, "")])
def test_a_signal_to_the_command_alone_stops_its_workers_too(tmp_path, signum, code, said):
    """`kill PID` reaches the command, not its workers: it passes the signal on, keeps
    the finished frames, and exits with 143 (killed outright, multiprocessing's tracker
    told of leaked semaphores and the workers' frames were left to finish). The frame
    being rendered when the signal comes is stopped, not finished: without the signal
    passed on, the command waited about 20 s for frame 1 and wrote it. So with `kill
    -INT PID` (130), which was not passed on (QA: frames queued for the workers started
    after it)."""
    source = tmp_path / "slow.pcsg"
    source.write_text(SLOW_LAST_FRAME, encoding="utf-8")
    out = tmp_path / "a"
    cmd = [sys.executable, "-m", "pcsg", "animate", str(source), "--frames", "2", "--jobs",
           "2", "--size", "320x240", "--samples", "64", "--ao", "32", "--eye", "3,-4,2",
           "--at", "0,0,0", "-o", str(out)]
    with sigint_reaches_children():
        p = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True)
    first = p.stdout.readline()                 # frame 0 is finished, frame 1 is rendering
    p.send_signal(signum)
    rest, err = p.communicate(timeout=300)
    assert "frame_0000.png" in first and p.returncode == code, err
    assert "interrupted with 1 of 2 frames done; the same command resumes" in err
    assert said in err
    assert "Traceback" not in err and "leaked" not in err, err
    assert [png.name for png in frames(out)] == ["frame_0000.png"]
    assert not list(out.glob(".*.part"))
    with Image.open(out / "frame_0000.png") as im:
        im.verify()


def test_ctrl_c_keeps_finished_frames_and_the_rerun_resumes(tmp_path):
    """Ctrl-C at the terminal reaches the whole process group: the command and its workers."""
    out = tmp_path / "a"
    cmd = [sys.executable, "-m", "pcsg", "animate", str(GRAMMARS / "growing_tree.pcsg"),
           "--frames", "16", "--size", "48x36", "--jobs", "2", "-o", str(out)]
    with sigint_reaches_children():
        p = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True, start_new_session=True)
    first = p.stdout.readline()                 # a frame is finished: the workers are busy
    os.killpg(p.pid, signal.SIGINT)
    rest, err = p.communicate(timeout=300)
    assert "frame_" in first and p.returncode == 130, err
    assert "the same command resumes" in err and "Traceback" not in err
    done = frames(out)
    assert 1 <= len(done) < 16 and not list(out.glob(".*.part"))
    for png in done:
        with Image.open(png) as im:
            im.verify()
    r = subprocess.run(cmd + ["-q"], cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    reused, rendered = map(int, re.search(r"\((\d+) reused, (\d+) rendered", r.stdout).groups())
    # every finished frame is reused (but one whose record Ctrl-C cut short, if that struck
    # while the manifest was being written)
    assert reused + rendered == 16 and len(done) - 1 <= reused <= len(done)


# rule 3 is no rule: with --strict the frames past t = 1/2 fail
FAILS_LATE = """#camera eye=(0,-6,3) at=(0,0,0.6) fov=40
#light at=(3,-2,8)
{t = 0} S
S if(t > 0.5, 3, 1)
1: S → move(t,0,0) sphere
"""


def test_a_failed_frame_writes_no_animation_and_names_the_earlier_one(capsys, tmp_path):
    source = tmp_path / "late.pcsg"
    source.write_text(FAILS_LATE, encoding="utf-8")
    out = tmp_path / "a"
    code, stdout, _ = animate(capsys, source, out, "--frames", "2", "-j", "1")
    assert code == 0 and "; animation " in stdout
    earlier = (out / "late.png").read_bytes()
    code, stdout, stderr = animate(capsys, source, out, "--frames", "2", "-j", "1", "--strict",
                                   "--force")
    assert code == 1 and "failed: frame_0001.png" in stdout and "--strict" in stderr
    # the earlier run's animation is kept, as render keeps a picture it could not replace,
    # and said to be the earlier run's (a user took it for this run's)
    assert f"no animation written ({out / 'late.png'} is an earlier run's)" in stdout
    assert (out / "late.png").read_bytes() == earlier
    (out / "late.png").unlink()
    code, stdout, _ = animate(capsys, source, out, "--frames", "2", "-j", "1", "--strict")
    assert code == 1 and "; no animation written; failed: frame_0001.png" in stdout


def test_a_file_named_as_a_frame_is_refused(capsys, tmp_path):
    """frame_0000.pcsg's animation, frame_0000.png, was written over its first frame."""
    src = tmp_path / "frame_0000.pcsg"
    src.write_text(BALL, encoding="utf-8")
    code, _, err = animate(capsys, src, tmp_path, "--frames", "2")
    assert code == 2 and "its animation would be named frame_0000.png, as a frame is" in err
    assert not list(tmp_path.glob("*.png"))
    named = tmp_path / "frame_one.pcsg"          # not a frame's name: animated
    named.write_text(BALL, encoding="utf-8")
    assert animate(capsys, named, tmp_path / "o", "--frames", "2")[0] == 0
    assert sorted(p.name for p in (tmp_path / "o").glob("*.png")) == [
        "frame_0000.png", "frame_0001.png", "frame_one.png"]
