"""The command's file parsed in a child process while the command imports numba
(pcsg/language/prefetch.py): the same pictures, output and errors as a parse in the
command's own process, which then never imports lark; a file that changed after
the child read it is parsed again; and Ctrl-C during the imports ends the command as it
does later."""
import os
import pickle
import subprocess
import sys

from pcsg.language import PcsgError

from .conftest import GRAMMARS, ROOT

ENV = dict(os.environ, PCSG_BOUNDS_CACHE="0")
OFF = dict(ENV, PCSG_PREFETCH="0")


def pcsg(*argv, env=ENV):
    return subprocess.run([sys.executable, "-m", "pcsg", *map(str, argv)], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=600)


# cli.run's steps, then what the command's process imported: run() itself leaves by
# os._exit, without a word after main
STEPS = """
import sys
from pcsg import cli
from pcsg.language import prefetch
argv = sys.argv[1:]
prefetch.first_file(argv)
cli.import_kernels()
code = cli.main(argv)
print(code, "lark" in sys.modules, "pcsg.language.parser" in sys.modules)
"""


def test_a_render_is_the_same_png_with_the_file_parsed_beside_the_imports(tmp_path):
    for name, setting in (("sierpinski", "c=4"), ("carpenter_terrain", "cnt=4")):
        pngs = []
        for env in (ENV, OFF):
            out = tmp_path / f"{name}-{len(pngs)}.png"
            p = pcsg("render", GRAMMARS / f"{name}.pcsg", "--set", setting, "--size", "48x36",
                     "-q", "-o", out, env=env)
            assert p.returncode == 0, p.stderr
            pngs.append(out.read_bytes())
        assert pngs[0] == pngs[1]


def test_the_command_that_took_the_childs_parse_never_imports_lark(tmp_path):
    p = subprocess.run([sys.executable, "-c", STEPS, "check", str(GRAMMARS / "sierpinski.pcsg")],
                       cwd=ROOT, env=ENV, capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    assert p.stdout.splitlines()[-1] == "0 False False"
    # and without the child it parses, with lark
    p = subprocess.run([sys.executable, "-c", STEPS, "check", str(GRAMMARS / "sierpinski.pcsg")],
                       cwd=ROOT, env=OFF, capture_output=True, text=True, timeout=600)
    assert p.stdout.splitlines()[-1] == "0 True True"


def test_a_path_the_command_writes_otherwise_still_takes_the_childs_parse(tmp_path):
    """`pcsg render ./x.pcsg` names the file `x.pcsg` in its messages, as it always did."""
    f = tmp_path / "w.pcsg"
    f.write_text("{c = 2} S\nS if(c > 0, 2, 1)\n1: S → sphere\n"
                 "2: S → sphere ∪ move(2,0,0) uscale(0.5) S\n", encoding="utf-8")   # endless
    argv = ["render", "./w.pcsg", "--size", "32x24", "-q", "-o", str(tmp_path / "w.png")]
    p = subprocess.run([sys.executable, "-c", STEPS, *argv], cwd=tmp_path, env=ENV,
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    assert p.stdout.splitlines()[-1] == "0 False False"
    off = subprocess.run([sys.executable, "-m", "pcsg", *argv], cwd=tmp_path, env=OFF,
                         capture_output=True, text=True, timeout=600)
    assert "w.pcsg:4:" in off.stderr and p.stderr == off.stderr


def test_errors_and_warnings_read_the_same_either_way(tmp_path):
    bad = tmp_path / "bad.pcsg"
    bad.write_text("{c = 1} S\n1: S → sphere ∪\n  move(1, 0 S\n", encoding="utf-8")
    undefined = tmp_path / "undefined.pcsg"
    undefined.write_text("{c = 1} S\n1: S → foo\n", encoding="utf-8")
    endless = tmp_path / "endless.pcsg"
    endless.write_text("{c = 2} S\nS if(c > 0, 2, 1)\n1: S → sphere\n"
                       "2: S → sphere ∪ move(2,0,0) uscale(0.5) S\n", encoding="utf-8")
    for f in (bad, undefined, endless):
        on, off = pcsg("check", f), pcsg("check", f, env=OFF)
        assert (on.returncode, on.stdout, on.stderr) == (off.returncode, off.stdout, off.stderr)
        assert str(f) in on.stderr
    assert pcsg("check", bad).returncode == 1 and ":3:" in pcsg("check", bad).stderr


CHANGED = """
import sys, time
from pathlib import Path
from pcsg.language import prefetch
from pcsg.compiler import compile_file
path = Path(sys.argv[1])
prefetch.start(str(path))
time.sleep(1.0)                 # the child has read and parsed the first text by now
path.write_text(sys.argv[2], encoding="utf-8")
graph = compile_file(str(path))
print(len(graph.nodes), "pcsg.language.parser" in sys.modules)
"""


def test_a_file_changed_after_the_child_read_it_is_parsed_again(tmp_path):
    f = tmp_path / "s.pcsg"
    f.write_text("S\n1: S → sphere\n", encoding="utf-8")
    three = "S\n1: S → sphere ∪ move(2,0,0) cube\n"
    p = subprocess.run([sys.executable, "-c", CHANGED, str(f), three], cwd=ROOT, env=ENV,
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    nodes, parsed_here = p.stdout.split()
    unchanged = subprocess.run([sys.executable, "-m", "pcsg", "stats", str(f)], cwd=ROOT,
                               env=OFF, capture_output=True, text=True, timeout=600)
    assert f"nodes        {nodes} " in unchanged.stdout, unchanged.stdout
    assert parsed_here == "True"


def test_a_pcsg_error_crosses_processes_whole():
    from pcsg.compiler import compile_text
    try:
        compile_text("{c = 1} S\n1: S → foo\n", "x.pcsg")
    except PcsgError as e:
        back = pickle.loads(pickle.dumps(e))
        assert type(back) is PcsgError and str(back) == str(e)
        assert [d.format() for d in back.diagnostics] == [d.format() for d in e.diagnostics]
    else:
        raise AssertionError("no error")


# Ctrl-C as the imports run: the command's own words, not a traceback from numba's imports
INTERRUPTED = """
import os, signal
signal.signal(signal.SIGINT, signal.default_int_handler)   # not ignored, as in a `&` job
from pcsg import cli
imports = cli.import_kernels
def import_kernels():
    os.kill(os.getpid(), signal.SIGINT)
    imports()
cli.import_kernels = import_kernels
cli.run()
"""


def test_ctrl_c_during_the_imports_ends_the_command_as_ctrl_c_after_them(tmp_path):
    p = subprocess.run([sys.executable, "-c", INTERRUPTED, "render",
                        str(GRAMMARS / "sierpinski.pcsg"), "-o", str(tmp_path / "s.png")],
                       cwd=ROOT, env=ENV, capture_output=True, text=True, timeout=600)
    assert (p.returncode, p.stderr) == (130, "pcsg: interrupted\n")
    assert not (tmp_path / "s.png").exists()


def test_no_child_is_forked_beside_other_threads():
    """A lock another thread holds at the fork would stay held in the child for good."""
    import threading
    from pcsg.language import prefetch
    done = threading.Event()
    t = threading.Thread(target=done.wait)
    t.start()
    try:
        prefetch.start(str(GRAMMARS / "sierpinski.pcsg"))
        assert prefetch._children == {}
    finally:
        done.set()
        t.join()


FORKED = """
import os, sys
from pcsg.language import prefetch
path = sys.argv[1]
prefetch.start(path)
(pid, pipe), = prefetch._children.values()
worker = os.fork()
if worker == 0:         # as animate's and sweep's workers are made
    try:
        os.fstat(pipe)
        os._exit(1)     # the pipe is still open here
    except OSError:
        os._exit(0 if prefetch._children == {} else 2)
_, status = os.waitpid(worker, 0)
text = open(path, encoding="utf-8").read()
print(os.waitstatus_to_exitcode(status), type(prefetch.take(path, text)).__name__)
"""


def test_a_process_forked_later_lets_the_parent_take_the_childs_parse():
    p = subprocess.run([sys.executable, "-c", FORKED, str(GRAMMARS / "carpenter_terrain.pcsg")],
                       cwd=ROOT, env=ENV, capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    assert p.stdout.split() == ["0", "tuple"]
