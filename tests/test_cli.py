"""The pcsg command line: check, expand, stats, graph, --set, exit codes."""
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from pcsg.cli import main

from .conftest import GRAMMARS, ROOT, SIERPINSKI, expand_and_recheck


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def sierpinski(tmp_path):
    p = tmp_path / "s.pcsg"
    p.write_text(SIERPINSKI, encoding="utf-8")
    return p


def test_version_is_the_installed_distribution(capsys):
    from importlib.metadata import version
    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0
    assert capsys.readouterr().out == f"pcsg {version('pcsg')}\n"


def test_check_ok_and_errors(capsys, tmp_path, sierpinski):
    bad = tmp_path / "bad.pcsg"
    bad.write_text("{c = 1} S\n1: S → foo\n", encoding="utf-8")
    code, out, err = run(capsys, "check", str(sierpinski), str(bad))
    assert code == 1
    assert f"{sierpinski}: ok (13 nodes, 1 module, 1 parameter)" in out
    assert err.startswith(f"{bad}:2:8: error: undefined name 'foo'")


def test_check_counts_in_words(capsys, tmp_path):
    # "1 nodes", and `pixels`, which the tracer fills, counted as a parameter
    one = tmp_path / "one.pcsg"
    one.write_text("sphere\n", encoding="utf-8")
    assert run(capsys, "check", str(one))[1].strip() == \
        f"{one}: ok (1 node, 0 modules, 0 parameters)"
    one.write_text("S\nS if(pixels > 2, 2, 1)\n1: S → sphere\n2: S → uscale(0.5) S ∪ cube\n",
                   encoding="utf-8")
    assert "1 module, 0 parameters" in run(capsys, "check", str(one))[1]


def test_check_samples_and_quoted_globs(capsys):
    code, out, err = run(capsys, "check", str(GRAMMARS / "*.pcsg"))
    assert code == 0, err
    assert out.count(": ok (") == len(list(GRAMMARS.glob("*.pcsg"))) >= 2


def test_check_warnings_and_werror(capsys, tmp_path):
    p = tmp_path / "w.pcsg"
    p.write_text("{c = 2} S\nS if(c > 0, 2, 1)\n1: S → sphere\n"
                 "2: S → sphere ∪ move(2,0,0) uscale(0.5) S\n", encoding="utf-8")
    code, out, err = run(capsys, "check", str(p))
    assert code == 0 and "warning: 'S' can call itself here" in err and "2 warnings" in out
    code, out, err = run(capsys, "check", "--werror", str(p))
    assert code == 1 and err.endswith(f"{p}: failed: 2 warnings with --werror\n")


def test_check_counts_graftals_and_the_samples_pass_werror(capsys):
    code, out, err = run(capsys, "check", "--werror", str(GRAMMARS / "*.pcsg"))
    assert code == 0 and err == ""
    assert "barnsley_fern.pcsg: ok (36 nodes, 3 modules, 0 parameters, 3 graftals)" in out


def test_render_names_the_file_of_a_warning_once(capsys, tmp_path):
    """A compile warning names its file:line:col itself; the render's other notes are
    put after the file's name (they once both were: 'fern.pcsg: fern.pcsg:24:16: ...')."""
    p = tmp_path / "fern.pcsg"
    text = (GRAMMARS / "barnsley_fern.pcsg").read_text(encoding="utf-8")
    p.write_text(text + "leaf = sphere\n", encoding="utf-8")
    code, out, err = run(capsys, "render", str(p), "--size", "32x24", "-q",
                         "-o", str(tmp_path / "fern.png"))
    assert code == 0
    lines = err.splitlines()
    line = text.count("\n") + 1
    assert f"{p}:{line}:1: warning: named expression 'leaf' is never used" in lines[0]
    assert not [x for x in lines if x.startswith(f"{p}: {p}")]
    assert [x for x in lines if x.startswith(f"{p}: level of detail: ")]


def test_expand(capsys, sierpinski, tmp_path):
    code, out, err = run(capsys, "expand", str(sierpinski), "-n", "2", "--set", "c=2")
    assert code == 0, err
    axiom = out.splitlines()[1]
    assert axiom.count("tetrahedron") == 0 and axiom.count("{c = 0} S") == 16
    target = tmp_path / "e.pcsg"
    code, out, err = run(capsys, "expand", str(sierpinski), "-n", "3", "--set", "c=2",
                         "-o", str(target))
    assert code == 0 and out == ""
    code, out, err = run(capsys, "check", str(target))
    assert code == 0


def test_expand_to_the_end_keeps_what_the_rules_read(capsys, tmp_path):
    """Fully derived, the word calls no module, but the rules stay in the file and read a
    parameter that only the old axiom assigned: the new axiom keeps that assignment."""
    out = expand_and_recheck(tmp_path, capsys, "{k = 1} S\nS 1\n1: S → move(0, 0, k) cube\n", 1)
    assert "{k = 1} (move(0, 0, 1) cube)" in out


def test_expand_refuses_huge_output(capsys, sierpinski):
    code, out, err = run(capsys, "expand", str(sierpinski), "-n", "8", "--max-chars", "1000")
    assert code == 2 and "longer than 1,000 characters" in err


def test_stats_text_and_json(capsys, sierpinski):
    code, out, err = run(capsys, "stats", str(sierpinski))
    assert "primitives   4,096 in the complete derivation (tetrahedron)" in out
    code, out, err = run(capsys, "stats", str(sierpinski), "--json", "--set", "c=8")
    data = json.loads(out)
    assert data["primitives"] == 4 ** 8 and data["modules"] == {"S": 2}
    assert data["node_kinds"]["select"] == 1 and data["parameters"] == ["c"]
    # counted, and counted by its size: endless is there, false (it was left out)
    assert data["endless"] is False
    code, out, err = run(capsys, "stats", str(sierpinski), "--json", "--set", "c=9999")
    assert json.loads(out)["endless"] is False


def test_stats_counts_one_instruction_in_the_singular(capsys, tmp_path):
    one = tmp_path / "one.pcsg"
    one.write_text("uscale(2) sphere\n")
    code, out, err = run(capsys, "stats", str(one))
    assert code == 0 and "  expressions  1 (1 instruction)\n" in out, out


def test_a_parameter_set_but_read_nowhere_is_warned_of(capsys, tmp_path, sierpinski):
    """An expanded file keeps its axiom's block, `{c = 2} (...)`: `--set c=5` on it drew
    what c=2 drew, without a word."""
    full = tmp_path / "full.pcsg"
    code, out, err = run(capsys, "expand", str(sierpinski), "-n", "9", "--set", "c=2",
                         "-o", str(full))
    assert code == 0 and "{c = 2} (" in full.read_text() and " S" not in full.read_text()
    code, out, err = run(capsys, "check", str(full), "--set", "c=5")
    assert code == 0
    assert "full.pcsg: warning: 'c' is set to 5, but nothing in the file reads it: the " \
           "object is the same whatever its value" in err
    assert run(capsys, "check", str(full), "--set", "c=5", "--werror")[0] == 1
    code, out, err = run(capsys, "check", str(sierpinski), "--set", "c=5")
    assert code == 0 and "warning" not in err
    # a sweep of it would draw one image again and again, as animate's of an unread t
    code, out, err = run(capsys, "sweep", str(full), "--set", "c=1..3", "-o",
                         str(tmp_path / "sweep"))
    assert code == 2 and "nothing in it reads c, so every image of the sweep would be " \
                         "the same" in err
    assert not (tmp_path / "sweep").exists()
    # read only by a selection, a paint, a directive: read all the same
    for text in ("{c = 1} S\nS if(c > 0, 1, 1)\n1: S → sphere\n",
                 "{c = 1} paint(c, 0, 0) sphere\n"):
        one = tmp_path / "one.pcsg"
        one.write_text(text)
        code, out, err = run(capsys, "check", str(one), "--set", "c=0.5")
        assert code == 0 and "warning" not in err, (text, err)


def test_set_errors(capsys, sierpinski):
    code, out, err = run(capsys, "stats", str(sierpinski), "--set", "k=1")
    assert code == 1 and "cannot set 'k': it is not an initial parameter (initial parameters: c)" in err
    with pytest.raises(SystemExit) as e:
        main(["stats", str(sierpinski), "--set", "c=abc"])
    assert e.value.code == 2
    assert "'abc' is not a number" in capsys.readouterr().err


@pytest.mark.parametrize("value", ["1_0", "inf", "nan", "0x10", "1e", "--1", ""])
def test_set_takes_the_numbers_a_file_writes(capsys, sierpinski, value):
    """Python's float() read 1_0 as ten and took inf and nan, which no file can write."""
    with pytest.raises(SystemExit) as e:
        main(["stats", str(sierpinski), f"--set=c={value}"])
    assert e.value.code == 2
    assert f"'{value}' is not a number (in --set c={value})" in capsys.readouterr().err


def test_set_refuses_a_number_past_the_largest_double(capsys, sierpinski):
    with pytest.raises(SystemExit) as e:
        main(["stats", str(sierpinski), "--set=c=-1e400"])
    assert e.value.code == 2
    assert "'-1e400' is too large (in --set c=-1e400)" in capsys.readouterr().err


@pytest.mark.parametrize("value", ["1e-400", "-2.5e-330"])
def test_set_refuses_a_number_too_small_for_a_double(capsys, sierpinski, value):
    """It read as 0 without a word, where a number too large is refused (QA)."""
    with pytest.raises(SystemExit) as e:
        main(["stats", str(sierpinski), f"--set=c={value}"])
    assert e.value.code == 2
    assert f"'{value}' is too small (in --set c={value}): it would be 0" in \
        capsys.readouterr().err


@pytest.mark.parametrize("value, count", [("+3", 4 ** 3), ("3.", 4 ** 3), (".3e1", 4 ** 3),
                                          ("30E-1", 4 ** 3), ("-0", 1), ("0.0e-500", 1), ("4.9e-324", 4)])
def test_set_takes_every_form_of_a_number(capsys, sierpinski, value, count):
    code, out, err = run(capsys, "stats", str(sierpinski), "--json", f"--set=c={value}")
    assert code == 0 and json.loads(out)["primitives"] == count


@pytest.mark.parametrize("command", ["stats", "check", "expand", "render"])
def test_a_parameter_set_twice_is_a_usage_error(capsys, sierpinski, tmp_path, command):
    """render and stats took the last value where sweep refused; now each refuses."""
    code, out, err = run(capsys, command, str(sierpinski), "--set", "c=1", "--set", "c=2",
                         *(["-o", str(tmp_path / "x.png")] if command == "render" else []))
    assert code == 2 and "--set c is given twice" in err
    assert not (tmp_path / "x.png").exists()


def test_graph_dot(capsys, sierpinski):
    code, out, err = run(capsys, "graph", str(sierpinski))
    assert code == 0 and out.startswith("// ") and "digraph pcsg {" in out
    assert 'shape=diamond' in out and 'label="S\\nif(c > 0, 2, 1)"' in out
    assert out.count("style=dashed") == 4            # the four cycles back to S
    assert 'label="c = c - 1"' in out


def test_graph_marks_the_operand_a_difference_takes_away(capsys, tmp_path):
    src = tmp_path / "d.pcsg"
    src.write_text("sphere \\ cube\n", encoding="utf-8")
    code, out, _ = run(capsys, "graph", str(src))
    node = {label: n for n, label in re.findall(r'(n\d+) \[label="(\w+|\\\\)"', out)}
    minus = node["\\\\"]                      # the \ node, its label escaped for dot
    assert code == 0 and f'{minus} -> {node["cube"]} [label="−"];' in out
    assert f'{minus} -> {node["sphere"]};' in out


def test_unreadable_inputs(capsys, tmp_path):
    code, out, err = run(capsys, "check", str(tmp_path))      # its .pcsg files: none
    assert code == 1 and "is a directory" in err
    code, out, err = run(capsys, "check", str(tmp_path / "missing.pcsg"))
    assert code == 1 and "cannot read: No such file or directory" in err
    binary = tmp_path / "b.pcsg"
    binary.write_bytes(b"\x00\x01\x02")
    code, out, err = run(capsys, "check", str(binary))
    assert code == 1 and "binary file" in err
    latin = tmp_path / "l.pcsg"
    latin.write_bytes(b"sphere // caf\xe9\n")
    code, out, err = run(capsys, "check", str(latin))
    assert code == 1 and "l.pcsg:1:14: error: not UTF-8 text (byte 0xe9)" in err


def test_a_render_that_writes_nothing_leaves_no_directory_it_made(capsys, sierpinski,
                                                                    tmp_path):
    """`-o DIR/` is made before the files render: one that failed, or a usage error found
    after it was made, left it there empty."""
    bad = tmp_path / "bad.pcsg"
    bad.write_text("sphere ∪ foo\n", encoding="utf-8")
    out = tmp_path / "new" / "renders"
    assert run(capsys, "render", str(bad), "-o", f"{out}/", "--size", "8x6")[0] == 1
    assert run(capsys, "render", str(sierpinski), "-o", f"{out}/", "--workers", "2",
               "--timings")[0] == 2
    assert not (tmp_path / "new").exists()
    # one that existed stays, and so does one something was written in
    out.mkdir(parents=True)
    assert run(capsys, "render", str(bad), "-o", f"{out}/", "--size", "8x6")[0] == 1
    assert out.is_dir()
    out.rmdir()
    assert run(capsys, "render", str(sierpinski), str(bad), "-o", f"{out}/", "--size", "8x6",
               "-q")[0] == 1
    assert [p.name for p in out.iterdir()] == ["s.png"]


def test_a_sweep_or_animation_that_writes_nothing_leaves_no_directory_it_made(
        capsys, sierpinski, tmp_path):
    """As render's: `sweep ... --timeout 1e-9 -o new/` and an animation stopped before its
    first frame left their directories there empty (QA)."""
    out = tmp_path / "new" / "sweep"
    assert run(capsys, "sweep", str(sierpinski), "--set", "c=1..2", "--size", "8x6", "-q",
               "--timeout", "1e-9", "-o", f"{out}/")[0] == 1
    assert not (tmp_path / "new").exists()
    moving = tmp_path / "m.pcsg"
    moving.write_text("move(0, 0, t) sphere\n", encoding="utf-8")
    assert run(capsys, "animate", str(moving), "--frames", "2", "--size", "8x6", "-q",
               "--timeout", "1e-9", "-o", f"{out}/")[0] == 1
    assert not (tmp_path / "new").exists()
    assert run(capsys, "sweep", str(sierpinski), "--set", "c=1..2", "--size", "8x6", "-q",
               "-o", f"{out}/")[0] == 0
    assert sorted(p.name for p in out.glob("*.png")) == ["s_c=1.png", "s_c=2.png"]


@pytest.mark.parametrize("command", ["graph", "expand"])
def test_an_output_named_as_a_directory_is_refused(capsys, sierpinski, tmp_path, command):
    # `-o new/` wrote a file named new (QA)
    code, _, err = run(capsys, command, str(sierpinski), "-o", f"{tmp_path}/new/")
    assert code == 2 and "a name that ends in / is a directory's; name a file" in err
    assert not (tmp_path / "new").exists()


def test_expand_writes_by_default_only_what_pcsg_reads_back(capsys, sierpinski, tmp_path,
                                                            monkeypatch):
    """expand's default limit was 50 million characters, where check and render read 8 MiB:
    a word of 15 MB was written and then refused (QA). The reader's limit, made small."""
    import pcsg.cli
    import pcsg.language.files
    for module in (pcsg.cli, pcsg.language.files):
        monkeypatch.setattr(module, "MAX_FILE_BYTES", 20_000)
    out = tmp_path / "e.pcsg"
    code, _, err = run(capsys, "expand", str(sierpinski), "-n", "5", "-o", str(out))
    assert code == 2 and not out.exists()
    assert "pcsg reads grammars of up to 20,000 bytes" in err and "--max-chars" in err
    code, _, err = run(capsys, "expand", str(sierpinski), "-n", "5", "-o", str(out),
                       "--max-chars", "1000000")
    size = out.stat().st_size
    assert code == 0 and size > 20_000
    assert f"the expansion is {size:,} bytes" in err and "check and render will refuse it" in err
    assert run(capsys, "check", str(out))[0] == 1
    code, _, err = run(capsys, "expand", str(sierpinski), "-n", "2", "-o", str(out))
    assert code == 0 and err == "" and run(capsys, "check", str(out))[0] == 0


@pytest.mark.parametrize("command", ["graph", "expand"])
def test_output_directory_missing(capsys, sierpinski, tmp_path, command):
    # the message named the temporary file beside the output
    out = tmp_path / "no" / "g.txt"
    code, _, err = run(capsys, command, str(sierpinski), "-o", str(out))
    assert code == 2 and f"-o {out}: the directory {out.parent} does not exist" in err and ".part" not in err
    (tmp_path / "file").write_text("x")
    code, _, err = run(capsys, command, str(sierpinski), "-o", str(tmp_path / "file" / "g"))
    assert code == 2 and "is a file, not a directory" in err


def test_an_output_directory_that_is_a_dangling_link_is_said_to_be_one(capsys, sierpinski,
                                                                        tmp_path):
    # "dangling is a file, not a directory" (QA)
    (tmp_path / "dangling").symlink_to("nowhere/")
    code, _, err = run(capsys, "render", str(sierpinski), "-o", f"{tmp_path}/dangling/")
    assert code == 2 and f"{tmp_path}/dangling is a link to nowhere/, which does not exist" in err


@pytest.mark.parametrize("argv, output", [
    (["render", "{f}", "-o", "{d}/file/sub/"], "-o {d}/file/sub/"),          # a directory
    (["render", "{f}", "{g}", "-o", "{d}/file/many"], "-o {d}/file/many"),   # a batch
    (["render", "{f}", "-o", "{d}/file/x.png"], "-o {d}/file/x.png"),
    (["export", "{f}", "--pov", "{d}/file/x.pov"], "--pov {d}/file/x.pov"),
    (["sweep", "{f}", "--set", "c=1..2", "-o", "{d}/file/sweep"], "-o {d}/file/sweep"),
    (["animate", "{f}", "--frames", "2", "--path", "4,0,0 0,4,0", "-o", "{d}/file/frames"],
     "-o {d}/file/frames"),
])
def test_an_output_under_a_file_is_a_usage_error(capsys, sierpinski, tmp_path, argv, output):
    # Python's "Not a directory: x/sub", exit 1, named neither the option nor the file
    (tmp_path / "file").write_text("x")
    other = tmp_path / "t.pcsg"
    other.write_text("sphere\n")
    fill = {"f": str(sierpinski), "g": str(other), "d": str(tmp_path)}
    code, _, err = run(capsys, *[a.format(**fill) for a in argv], "--size", "8x6")
    assert code == 2
    assert f"{output.format(**fill)}: " in err and f"{tmp_path / 'file'} is" in err
    assert "Traceback" not in err


@pytest.mark.skipif(not Path("/sys").is_dir(), reason="needs /sys, which no one writes in")
@pytest.mark.parametrize("argv, output", [
    (["render", "{f}", "-o", "/sys/x.png", "--size", "8x6"], "-o /sys/x.png"),
    (["render", "{f}", "{g}", "-o", "/sys/", "--size", "8x6"], "-o /sys/"),
    (["export", "{f}", "--pov", "/sys/x.pov", "--size", "8x6"], "--pov /sys/x.pov"),
    (["expand", "{f}", "-o", "/sys/x.pcsg"], "-o /sys/x.pcsg"),
    (["sweep", "{f}", "--set", "c=1..2", "-o", "/sys/", "--size", "8x6"], "-o /sys/"),
])
def test_an_output_where_nothing_can_be_written_is_refused_before_the_render(
        capsys, sierpinski, tmp_path, argv, output):
    """render found /sys/x.png unwritable after its render, exit 1 (QA: 6 s of graftals)."""
    other = tmp_path / "t.pcsg"
    other.write_text("sphere\n")
    fill = {"f": str(sierpinski), "g": str(other)}
    code, out, err = run(capsys, *[a.format(**fill) for a in argv])
    assert code == 2 and not out
    assert f"error: {output}: cannot write in /sys: " in err


def test_an_output_through_a_link_to_nowhere_is_refused_before_the_render(
        capsys, sierpinski, tmp_path):
    link = tmp_path / "dangle.png"
    link.symlink_to(tmp_path / "nowhere" / "x.png")
    code, out, err = run(capsys, "render", str(sierpinski), "-o", str(link), "--size", "8x6")
    assert code == 2 and not out
    assert f"-o {link}: that is a link to {tmp_path / 'nowhere' / 'x.png'}, whose directory " \
           f"does not exist" in err


def test_graph_refuses_an_image_name_for_its_dot_text(capsys, sierpinski, tmp_path):
    out = tmp_path / "g.png"
    code, _, err = run(capsys, "graph", str(sierpinski), "-o", str(out))
    assert code == 2 and not out.exists()
    assert f"-o {out}: pcsg graph writes Graphviz text, not an image: -o " \
           f"{out.with_suffix('.dot')}, then `dot -Tpng" in err
    assert run(capsys, "graph", str(sierpinski), "-o", str(out.with_suffix(".dot")))[0] == 0


def test_standard_input_is_said_to_be_no_grammar(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, _, err = run(capsys, "check", "-")
    assert code == 1 and "-: error: cannot read: No such file or directory (pcsg reads a " \
                         "grammar from a file, not from standard input" in err


def test_more_threads_than_there_are_is_said(capsys, sierpinski, tmp_path):
    from numba import config
    many = config.NUMBA_NUM_THREADS + 5
    for quiet in ([], ["-q"]):      # -q hid it, and no other note
        code, _, err = run(capsys, "render", str(sierpinski), "--set", "c=1", "--size", "8x6",
                           "-o", str(tmp_path / "a.png"), "--threads", str(many), *quiet)
        assert code == 0
        assert f"note: --threads {many}: at most {config.NUMBA_NUM_THREADS} here" in err


def test_console_script_runs_without_traceback(tmp_path):
    exe = shutil.which("pcsg") or str(__import__("pathlib").Path(sys.executable).parent / "pcsg")
    bad = tmp_path / "bad.pcsg"
    bad.write_text("{c = 6} S\nS if(c > 0, 2, 1)\n1: S → tetrahedron ∪ (\n", encoding="utf-8")
    r = subprocess.run([exe, "check", str(bad)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 1 and "Traceback" not in r.stderr
    assert f"{bad}:4:1: error: unexpected end of file" in r.stderr or ":3:" in r.stderr
    r = subprocess.run([exe, "stats", str(GRAMMARS / "sierpinski.pcsg"), "--set", "c=16"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and "4,294,967,29" in r.stdout


def test_console_command_delivers_all_output_before_its_fast_exit(capsys):
    # run() ends the process with os._exit, past the interpreter's teardown: what main
    # wrote must still arrive whole, through a pipe (block-buffered), from both entries
    args = ["expand", str(GRAMMARS / "sierpinski.pcsg"), "-n", "7"]
    code, want, _ = run(capsys, *args)
    assert code == 0 and len(want) > 200_000      # several pipe buffers
    exe = shutil.which("pcsg") or str(__import__("pathlib").Path(sys.executable).parent / "pcsg")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}   # as users run it
    for cmd in ([exe], [sys.executable, "-m", "pcsg"]):
        r = subprocess.run(cmd + args, capture_output=True, text=True, timeout=120, env=env)
        assert (r.returncode, r.stderr) == (0, "")
        assert r.stdout == want
    # a reader that leaves early: no error, no traceback
    p = subprocess.Popen([exe] + args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    assert len(p.stdout.read(10)) == 10
    p.stdout.close()
    assert p.wait(timeout=120) == 0 and p.stderr.read() == b""
    # output that cannot be written (a full disk) fails the command
    with open("/dev/full", "w") as full:
        r = subprocess.run([exe, "stats", str(GRAMMARS / "sierpinski.pcsg")], stdout=full,
                           stderr=subprocess.PIPE, text=True, timeout=120, env=env)
    assert r.returncode == 1 and "No space left on device" in r.stderr


def test_the_command_imports_numba_with_the_collector_off():
    # `import pcsg.cli` must leave numba to import_kernels, which imports it with the
    # collector off and freezes what it made; the collector runs again afterwards
    code = """
import gc, sys
import pcsg, pcsg.cli
assert "numba" not in sys.modules, "import pcsg.cli imported numba"
seen = []
gc.callbacks.append(lambda phase, info: phase == "start" and seen.append(info["generation"]))
pcsg.cli.import_kernels()
assert "numba" in sys.modules and "pcsg.tracer" in sys.modules
assert seen == [], f"the collector ran during the imports: {seen}"
assert gc.isenabled() and gc.get_freeze_count() > 50_000
assert pcsg.load is sys.modules["pcsg.tracer"].load and issubclass(pcsg.PcsgError, Exception)
assert set(pcsg.__all__) <= set(dir(pcsg))
try:
    pcsg.nothing
except AttributeError as e:
    assert "no attribute 'nothing'" in str(e)
else:
    raise AssertionError("pcsg.nothing resolved")
"""
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr


@pytest.mark.parametrize("args, code", [([], 2), (["--help"], 0), (["--version"], 0),
                                        (["render", "--help"], 0), (["check", "x.pcsg", "-h"], 0)])
def test_help_and_version_do_not_import_numba(args, code):
    # argparse answers these before a command runs: numba's import would be 0.25 s of
    # waiting for a line of text. run() exits with os._exit, so what it imported is
    # read from -X importtime's lines
    run = f"import sys; sys.argv = ['pcsg'] + {args!r}; import pcsg.cli; pcsg.cli.run()"
    r = subprocess.run([sys.executable, "-X", "importtime", "-c", run], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == code, r.stderr
    assert ("pcsg 0" if args == ["--version"] else "usage: pcsg") in r.stdout + r.stderr
    imported = {line.rsplit("|", 1)[-1].strip() for line in r.stderr.splitlines()
                if line.startswith("import time:")}
    assert "pcsg.cli" in imported and "numba" not in imported


def test_a_command_with_a_file_still_imports_the_kernels():
    from pcsg.cli import needs_kernels
    assert needs_kernels(["render", "a.pcsg"]) and needs_kernels(["check", "a.pcsg"])
    assert not needs_kernels(["render", "a.pcsg", "--help"]) and not needs_kernels([])


BLAS = """
import ctypes, os, sys
import pcsg.cli
pcsg.cli.import_kernels()
for path in {line.split()[-1] for line in open("/proc/self/maps") if "openblas" in line}:
    for name in ("scipy_openblas_get_num_threads64_", "openblas_get_num_threads64_",
                 "openblas_get_num_threads"):
        threads = getattr(ctypes.CDLL(path), name, None)
        if threads is not None:
            print(threads())
            sys.exit()
print("no OpenBLAS")
"""


@pytest.mark.skipif(sys.platform != "linux", reason="/proc/self/maps")
def test_the_command_gives_openblas_one_thread_unless_the_user_chose():
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}

    def threads(**extra):
        r = subprocess.run([sys.executable, "-c", BLAS], capture_output=True, text=True,
                           timeout=120, env={**env, **extra})
        assert r.returncode == 0, r.stderr
        return r.stdout.strip()
    got = threads()
    if got == "no OpenBLAS":
        pytest.skip("this numpy does not use OpenBLAS")
    assert got == "1"
    assert threads(OPENBLAS_NUM_THREADS="2") == "2"


YAML = """
import sys
from pathlib import Path
from pcsg import cli
cli.import_kernels()
import numba.core.config as config
print(config._HAVE_YAML, "yaml" in sys.modules, config.DISABLE_PERFORMANCE_WARNINGS)
import yaml                     # dask's import after the command's: found as usual
print(yaml.safe_load("a: 1"))
"""


def test_numba_reads_its_yaml_config_only_where_there_is_one(tmp_path):
    """The command hides PyYAML from numba's import unless the working directory has a
    .numba_config.yaml, the only file numba reads it for; yaml imports as usual after."""
    pytest.importorskip("yaml")

    def config(where):
        r = subprocess.run([sys.executable, "-c", YAML], capture_output=True, text=True,
                           timeout=120, cwd=where)
        assert r.returncode == 0, r.stderr
        return r.stdout.split("\n")[:2]
    assert config(tmp_path) == ["False False 0", "{'a': 1}"]
    (tmp_path / ".numba_config.yaml").write_text("disable_performance_warnings: 1\n")
    assert config(tmp_path) == ["True True 1", "{'a': 1}"]


EXTENSION = """
import sys
from pathlib import Path
import numpy as np
{setup}
from numba import njit
njit(lambda x: x + 1)(np.ones(2))     # a kernel compiled: numba loads its extensions first
print(sorted(m for m in sys.modules if m.startswith("fake_numba_extension")),
      type(sys.modules.get("importlib.metadata")).__name__)
from importlib import metadata
print(metadata.version("numpy") == np.__version__)
"""


def test_the_command_loads_no_numba_extension_and_imports_metadata_on_use(tmp_path):
    """A distribution's `numba_extensions` entry point (a plug-in of numba's) is loaded by
    numba, but not in the command's process, which does not import importlib.metadata
    until something uses it: then it works as usual."""
    (tmp_path / "fake_numba_extension.py").write_text("def init():\n    pass\n")
    info = tmp_path / "fake_numba_extension-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: fake-numba-extension\n"
                                   "Version: 1.0\n")
    (info / "entry_points.txt").write_text("[numba_extensions]\ninit = "
                                           "fake_numba_extension:init\n")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), str(ROOT)])}

    def run_with(setup):
        r = subprocess.run([sys.executable, "-c", EXTENSION.format(setup=setup)], env=env,
                           capture_output=True, text=True, timeout=300, cwd=tmp_path)
        assert r.returncode == 0, r.stderr
        return r.stdout.split("\n")[:2]
    assert run_with("") == ["['fake_numba_extension'] module", "True"]
    assert run_with("import pcsg.cli; pcsg.cli.import_kernels()") == ["[] _LazyModule", "True"]


def test_written_files_get_ordinary_permissions(capsys, sierpinski, tmp_path):
    import stat
    out = tmp_path / "g.dot"
    assert run(capsys, "graph", str(sierpinski), "-o", str(out))[0] == 0
    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE(out.stat().st_mode) == 0o666 & ~umask
    # a file replaced keeps its own (a read-only scene came back 644)
    out.chmod(0o444)
    assert run(capsys, "graph", str(sierpinski), "-o", str(out))[0] == 0
    assert stat.S_IMODE(out.stat().st_mode) == 0o444


SINGULAR = """{n = 2} S
S if(n > 0, 2, 1)
1: S → scale(1, 1, n) sphere
2: S → {n = n-1} (move(1, 0, 0) S ∪ move(-1, 0, 0) S)
"""


def test_strict_fails_on_runtime_errors_and_keeps_the_old_image(capsys, tmp_path):
    bad = tmp_path / "bad.pcsg"
    bad.write_text(SINGULAR, encoding="utf-8")
    out = tmp_path / "bad.png"
    assert main(["render", str(bad), "-o", str(out), "--size", "40x30", "-q"]) == 0
    err = capsys.readouterr().err
    assert "this transformation is singular" in err and "bad.pcsg:3:" in err
    before = out.read_bytes()
    assert main(["render", str(bad), "-o", str(out), "--size", "40x30", "-q", "--strict"]) == 1
    err = capsys.readouterr().err
    assert "--strict" in err and "nothing written" in err and "bad.pcsg:3:" in err
    assert out.read_bytes() == before


def test_timeout_stops_the_render_and_keeps_the_old_image(capsys, tmp_path):
    out = tmp_path / "sympodial_tree.png"
    out.write_bytes(b"earlier")
    code = main(["render", str(GRAMMARS / "sympodial_tree.pcsg"), "-o", str(out),
                 "--size", "64x48", "-q", "--timeout", "0.001", "--set", "cnt=9"])
    err = capsys.readouterr().err
    assert code == 1        # parsing alone takes longer: the render stops before its first row
    assert "sympodial_tree.pcsg: stopped by --timeout 0.001 s; nothing written" in err
    assert out.read_bytes() == b"earlier"


def test_timeout_stops_a_long_bounding_walk(capsys, tmp_path):
    """The terrain at 12 walks its 44 million instances for seconds before it renders:
    --timeout stops the walk itself, not the render after it."""
    out = tmp_path / "carpenter_terrain.png"
    code = main(["render", str(GRAMMARS / "carpenter_terrain.pcsg"), "-o", str(out),
                 "--size", "32x24", "-q", "--timeout", "1", "--set", "cnt=12"])
    err = capsys.readouterr().err
    assert code == 1
    assert ("carpenter_terrain.pcsg: stopped by --timeout 1 s in the bounding walk; nothing "
            "written") in err
    assert not out.exists()


@pytest.mark.parametrize("text, options, message", [
    # the object's box overflows the framing: the eye would be at infinity
    ("move(1e300, 0, 0) sphere ∪ move(-1e300, 0, 0) sphere\n", [],
     "is too large to frame: place the camera with #camera eye=... at=..."),
    # the file's eye and the command line's at (both on the command line: a usage error)
    ("#camera eye=(1, 1, 1) at=(0, 0, 0)\n" + SIERPINSKI, ["--at", "1,1,1"],
     "the camera's eye and at are the same point (1, 1, 1)"),
    (SIERPINSKI, ["--eye", "0,0,5", "--at", "0,0,0"],
     "the camera's up (0, 0, 1) is parallel to its viewing direction"),
    # the file's eye (both on the command line: a usage error, below)
    ("#camera eye=(1e300, 1e300, 1e300)\n" + SIERPINSKI, ["--at", "0,0,0"],
     "the camera's eye is too far from at"),
])
def test_a_camera_that_cannot_be_placed_fails_cleanly(capsys, tmp_path, text, options,
                                                      message):
    """A clear line and nothing written, not NaN pixels or an internal error."""
    path = tmp_path / "c.pcsg"
    path.write_text(text, encoding="utf-8")
    out = tmp_path / "c.png"
    code = main(["render", str(path), "-o", str(out), "--size", "40x30", "-q", *options])
    err = capsys.readouterr().err
    assert code == 1 and message in err and "internal error" not in err
    assert not out.exists()


def test_an_up_of_zero_is_no_direction(capsys, tmp_path):
    # it was "parallel to its viewing direction", from render only, without a place
    path = tmp_path / "c.pcsg"
    path.write_text("#camera eye=(1, 2, 3) up=(0, 0, 0)\nsphere\n", encoding="utf-8")
    assert main(["check", str(path)]) == 1
    assert "c.pcsg:1:23: error: #camera: up is (0, 0, 0), no direction" in capsys.readouterr().err
    path.write_text("sphere\n", encoding="utf-8")
    assert main(["render", str(path), "--up", "0,0,0", "-o", str(tmp_path / "c.png")]) == 2
    assert "--up 0,0,0 is no direction" in capsys.readouterr().err
    # an eye at the point it looks at is the command line's slip too (it failed as the file's)
    assert main(["render", str(path), "--eye", "1,1,1", "--at", "1,1,1", "-o",
                 str(tmp_path / "c.png")]) == 2
    assert "--eye and --at are the same point 1,1,1" in capsys.readouterr().err
    # and so are an up along the view the command line gives whole, and a nan (exit 1, as
    # if the file had failed)
    for options, said in ((["--eye", "0,0,5", "--at", "0,0,0", "--up", "0,0,1"],
                           "--up 0,0,1 is parallel to the view from --eye to --at"),
                          (["--eye", "1e154,0,0", "--at", "0,0,0", "--up", "0,0,1"],
                           "--eye 1e+154,0,0 is too far from --at 0,0,0 (at most 1e+150)"),
                          # whatever the up: it failed the file, exit 1 (QA)
                          (["--eye", "1e300,0,0", "--at", "0,0,0"],
                           "--eye 1e+300,0,0 is too far from --at 0,0,0 (at most 1e+150)"),
                          (["--eye", "nan,0,0"], "--eye nan,0,0: give finite coordinates"),
                          (["--at", "1,inf,0"], "--at 1,inf,0: give finite coordinates"),
                          # framed, this eye was at infinity: "the object's box is too
                          # large to frame"
                          (["--fov", "1e-320"], "--fov 9.99989e-321: the vertical field of "
                                                "view is from 1e-09 to under 180 degrees")):
        assert main(["render", str(path), *options, "-o", str(tmp_path / "c.png")]) == 2
        assert said in capsys.readouterr().err


def test_a_directory_is_its_pcsg_files_and_an_empty_output_name_is_refused(capsys, tmp_path):
    for name in ("b.pcsg", "a.pcsg", "notes.txt"):
        (tmp_path / name).write_text("sphere\n", encoding="utf-8")
    assert main(["check", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert out.index("a.pcsg: ok") < out.index("b.pcsg: ok") and "notes" not in out
    (tmp_path / "empty").mkdir()
    assert main(["check", str(tmp_path / "empty")]) == 1
    assert "empty: error: is a directory with no .pcsg file in it" in capsys.readouterr().err
    # a subdirectory named *.pcsg is not one of its files: the batch failed on it
    (tmp_path / "held").mkdir()
    (tmp_path / "held" / "sub.pcsg").mkdir()
    (tmp_path / "held" / "c.pcsg").write_text("sphere\n", encoding="utf-8")
    assert main(["check", str(tmp_path / "held")]) == 0
    assert "c.pcsg: ok" in capsys.readouterr().out
    assert main(["expand", str(tmp_path / "held")]) == 1       # one file asked for
    assert "held: error: is a directory, not a .pcsg file" in capsys.readouterr().err
    # -o '' rendered into the working directory
    assert main(["render", str(tmp_path / "a.pcsg"), "-o", ""]) == 2
    assert "-o '': name a file or a directory" in capsys.readouterr().err
    for args in (["sweep", str(tmp_path / "a.pcsg"), "--set", "c=1..2", "-o", ""],
                 ["animate", str(tmp_path / "a.pcsg"), "-o", ""],
                 ["export", str(tmp_path / "a.pcsg"), "--pov", ""]):
        assert main(args) == 2, args
        assert "'': name a file or a directory" in capsys.readouterr().err
    # a quoted glob that matches a directory: its files too
    assert main(["check", str(tmp_path / "[a-z]mpty"), str(tmp_path / "?.pcsg")]) == 1
    assert "empty: error: is a directory" in capsys.readouterr().err
    sub = tmp_path / "sub"
    sub.mkdir()
    (sub / "c.pcsg").write_text("sphere\n", encoding="utf-8")
    assert main(["check", str(tmp_path / "s?b")]) == 0
    assert "c.pcsg: ok" in capsys.readouterr().out
    # ** is any depth of directories, as bash's globstar (it was one level: QA); the
    # directories it matches give their files once
    (sub / "deep").mkdir()
    (sub / "deep" / "d.pcsg").write_text("sphere\n", encoding="utf-8")
    for pattern in ("sub/**/*.pcsg", "sub/**"):
        assert main(["check", str(tmp_path / pattern)]) == 0
        out = capsys.readouterr().out
        assert out.count("c.pcsg: ok") == 1 and out.count("d.pcsg: ok") == 1, pattern


def test_a_size_past_the_limit_says_its_pixels_exactly(capsys, tmp_path):
    # "10000x6401 is 64 million pixels ...; pcsg renders up to 64 million"
    assert main(["render", str(GRAMMARS / "sierpinski.pcsg"), "--size", "10000x6401", "-o",
                 str(tmp_path / "s.png")]) == 2
    assert "is 64,010,000 pixels" in capsys.readouterr().err


def test_an_animation_of_an_object_too_large_to_frame_fails_cleanly(capsys, tmp_path):
    path = tmp_path / "c.pcsg"
    path.write_text("move(1e300, 0, 0) sphere ∪ move(-1e300, 0, 0) sphere\n",
                    encoding="utf-8")
    code = main(["animate", str(path), "--frames", "2", "--path", "1,1,1 2,2,2",
                 "-o", str(tmp_path / "frames")])
    err = capsys.readouterr().err
    assert code != 0 and "too large to frame" in err and "internal error" not in err


@pytest.mark.parametrize("value", ["0", "-1", "nan"])
def test_timeout_must_be_positive(capsys, value):
    assert main(["render", str(GRAMMARS / "sierpinski.pcsg"), "--timeout", value]) == 2
    assert "--timeout" in capsys.readouterr().err


@pytest.mark.parametrize("command", ["render", "export"])
@pytest.mark.parametrize("option, value, message", [
    ("--size", "5x0", "--size 5x0: width and height must be at least 1"),
    ("--size", "0x5", "--size 0x5: width and height must be at least 1"),
    ("--shadow-samples", "0", "--shadow-samples 0: use 1 to 256")])
def test_sizes_and_shadow_samples_out_of_range_are_usage_errors(capsys, tmp_path, command,
                                                                option, value, message):
    # export divided by the height (an internal error), or wrote a camera of no width
    out = (["--pov", str(tmp_path / "x.pov")] if command == "export"
           else ["-o", str(tmp_path / "x.png")])
    assert main([command, str(GRAMMARS / "sierpinski.pcsg"), option, value, *out]) == 2
    err = capsys.readouterr().err
    assert message in err and "internal error" not in err
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("command", ["render", "export"])
@pytest.mark.parametrize("value", ["-1", "33"])
def test_bounces_out_of_range_are_usage_errors(capsys, tmp_path, command, value):
    out = (["--pov", str(tmp_path / "x.pov")] if command == "export"
           else ["-o", str(tmp_path / "x.png")])
    assert main([command, str(GRAMMARS / "sierpinski.pcsg"), "--bounces", value, *out]) == 2
    err = capsys.readouterr().err
    assert f"--bounces {value}: use 0 (off) to 32" in err and "Traceback" not in err
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("address", ["bogus://", "tcp://127.0.0.1:abc", "tcp://", "inproc://x",
                                     "", "10.0.0.5", "tcp://10.0.0.5:0"])
def test_a_malformed_scheduler_address_is_a_usage_error(capsys, tmp_path, address):
    # dask's own parse raised ValueErrors that came out as internal errors, and an empty
    # address rendered here instead
    with pytest.raises(SystemExit) as e:
        main(["render", str(GRAMMARS / "sierpinski.pcsg"), "-o", str(tmp_path / "x.png"),
              "--scheduler", address])
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert "argument --scheduler: expected a Dask scheduler's address" in err
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("address", ["tcp://10.0.0.5:8786", "10.0.0.5:8786", "tls://[::1]:8786"])
def test_scheduler_addresses_dask_takes_pass(address):
    from pcsg.arguments import _scheduler
    assert _scheduler(address) == address


def _server(reply: bytes | None):
    """A loopback server that sends `reply` to each connection (None: nothing, and keeps
    it open); its tcp:// address."""
    import socket
    import threading
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(4)
    held = []

    def serve():
        while True:
            try:
                c, _ = srv.accept()
            except OSError:
                return
            held.append(c)
            if reply is not None:
                c.sendall(reply)
    threading.Thread(target=serve, daemon=True).start()
    return f"tcp://127.0.0.1:{srv.getsockname()[1]}", srv


@pytest.mark.parametrize("reply, said", [
    (b"HTTP/1.1 400 Bad Request\r\n\r\n", "it is not a Dask scheduler (it answered "
                                           "'HTTP/1.1'..., a web server?)"),
    (None, "it accepted the connection but sent nothing within 0.3 s"),
    ((300).to_bytes(8, "little") + b"x" * 300, None),     # a handshake's length: may be one
])
def test_a_scheduler_that_is_no_dask_scheduler_is_said(reply, said):
    """Dask's client read a web server's reply as a message length and asked for 3 EiB
    (an internal error, MemoryError), and waited without end on one that says nothing."""
    from pcsg.distributed.cluster import not_a_scheduler
    address, srv = _server(reply)
    try:
        got = not_a_scheduler(address, wait=0.3)
        assert got == said if said is None else said in got
    finally:
        srv.close()


def test_a_scheduler_address_where_nothing_listens_is_left_to_dasks_connect():
    import socket
    from pcsg.distributed.cluster import not_a_scheduler
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))            # bound, never listening: refused
        assert not_a_scheduler(f"tcp://127.0.0.1:{s.getsockname()[1]}", wait=0.3) is None


def test_a_negative_vector_after_its_option_is_its_value(capsys, tmp_path):
    # argparse took `--eye -3,2,1` for an option: "expected one argument"; the camera at
    # negative x could be placed only as --eye=-3,2,1
    s = str(GRAMMARS / "sierpinski.pcsg")
    spaced, joined = tmp_path / "spaced.png", tmp_path / "joined.png"
    assert main(["render", s, "--size", "40x30", "-q", "--eye", "-3,2,1", "--at", "-.5,0,0",
                 "-o", str(spaced)]) == 0
    assert main(["render", s, "--size", "40x30", "-q", "--eye=-3,2,1", "--at=-.5,0,0",
                 "-o", str(joined)]) == 0
    assert spaced.read_bytes() == joined.read_bytes()
    code, _, err = run(capsys, "render", s, "--size", "-40x30", "-o", str(tmp_path / "n.png"))
    assert code == 2 and "--size -40x30: width and height must be at least 1" in err


@pytest.mark.parametrize("eye", ["1e-200,0,0", "0,1e-300,2e-300", "1e149,0,0"])
def test_an_eye_very_near_or_far_from_at_still_frames_a_picture(tmp_path, eye):
    # the sum of squares of its distance underflowed to 0: every pixel NaN, all black
    import warnings
    import numpy as np
    from PIL import Image
    out = tmp_path / "c.png"
    with warnings.catch_warnings():
        warnings.simplefilter("error")          # numpy's too: none may be printed
        assert main(["render", str(GRAMMARS / "sierpinski.pcsg"), "-o", str(out), "--size",
                     "40x30", "-q", "--eye", eye, "--at", "0,0,0"]) == 0
    assert np.ptp(np.asarray(Image.open(out))) > 0


def test_a_directive_value_in_error_is_reported_once(tmp_path):
    from pcsg.compiler import compile_text
    from pcsg.language.errors import PcsgError
    with pytest.raises(PcsgError) as e:
        compile_text("#camera eye=(c, 1, 1) at=(0, 0, 0)\nsphere\n", "t.pcsg")
    assert [d.message for d in e.value.diagnostics] == ["undefined name 'c'"]


@pytest.mark.parametrize("args, code, message", [
    (["--set", "c=1..2", "--set", "c=3"], 2, "--set c is given twice"),
    (["--set", "z=1..3"], 1, "cannot set 'z': it is not an initial parameter"),
    (["--set", "c=1..100000000"], 2, "100,000,000 images; a sweep renders at most 10,000"),
    # the options' errors too: they left an empty directory
    (["--set", "c=1..2", "--threads", "0"], 2, "--threads 0: give 1 or more"),
    (["--set", "c=1..2", "--threads", "1", "--workers", "2"], 2, "--threads counts this"),
])
def test_sweep_usage_errors_are_said_once_before_any_image(capsys, tmp_path, args, code,
                                                          message):
    out = tmp_path / "out"
    try:
        got = main(["sweep", str(GRAMMARS / "sierpinski.pcsg"), *args, "-o", str(out), "-q",
                    "--size", "16x12"])
    except SystemExit as e:         # argparse's own
        got = e.code
    err = capsys.readouterr().err
    assert got == code and err.count(message) == 1 and not out.exists()


@pytest.mark.parametrize("command", ["render", "sweep"])
def test_an_image_whose_name_is_a_directory_is_refused_before_anything_renders(
        capsys, tmp_path, monkeypatch, command):
    """It rendered to the end and then failed, exit 1, on 'Is a directory' (QA), where -o
    and --depth naming a directory are refused at once."""
    from pcsg.render import job
    monkeypatch.setattr(job, "render_file", lambda *a, **k: pytest.fail("it rendered"))
    monkeypatch.chdir(tmp_path)
    if command == "render":
        (tmp_path / "sierpinski.png").mkdir()
        args = ["render", str(GRAMMARS / "sierpinski.pcsg"), str(GRAMMARS / "table_tower.pcsg")]
        blocked = "sierpinski.png"
    else:
        (tmp_path / "sw" / "sierpinski_c=2.png").mkdir(parents=True)
        args = ["sweep", str(GRAMMARS / "sierpinski.pcsg"), "--set", "c=1..3", "-o", "sw/"]
        blocked = "sw/sierpinski_c=2.png"
    code, out, err = run(capsys, *args, "--size", "8x6")
    assert code == 2 and out == ""
    assert err.strip().endswith(f"{blocked} is a directory, where an image goes: move it, "
                                f"or write the images elsewhere with -o")
    assert sorted(p.name for p in tmp_path.rglob("*.png")) == [Path(blocked).name]


def test_sweep_into_a_file_is_a_usage_error(capsys, tmp_path):
    out = tmp_path / "s.png"
    out.write_bytes(b"old")
    assert main(["sweep", str(GRAMMARS / "sierpinski.pcsg"), "--set", "c=1..2", "-o",
                 str(out)]) == 2
    assert "a sweep writes one image per value into a directory" in capsys.readouterr().err
    assert out.read_bytes() == b"old"
    # a name like an image's, not there yet: it made a directory of that name
    assert main(["sweep", str(GRAMMARS / "sierpinski.pcsg"), "--set", "c=1..2", "-o",
                 str(tmp_path / "x.png")]) == 2
    assert f"name it, e.g. -o {tmp_path / 'x'}/" in capsys.readouterr().err
    assert not (tmp_path / "x.png").exists()


@pytest.mark.parametrize("text, message", [
    ("{c = 0} S\nS 1/c\n1: S → sphere\n", "gives inf, which is not a finite number (with c = 0)"),
    ("{c = 3} S\nS c\n1: S → sphere\n2: S → cube\n",
     "gives 3, which names rule 3, but 'S' has rules 1..2 (with c = 3)"),
    ("{c = 4} S\nS if(c > 0, 2, 3)\n1: S → sphere\n2: S → {c = c - 1} move(1, 0, 0) S\n",
     "gives 3, which names rule 3, but 'S' has rules 1..2 (with c = 0)"),   # four levels down
])
def test_check_reports_a_selection_the_derivation_makes_invalid(capsys, tmp_path, text,
                                                               message):
    # notation §6 calls it an error and §9 has check report every error; stats and expand
    # failed on these while check said "ok"
    path = tmp_path / "s.pcsg"
    path.write_text(text, encoding="utf-8")
    assert main(["check", str(path)]) == 1
    err = capsys.readouterr().err
    assert "s.pcsg:2:3: error: the selection of module 'S' " + message in err


def test_check_does_not_derive_a_graftal_to_the_end(capsys):
    assert main(["check", "-q", str(GRAMMARS / "barnsley_fern.pcsg")]) == 0


def test_a_picture_of_nothing_says_so(capsys, tmp_path):
    # the render wrote a sky without a word
    src = tmp_path / "away.pcsg"
    src.write_text("#camera eye=(0, -5, 0) at=(0, -10, 0)\nsphere\n", encoding="utf-8")
    assert main(["render", str(src), "--size", "40x30", "-o", str(tmp_path / "a.png")]) == 0
    assert "warning: no ray met the object" in capsys.readouterr().err
    # c only grows: every instance shrinks on towards the origin, and what is drawn is
    # the sphere --max-depth ends it with, 2^-64 across, framed as any object is (it was
    # "no ray met", framed as 1e-9 across at least); the render says where it stopped
    src = tmp_path / "up.pcsg"
    src.write_text("{c = 3} S\nS if(c > 0, 2, 1)\n1: S → sphere\n"
                   "2: S → {c = c+1} uscale(0.5) S\n", encoding="utf-8")
    assert main(["render", str(src), "--size", "40x30", "-o", str(tmp_path / "u.png")]) == 0
    err = capsys.readouterr().err
    assert "no ray met" not in err and "depth limit: instances at --max-depth 64" in err
    assert main(["render", str(GRAMMARS / "sierpinski.pcsg"), "--size", "40x30",
                 "-o", str(tmp_path / "b.png")]) == 0
    assert "no ray met" not in capsys.readouterr().err


def test_a_sweep_of_one_value_renders_it(capsys, tmp_path):
    # c=2..2 was "give one parameter to sweep (0 ranges given)"
    out = tmp_path / "sweep"
    assert main(["sweep", str(GRAMMARS / "sierpinski.pcsg"), "--set", "c=2..2", "--size",
                 "24x18", "-o", str(out), "-q"]) == 0
    assert [p.name for p in out.glob("*.png")] == ["sierpinski_c=2.png"]


def test_a_local_sweep_reports_each_image_once(capsys, tmp_path):
    # each image was reported twice: "[1/2] ... on this process" and its summary line
    out = tmp_path / "sweep"
    assert main(["sweep", str(GRAMMARS / "sierpinski.pcsg"), "--set", "c=1..2", "--size",
                 "24x18", "-o", str(out)]) == 0
    captured = capsys.readouterr()
    lines = (captured.out + captured.err).splitlines()
    for name in ("sierpinski_c=1.png", "sierpinski_c=2.png"):
        assert len([line for line in lines if name in line]) == 1, lines
    assert "rendered 2 of 2 images" in captured.out


def test_a_sweeps_notes_name_their_image(capsys, tmp_path):
    """Each image's level-of-detail note said the file's name alone."""
    out = tmp_path / "sweep"
    assert main(["sweep", str(GRAMMARS / "sierpinski.pcsg"), "--set", "c=5..6", "--size",
                 "24x18", "-o", str(out), "-q"]) == 0
    err = capsys.readouterr().err
    for c in (5, 6):
        assert f"sierpinski.pcsg (sierpinski_c={c}.png): level of detail: " in err


def test_a_sweep_names_itself_and_the_image_that_failed(capsys, tmp_path):
    """--strict's failure of one image said "pcsg render: sel.pcsg: ..." in a sweep."""
    src = tmp_path / "sel.pcsg"
    src.write_text("{s = 1} (S ∪ move(0,0,-1) plane)\nS s\n1: S → sphere\n2: S → cube\n",
                   encoding="utf-8")
    out = tmp_path / "sweep"
    assert main(["sweep", str(src), "--set", "s=1..3", "--strict", "--size", "24x18",
                 "--shadow-samples", "1", "-o", str(out), "-q"]) == 1
    err = capsys.readouterr().err
    assert f"pcsg sweep: {src} (sel_s=3.png): --strict: runtime errors in the grammar or " \
        "limits of the walk, nothing written:" in err and "pcsg render" not in err
    # the faults a render warns of are what --strict fails on: errors, said so
    assert f"{src}:2:3: error: the selection of module 'S' gives 3" in err
    assert sorted(p.name for p in out.glob("*.png")) == ["sel_s=1.png", "sel_s=2.png"]


def test_a_sweep_whose_list_of_images_cannot_be_written_renders_nothing(capsys, tmp_path):
    """A directory where the sweep's manifest goes failed the sweep after every image."""
    out = tmp_path / "sweep"
    (out / ".pcsg-done.json").mkdir(parents=True)
    assert main(["sweep", str(GRAMMARS / "sierpinski.pcsg"), "--set", "c=1..2", "--size",
                 "24x18", "-o", str(out), "-q"]) == 1
    err = capsys.readouterr().err
    assert f"{out / '.pcsg-done.json'} is not a file" in err
    assert not list(out.glob("*.png"))


def test_stats_json_of_several_files_is_a_list_whatever_fails(capsys, tmp_path, sierpinski):
    bad = tmp_path / "bad.pcsg"
    bad.write_text("sphere ∪\n", encoding="utf-8")
    code, out, _ = run(capsys, "stats", "--json", str(sierpinski), str(bad))
    assert code == 1 and isinstance(json.loads(out), list) and len(json.loads(out)) == 1
    code, out, _ = run(capsys, "stats", "--json", str(sierpinski))
    assert code == 0 and isinstance(json.loads(out), dict)


@pytest.mark.parametrize("value", ["0", "-5"])
def test_expand_max_chars_below_one_is_a_usage_error(capsys, sierpinski, value):
    code, _, err = run(capsys, "expand", str(sierpinski), "--max-chars", value)
    assert code == 2 and f"--max-chars {value}: give 1 or more" in err


def test_expand_takes_at_most_the_levels_a_derivation_may_have(capsys, tmp_path):
    """-n 20000 stopped at 10,000 steps without a word, and its header said 20000."""
    source = tmp_path / "chain.pcsg"
    source.write_text("S\n1: S -> move(1, 0, 0) S\n", encoding="utf-8")
    code, _, err = run(capsys, "expand", str(source), "-n", "10001")
    assert code == 2 and "-n 10001: expand takes at most 10000 steps" in err
    code, out, _ = run(capsys, "expand", str(source), "-n", "10000")
    header, word = out.splitlines()[:2]
    assert code == 0 and header.endswith("chain.pcsg after 10000 derivation steps")
    assert word.count("move(1, 0, 0)") == 10000


def test_expands_header_names_the_values_set(capsys, tmp_path):
    """The file's comments are copied as written: after `--set c=2` the Sierpinski's
    still told of "order 6 gives 4^6 = 4096 tetrahedra", and nothing said c was 2."""
    src = tmp_path / "rod.pcsg"
    src.write_text("// c rods of length 6\n{c = 6; r = 0.1} S\nS if(c > 0, 1, 2)\n"
                   "1: S → scale(r, r, 1) cylinder ∪ move(0, 0, 2) {c = c - 1} S\n"
                   "2: S → sphere\n", encoding="utf-8")
    code, out, _ = run(capsys, "expand", str(src), "--set", "c=2", "--set", "r=.5")
    assert code == 0 and out.splitlines()[:2] == [
        f"// {src} --set c=2 --set r=0.5 after 1 derivation step; its comments are as the "
        f"file wrote them", "// c rods of length 6"]
    code, out, _ = run(capsys, "expand", str(src))
    assert out.splitlines()[0] == f"// {src} after 1 derivation step"


def test_expand_says_pixels_were_taken_as_infinite_and_stats_lists_no_pixels(capsys, tmp_path):
    forest = str(GRAMMARS / "pixel_forest.pcsg")
    code, _, err = run(capsys, "expand", forest, "-n", "1", "-o", str(tmp_path / "w.pcsg"))
    assert code == 0 and "selections that read `pixels` took it as +inf" in err
    code, out, _ = run(capsys, "stats", "--json", forest)
    assert code == 0 and "pixels" not in json.loads(out)["parameters"]
    code, _, err = run(capsys, "expand", str(GRAMMARS / "sierpinski.pcsg"), "-n", "1",
                       "-o", str(tmp_path / "s.pcsg"))
    assert code == 0 and "pixels" not in err


@pytest.mark.parametrize("argv, said", [
    (["render", "{f}", "-o", "{d}/same.png", "--depth", "{d}/same.png"],
     "--depth {d}/same.png: the depths are written as a NumPy array; name the file same.npy"),
    (["render", "{f}", "-o", "{d}/x.png", "--depth", "{f}"],
     "--depth {f}: the depths are written as a NumPy array; name the file s.npy"),
    (["render", "{f}", "-o", "{d}/x.png", "--depth", "{d}/no/x.npy"],
     "--depth {d}/no/x.npy: the directory {d}/no does not exist"),
    (["render", "{f}", "-o", "{f}"], "-o {f}: pcsg writes PNG images; name the file s.png"),
    (["export", "{f}", "--pov", "{f}"], "--pov {f}: that is {f}, which this command reads"),
    (["graph", "{f}", "-o", "{f}"], "-o {f}: that is {f}, which this command reads"),
    (["expand", "{f}", "-o", "{f}"], "-o {f}: that is {f}, which this command reads"),
    # POV-Ray's text went into an image's name, or over another grammar, with exit 0; so
    # did graph's dot text over a grammar, and expand's grammar into an image's name
    (["export", "{f}", "--pov", "{d}/x.PNG"],
     "--pov {d}/x.PNG: the file is a POV-Ray scene, not an image; name it x.pov"),
    (["export", "{f}", "--pov", "{d}/x.pcsg"],
     "--pov {d}/x.pcsg: the file is a POV-Ray scene, not a grammar; name it x.pov"),
    (["graph", "{f}", "-o", "{d}/x.pcsg"],
     "-o {d}/x.pcsg: the file is Graphviz text, not a grammar; name it x.dot"),
    (["graph", "{f}", "-o", "{d}/x.pov"],
     "-o {d}/x.pov: the file is Graphviz text, not a POV-Ray scene; name it x.dot"),
    (["expand", "{f}", "-o", "{d}/x.png"],
     "-o {d}/x.png: the file is a grammar, not an image; name it x.pcsg"),
    (["expand", "{f}", "-o", "{d}/x.dot"],
     "-o {d}/x.dot: the file is a grammar, not Graphviz text; name it x.pcsg"),
])
def test_an_output_over_an_input_or_the_image_is_refused(capsys, sierpinski, tmp_path, argv,
                                                         said):
    # `--depth same.png` replaced the picture with an array and `--pov s.pcsg` the grammar,
    # with exit 0; a --depth into a missing directory failed after writing the image
    fill = {"f": str(sierpinski), "d": str(tmp_path)}
    grammar = sierpinski.read_bytes()
    code, _, err = run(capsys, *[a.format(**fill) for a in argv])
    assert code == 2 and said.format(**fill) in err
    assert sierpinski.read_bytes() == grammar
    assert sorted(p.name for p in tmp_path.iterdir()) == [sierpinski.name]


@pytest.mark.parametrize("command, option", [("expand", "-o"), ("graph", "-o"),
                                             ("export", "--pov")])
def test_an_output_onto_a_hard_link_of_the_input_is_refused(capsys, sierpinski, tmp_path,
                                                             command, option):
    """`expand s.pcsg -o link.pcsg`, link.pcsg a hard link of s.pcsg, was written: the
    link was replaced and the file it shared kept under its other name."""
    link = tmp_path / "link.pcsg"
    os.link(sierpinski, link)
    code, _, err = run(capsys, command, str(sierpinski), option, str(link))
    assert code == 2 and f"{option} {link}: that is {sierpinski}, which this command reads" in err
    assert os.path.samefile(link, sierpinski)


def test_an_unknown_option_before_the_command_is_the_top_level_s(capsys, sierpinski):
    with pytest.raises(SystemExit):
        main(["--bogus", "check", str(sierpinski)])
    assert "pcsg: error: unrecognized arguments: --bogus" in capsys.readouterr().err


@pytest.mark.parametrize("argv", [["render", "{f}", "--bogus"],
                                  ["sweep", "{f}", "--set", "c=1..2", "--timings"],
                                  ["animate", "{f}", "--timings"]])
def test_an_unknown_option_is_said_by_its_command(capsys, sierpinski, argv):
    # the top level said it, with its own usage line: "usage: pcsg [-h] [--version] COMMAND"
    with pytest.raises(SystemExit) as e:
        main([a.format(f=sierpinski) for a in argv])
    err = capsys.readouterr().err
    assert e.value.code == 2
    assert f"pcsg {argv[0]}: error: unrecognized arguments: {argv[-1]}" in err
    assert f"usage: pcsg {argv[0]} " in err


def test_files_may_follow_options(capsys, sierpinski, tmp_path):
    # argparse takes a command's list of files in one run: the second was "unrecognized"
    tower = GRAMMARS / "table_tower.pcsg"
    out = tmp_path / "out"
    assert main(["render", str(sierpinski), "--size", "16x12", str(tower), "-q", "-o",
                 f"{out}/"]) == 0
    assert sorted(p.name for p in out.iterdir()) == [f"{sierpinski.stem}.png", "table_tower.png"]
    assert main(["check", str(sierpinski), "-q", str(tower)]) == 0
    # but not an unknown option among them, nor a second file where one is read
    for argv in (["check", str(sierpinski), "--bogus", str(tower)],
                 ["export", str(sierpinski), "--pov", str(tmp_path / "s.pov"), str(tower)]):
        with pytest.raises(SystemExit) as e:
            main(argv)
        assert e.value.code == 2 and "unrecognized arguments" in capsys.readouterr().err


def test_an_ao_distance_without_occlusion_is_said(capsys, sierpinski, tmp_path):
    # it was ignored without a word: the picture the same bytes as without it
    out = str(tmp_path / "s.png")
    assert main(["render", str(sierpinski), "-o", out, "--size", "16x12", "--ao-distance",
                 "0.5"]) == 0
    assert "--ao-distance does nothing without ambient occlusion" in capsys.readouterr().err
    assert main(["render", str(sierpinski), "-o", out, "--size", "16x12", "--ao-distance",
                 "0.5", "--ao", "2"]) == 0
    assert "--ao-distance" not in capsys.readouterr().err


def test_a_bad_depth_is_refused_before_the_output_directory_is_made(capsys, sierpinski,
                                                                    tmp_path):
    code, _, err = run(capsys, "render", str(sierpinski), "-o", f"{tmp_path}/new/",
                       "--depth", f"{tmp_path}/d.txt")
    assert code == 2 and "--depth" in err and not (tmp_path / "new").exists()


def test_an_export_too_deep_names_the_option_that_ends_it(capsys, tmp_path):
    # "the derivation is deeper than 10000 levels at 'S'", and nothing of what to do
    src = tmp_path / "up.pcsg"
    src.write_text("{c = 1} S\nS if(c > 0, 2, 1)\n1: S → cube\n"
                   "2: S → {c = c + 1} (cube ∪ move(2, 0, 0) uscale(0.5) S)\n", encoding="utf-8")
    code, _, err = run(capsys, "export", str(src), "--pov", str(tmp_path / "up.pov"), "-q")
    assert code == 1 and "give --max-depth N to cut it at depth N" in err
    code, _, err = run(capsys, "export", str(src), "--pov", str(tmp_path / "up.pov"), "-q",
                       "--max-depth", "5")
    assert code == 0


def test_a_reader_that_leaves_does_not_end_a_batch(tmp_path):
    # `pcsg render *.pcsg -o out/ | head -1`: the batch ended at its second status line,
    # with exit status 0 and the other images never written
    files = []
    for k in range(3):
        files.append(tmp_path / f"g{k}.pcsg")
        files[-1].write_text(f"move({k}, 0, 0) sphere\n", encoding="utf-8")
    out = tmp_path / "out"
    out.mkdir()
    read, write = os.pipe()
    os.close(read)                  # every write to stdout fails at once
    try:
        r = subprocess.run([sys.executable, "-m", "pcsg", "render", *map(str, files), "-o",
                            f"{out}/", "--size", "16x12", "-q"], stdout=write,
                           stderr=subprocess.PIPE, text=True, timeout=300)
    finally:
        os.close(write)
    assert (r.returncode, r.stderr) == (0, "")
    assert sorted(p.name for p in out.iterdir()) == ["g0.png", "g1.png", "g2.png"]


@pytest.mark.parametrize("both", [False, True])
def test_a_reader_that_leaves_does_not_end_a_check(tmp_path, both):
    """`pcsg check dir | head -1`: the files after the first were never checked and the
    status was 0, the error of the last unsaid; it goes to stderr, and the status is 1,
    also where stderr went to the pipe that closed (`2>&1 | head -1`)."""
    for k in range(3):
        (tmp_path / f"a{k}.pcsg").write_text("sphere\n", encoding="utf-8")
    (tmp_path / "z.pcsg").write_text("S\n1: S -> foo\n", encoding="utf-8")
    read, write = os.pipe()
    os.close(read)                  # every write to the pipe fails at once
    try:
        r = subprocess.run([sys.executable, "-m", "pcsg", "check", str(tmp_path)],
                           stdout=write, stderr=write if both else subprocess.PIPE,
                           text=True, timeout=300)
    finally:
        os.close(write)
    assert r.returncode == 1
    if not both:
        assert "z.pcsg:2:9: error: undefined name 'foo'" in r.stderr
        assert "Traceback" not in r.stderr and "ok (" not in r.stderr


def test_streams_without_a_file_are_left_as_they_are(monkeypatch):
    """A host that put its own objects in sys.stdout and sys.stderr (io.StringIO, or
    None): after a broken pipe, check's clean-up asked them for a file descriptor."""
    import io
    from pcsg.cli import _drop_broken_streams
    out = io.StringIO()
    monkeypatch.setattr(sys, "stdout", out)
    monkeypatch.setattr(sys, "stderr", None)
    _drop_broken_streams()
    assert sys.stdout is out


def test_an_image_on_standard_output_gets_no_status_line_inside(tmp_path):
    # the summary came after the PNG's end, in its stream; it goes to stderr there
    r = subprocess.run([sys.executable, "-m", "pcsg", "render", str(GRAMMARS / "sierpinski.pcsg"),
                        "-o", "/dev/stdout", "--size", "16x12", "-q", "--set", "c=1"],
                       capture_output=True, timeout=300)
    assert r.returncode == 0 and r.stdout.startswith(b"\x89PNG")
    assert r.stdout.endswith(b"IEND\xaeB`\x82")
    assert b"/dev/stdout: 16x12," in r.stderr


def test_main_gives_the_callers_standard_output_back(capsys, tmp_path):
    # it kept its wrapper: a caller's prints, and a later render's status line over an
    # image on /dev/stdout, went where the first render had sent its own
    before = sys.stdout
    src = tmp_path / "g.pcsg"
    src.write_text("sphere\n", encoding="utf-8")
    assert main(["render", str(src), "-o", str(tmp_path / "g.png"), "--size", "8x6", "-q"]) == 0
    assert sys.stdout is before
    assert "g.png: 8x6" in capsys.readouterr().out


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="no /dev/full here")
def test_standard_output_that_cannot_be_written_is_said(tmp_path):
    # a full disk under stdout: a traceback and status 120 where main flushed it itself
    src = tmp_path / "g.pcsg"
    src.write_text("sphere\n", encoding="utf-8")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}   # as users run it
    with open("/dev/full", "w") as full:
        r = subprocess.run([sys.executable, "-m", "pcsg", "render", str(src), "-o",
                            str(tmp_path / "g.png"), "--size", "8x6", "-q"], stdout=full,
                           stderr=subprocess.PIPE, text=True, timeout=300, env=env)
    assert (r.returncode, r.stderr) == (1, "pcsg: error: No space left on device\n")
    # expand's text is its product: a closed stdout is said, not lost
    r = subprocess.run(f"{shlex.quote(sys.executable)} -m pcsg expand {src} >&-", shell=True,
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 2 and "standard output is closed: give -o FILE" in r.stderr


def test_a_render_with_standard_output_closed_writes_its_image(tmp_path):
    # `pcsg render ... >&-`: "internal error" and status 120, the PNG written
    src = tmp_path / "g.pcsg"
    src.write_text("sphere\n", encoding="utf-8")
    r = subprocess.run(f"{shlex.quote(sys.executable)} -m pcsg render {src} -o "
                       f"{tmp_path / 'g.png'} --size 8x6 -q >&-", shell=True,
                       capture_output=True, text=True, timeout=300)
    assert (r.returncode, r.stderr) == (0, "") and (tmp_path / "g.png").exists()


@pytest.mark.parametrize("value", ["inf", "nan", "0", "-1"])
def test_an_ao_distance_must_be_positive_and_finite(capsys, sierpinski, tmp_path, value):
    # inf was refused as not "a positive distance"
    assert main(["render", str(sierpinski), "-o", str(tmp_path / "s.png"), "--size", "16x12",
                 "--ao", "2", f"--ao-distance={value}"]) == 2
    assert "give a positive finite distance" in capsys.readouterr().err


def test_numpys_warnings_do_not_reach_the_user(tmp_path):
    """Overflow in the bounds of a huge shear printed numpy's RuntimeWarning and its
    source line (pytest records warnings itself, so a process of its own shows it)."""
    src = tmp_path / "rw.pcsg"
    src.write_text("#camera eye=(4,-5,3) at=(0,0,0)\nsphere ∪ xshear(1e308, 1e308) sphere\n",
                   encoding="utf-8")
    r = subprocess.run([sys.executable, "-m", "pcsg", "render", str(src), "--size", "16x12",
                        "-q", "-o", str(tmp_path / "rw.png")], capture_output=True, text=True,
                       timeout=600)
    assert r.returncode == 0, r.stderr
    assert "RuntimeWarning" not in r.stderr and "Warning" not in r.stderr, r.stderr


def test_threads_sets_the_tracers_threads_and_not_the_bytes(capsys, tmp_path, sierpinski):
    """--threads N: the tracer's threads in this process (NUMBA_NUM_THREADS alone set
    them before), at most the cores; the PNG the same at any N."""
    from numba import config

    from pcsg.trace import jit
    before = jit.threads()
    try:
        pngs = []
        for n in (1, 2):
            out = tmp_path / f"t{n}.png"
            assert run(capsys, "render", str(sierpinski), "--size", "64x48", "--threads",
                       str(n), "-q", "-o", str(out))[0] == 0
            assert jit.threads() == min(n, config.NUMBA_NUM_THREADS)
            pngs.append(out.read_bytes())
        assert pngs[0] == pngs[1]
    finally:
        jit.set_threads(before)


@pytest.mark.parametrize("argv, said", [
    (("--threads", "0"), "--threads 0: give 1 or more"),
    (("--threads", "1", "--workers", "2"), "--threads counts this process's threads and "
                                            "--workers renders on a cluster's workers"),
    (("--threads", "1", "--scheduler", "tcp://localhost:8786"), "and --scheduler renders"),
])
def test_threads_usage_errors(capsys, tmp_path, sierpinski, argv, said):
    from pcsg.trace import jit
    before = jit.threads()
    code, _, err = run(capsys, "render", str(sierpinski), "-o", str(tmp_path / "x.png"), *argv)
    assert code == 2 and said in err
    assert jit.threads() == before
