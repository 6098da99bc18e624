import contextlib
import os
import signal
from pathlib import Path

import pytest
from hypothesis import settings

from pcsg.compiler import compile_text
from pcsg.language.errors import PcsgError

# every render walks its bounds, as the tests of that walk (its progress, Ctrl-C,
# --timeout, budgets) need, and no test reads what another kept; tests/test_boxcache.py
# turns the cache on, in a folder of its own
os.environ["PCSG_BOUNDS_CACHE"] = "0"

# no example has a deadline: hypothesis's 200 ms default is a timed assertion, and on this
# shared 2-core machine, with the bounds-check pass beside the main one, an example of the
# hash mixers' test (test_vm.py) once took 252 ms
settings.register_profile("pcsg", deadline=None)
settings.load_profile("pcsg")

ROOT = Path(__file__).resolve().parent.parent
GRAMMARS = ROOT / "grammars"


@contextlib.contextmanager
def sigint_reaches_children():
    """Processes started inside get SIGINT at its default, as a command typed at a
    terminal has it. A test run started in the background by a script (`cmd &`) ignores
    SIGINT, an ignored signal stays ignored across exec, and the test's Ctrl-C would
    then never reach the command it interrupts."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def errors_of(text: str, file: str = "t.pcsg", **overrides) -> list:
    """The diagnostics compiling `text` raises (fails the test if it compiles)."""
    with pytest.raises(PcsgError) as e:
        compile_text(text, file, overrides)
    return e.value.diagnostics


def first_error(text: str, **overrides) -> str:
    d = errors_of(text, **overrides)[0]
    return f"{d.location.line}:{d.location.column}: {d.message}" if d.location else d.message


SIERPINSKI = """{c = 6} S                          // start node and initialisation of c
S if(c > 0, 2, 1)                  // module S and its selection function
1: S → tetrahedron                 // terminating rule
2: S → {c = c-1} (move(0.5,0.5,0.5) uscale(0.5) S ∪     // generating rule
                  move(-0.5,-0.5,0.5) uscale(0.5) S ∪
                  move(0.5,-0.5,-0.5) uscale(0.5) S ∪
                  move(-0.5,0.5,-0.5) uscale(0.5) S)
"""

# Fig. 3a exactly as the paper prints it: the block binds to the first operand only.
FIG3A_AS_PRINTED = """{c=6} S // definition of the start node and initialization of c
S if(c > 0,2,1) // declaration of the module S and its selection function
1: S → tetrahedron // terminating rule
2: S → {c=c-1} move(0.5,0.5,0.5) uscale(0.5) S ∪ // generating rule
           move(-0.5,-0.5,0.5) uscale(0.5) S ∪
           move(0.5,-0.5,-0.5) uscale(0.5) S ∪
           move(-0.5,0.5,-0.5) uscale(0.5) S
"""


def expand_and_recheck(tmp_path, capsys, text: str, steps: int) -> str:
    """`pcsg expand` of `text`, checked that `pcsg check` accepts what it printed;
    returns the printed file."""
    from pcsg.cli import main
    src = tmp_path / "source.pcsg"
    src.write_text(text)
    assert main(["expand", str(src), "-n", str(steps)]) == 0
    out = capsys.readouterr().out
    again = tmp_path / "again.pcsg"
    again.write_text(out)
    assert main(["check", "-q", str(again)]) == 0, capsys.readouterr().err
    return out
