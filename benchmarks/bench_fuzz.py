"""Long fuzz run of every reader: the property tests of ``tests/test_hardening.py`` with many more inputs.

Each reader (stroke JSON, stroke binary, style, convert round trip, COLMAP binary and text models, NeRF-synthetic
transforms JSON and its camera-only reader, nerfstudio, images: every ``test_fuzz_*`` of the test file) gets
``--examples`` generated inputs
(default 10,000) under a 10 s per-input limit; prints the inputs tried, failures and the time per reader.
A failure is any exception other than the reader's one-line error, or a hang.

Run: ``python benchmarks/bench_fuzz.py [--examples 10000]``.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--examples", type=int, default=10_000)
    ap.add_argument("--only", nargs="*", help="run only these tests (names as below)")
    args = ap.parse_args()
    # Hypothesis fails any input that takes over 10 s; pytest-timeout ends a reader's run that hangs for good.
    env = {**os.environ, "DOODLE_FUZZ_EXAMPLES": str(args.examples), "DOODLE_FUZZ_DEADLINE": "10"}
    source = (ROOT / "tests" / "test_hardening.py").read_text(encoding="utf-8")
    # every reader's property test, as the test file has them (a hypothesis @given right above the def)
    tests = re.findall(r"^@given\(.*?\n(?:@.*\n)*def (test_fuzz_\w+)\(", source, re.M | re.S)
    for test in args.only or tests:
        t = time.perf_counter()
        p = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "--timeout", "3600",
                            "--hypothesis-show-statistics", f"tests/test_hardening.py::{test}"],
                           cwd=ROOT, env=env, capture_output=True, text=True)
        # Hypothesis reports each phase (replaying its example database, generating, shrinking): sum them.
        stats = re.findall(r"(\d+) passing(?: examples?)?, (\d+) failing", p.stdout)
        tried = f"{sum(int(a) for a, _ in stats)} passing, {sum(int(b) for _, b in stats)} failing" if stats else "?"
        print(f"{test:<32} {tried:<32} {'ok' if p.returncode == 0 else 'FAILED'}  {time.perf_counter() - t:.0f} s")
        if p.returncode != 0:
            print(p.stdout[-3000:])


if __name__ == "__main__":
    main()
