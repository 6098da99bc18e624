"""No input, however broken, escapes as anything but PcsgError, and each ends fast."""
import random
import time

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pcsg.compiler import compile_text
from pcsg.graph.stats import count_primitives
from pcsg.language.errors import PcsgError

from .conftest import GRAMMARS

SAMPLES = [p.read_text(encoding="utf-8") for p in sorted(GRAMMARS.glob("*.pcsg"))]
ALPHABET = "SABT1234567890.,;:(){}[]=+-*/%^!<>&|\\∪∩∖→ \n\t#xyzc_" + "movescalerotpaint"
FRAGMENTS = ["∪", "∩", "\\", "→", "->", "(", ")", "{", "}", "=", ";", ",", "\n", "#define X ",
             "X", "S", "move(", "uscale(0.5)", "sphere", "if(", "rand()", "1:", "2:", "c", "cnt",
             "/*", "*/", "//", "paint(1,0,0)", "material(m)", "#camera fov=", "tri1", "0/0"]


def outcome(text: str) -> str:
    """Compile (and count, when it compiles): success or a PcsgError, quickly."""
    t0 = time.perf_counter()
    try:
        g = compile_text(text, "fuzz.pcsg")
        try:
            count_primitives(g)
        except PcsgError:
            pass
        result = "ok"
    except PcsgError as e:
        assert e.diagnostics and all(d.message for d in e.diagnostics)
        str(e)                  # formatting the report must not fail either
        result = "error"
    assert time.perf_counter() - t0 < 10, "a single input took more than 10 s"
    return result


@st.composite
def mutated_sample(draw):
    text = draw(st.sampled_from(SAMPLES))
    rng = random.Random(draw(st.integers(0, 2 ** 32)))
    for _ in range(draw(st.integers(1, 6))):
        i = rng.randrange(len(text) + 1)
        j = min(len(text), i + rng.randrange(8))
        op = rng.randrange(4)
        if op == 0:
            text = text[:i] + text[j:]                              # delete
        elif op == 1:
            text = text[:i] + rng.choice(FRAGMENTS) + text[i:]     # insert a token
        elif op == 2:
            text = text[:i] + rng.choice(ALPHABET) + text[j:]      # replace
        else:
            lines = text.split("\n")                                # swap two lines
            a, b = rng.randrange(len(lines)), rng.randrange(len(lines))
            lines[a], lines[b] = lines[b], lines[a]
            text = "\n".join(lines)
    return text


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutated_sample())
def test_mutated_samples_end_cleanly(text):
    outcome(text)


@settings(max_examples=150, deadline=None)
@given(st.text(alphabet=ALPHABET, max_size=300))
def test_random_text_ends_cleanly(text):
    outcome(text)


@settings(max_examples=100, deadline=None)
@given(st.lists(st.sampled_from(FRAGMENTS), max_size=40))
def test_random_token_soup_ends_cleanly(parts):
    outcome(" ".join(parts))


def test_extreme_inputs():
    assert outcome("") == "error"
    assert outcome("(" * 10_000 + "sphere" + ")" * 10_000) == "ok"
    assert outcome("{a = " + "(" * 10_000 + "1" + ")" * 10_000 + "} sphere") == "ok"
    assert outcome("move(1,0,0) " * 5_000 + "sphere") == "ok"
    assert outcome(" ∪ ".join(["sphere"] * 50_000)) == "ok"
    assert outcome("(" * 10_000) == "error"
    macro_bomb = "#define A B B B B B B B B B B\n" + "".join(
        f"#define {c} {n} {n} {n} {n} {n} {n} {n} {n} {n} {n}\n"
        for c, n in zip("BCDEFGH", "CDEFGHI")) + "A\n"
    assert outcome(macro_bomb) == "error"


def test_large_file_is_refused_up_front(tmp_path, monkeypatch):
    from pathlib import Path
    from pcsg.compiler import compile_file
    big = tmp_path / "big.pcsg"
    big.write_text("sphere\n" + "// padding\n" * 1_000_000, encoding="utf-8")

    def unread(self):
        raise AssertionError("the file was read before its size was checked")
    monkeypatch.setattr(Path, "read_bytes", unread)
    try:
        compile_file(big)
        raise AssertionError("a 10 MB file compiled")
    except PcsgError as e:
        assert e.diagnostics[0].message.startswith(
            f"file is {big.stat().st_size:,} bytes; pcsg reads grammars of up to 8,388,608 "
            f"bytes (8 MiB")


def test_text_given_to_loads_is_held_to_the_files_limit():
    """loads() of 11 MB parsed for minutes where a file of it was refused at once; the
    limit is in UTF-8 bytes, as a file's (3 bytes a '∪')."""
    from pcsg.tracer import loads
    with pytest.raises(PcsgError) as e:
        loads("sphere ∪ " * 1_000_000 + "cube")
    assert str(e.value).startswith("<string>: error: text is 11,000,004 bytes; pcsg reads "
                                   "grammars of up to 8,388,608 bytes")
    just = "sphere // " + "∪" * ((8 * 1024 * 1024 - 10) // 3) + "\n"
    assert len(just.encode()) <= 8 * 1024 * 1024
    assert loads(just).graph.nodes[0].name == "sphere"
