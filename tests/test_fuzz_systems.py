"""Random valid systems (tests/systems.py) and mutated sample grammars through check,
stats and a small render: no crash, no hang past a bound, and the graph tracer agrees
with the brute-force reference wherever the expansion is small. Every case that ever
failed lives on in tests/corpus/ and runs first.

PCSG_FUZZ_EXAMPLES=N runs N examples per generator instead of CI's few (the note on
issue 6 gives the figures of a long run)."""
import os
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings

import pcsg
from pcsg.cli import main
from pcsg.compiler import compile_text
from pcsg.graph.stats import count_primitives
from pcsg.language.errors import PcsgError
from pcsg.render.job import Options, RenderFailed, render_file

from .oracle import assert_agrees, camera_rays
from .systems import system
from .test_fuzz_front_end import mutated_sample

CORPUS = Path(__file__).parent / "corpus"
EXAMPLES = int(os.environ.get("PCSG_FUZZ_EXAMPLES", "40"))
CASE_SECONDS = 60           # a bound far above any case's time, far below a hang
SMALL = 400                 # primitives up to which the reference is traced too
# what one case may spend: a ray stops after this many instances, a render after this long
LIMITS = dict(max_depth=24, max_instances=20_000)
SLOWEST = [0.0, ""]         # reported by the long run


def run_case(text: str, tmp_path: Path, name: str = "case.pcsg") -> str:
    """check, stats and render from the command line, then the tracer against the
    reference when the expansion is small. Returns how far the case got."""
    t0 = time.perf_counter()
    src = tmp_path / name
    src.write_text(text, encoding="utf-8")
    assert main(["check", str(src)]) in (0, 1)
    assert main(["stats", str(src)]) in (0, 1)
    try:
        graph = compile_text(text, name)
    except PcsgError:
        return "error"
    out = tmp_path / "case.png"
    opts = Options(size=(16, 12), adaptive=False, shadow_samples=1, quiet=True, bounces=1,
                   timeout=CASE_SECONDS, **LIMITS)
    try:
        render_file(src, out, opts)
        assert out.stat().st_size > 0
    except RenderFailed as e:
        raise AssertionError(f"the render stopped: {e}") from None
    result = "rendered"
    try:
        small = count_primitives(graph) <= SMALL
    except PcsgError:
        small = False           # it never ends, or is too big to count
    if small:
        obj = pcsg.Traced(graph, **LIMITS)
        b = obj.bounds
        if np.all(np.isfinite(b)) and b[0] <= b[3]:
            for view in [(1, -1.3, 0.7), (-0.4, 0.9, -1.1)]:
                o, d = camera_rays(b, 12, view, seed=5)
                assert_agrees(obj, o, d, min_hits=0)
            result = "agrees"
    took = time.perf_counter() - t0
    assert took < CASE_SECONDS, f"one case took {took:.1f} s"
    if took > SLOWEST[0]:
        SLOWEST[:] = [took, text]
    return result


def warm_up(tmp_path: Path):
    """Compile the kernels (or load them) before any case's time starts."""
    run_case("#material m reflect=0.5\nmaterial(m) (sphere ∪ move(1, 0, 0) cube \\ cone)\n",
             tmp_path, "warm.pcsg")


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    path = tmp_path_factory.mktemp("fuzz")
    warm_up(path)
    return path


@pytest.mark.parametrize("case", sorted(CORPUS.glob("*.pcsg")), ids=lambda p: p.stem)
def test_corpus(case, workdir):
    """Cases that once failed: each stays fixed."""
    run_case(case.read_text(encoding="utf-8"), workdir, case.name)


@settings(max_examples=EXAMPLES, deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture,
                                 HealthCheck.data_too_large])
@given(text=system())
def test_random_valid_systems(text, workdir):
    assert run_case(text, workdir) != "error", "the generator makes valid systems only"


@settings(max_examples=EXAMPLES // 2, deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(text=mutated_sample())
def test_mutated_samples_render_or_fail_cleanly(text, workdir):
    run_case(text, workdir)
