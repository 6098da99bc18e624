"""A long fuzzing run with the generators of tests/test_fuzz_systems.py, for the figures
CI's few examples cannot give: how many systems ran, how far each got (a compile error,
rendered, or rendered and checked against the reference ray by ray), the slowest case.

    python tools/fuzz.py [--examples 1000] [--seed 1]

A failing case is printed and saved to tests/corpus/found-<hash>.pcsg: once it is fixed,
it stays in the corpus as a regression test."""
from __future__ import annotations

import argparse
import hashlib
import sys
import tempfile
import time
import traceback
from collections import Counter
from pathlib import Path

from hypothesis import HealthCheck, given, seed, settings

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests import test_fuzz_systems as fz  # noqa: E402
from tests.systems import system  # noqa: E402
from tests.test_fuzz_front_end import mutated_sample  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--examples", type=int, default=1000, help="per generator")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="pcsg-fuzz-"))
    fz.warm_up(work)
    failures = {}
    for name, strategy in [("random valid systems", system()),
                           ("mutated samples", mutated_sample())]:
        tally: Counter = Counter()
        t0 = time.perf_counter()

        @seed(args.seed)
        @settings(max_examples=args.examples, deadline=None, database=None,
                  suppress_health_check=list(HealthCheck))
        @given(text=strategy)
        def run(text):
            try:
                tally[fz.run_case(text, work)] += 1
            except Exception as e:      # noqa: BLE001 - every failure is a finding
                key = f"{type(e).__name__}: {str(e).splitlines()[0] if str(e) else ''}"[:160]
                tally["FAILED"] += 1
                if key not in failures:
                    failures[key] = text
                    digest = hashlib.sha1(text.encode()).hexdigest()[:10]
                    (ROOT / "tests" / "corpus" / f"found-{digest}.pcsg").write_text(
                        f"// {key}\n{text}", encoding="utf-8")
                    traceback.print_exc()

        run()
        took = time.perf_counter() - t0
        print(f"{name}: {sum(tally.values())} cases in {took:.0f} s: {dict(tally)}", flush=True)
    print(f"slowest case: {fz.SLOWEST[0]:.2f} s")
    print(f"distinct failures: {len(failures)}")
    for key in failures:
        print("  " + key)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
