"""Benchmark: render one procedural scene (40 train + 10 test views at 256 px) and load it back.

Target (issue 2): ≤ 10 s per 50-view scene on 2 CPU cores. Run: ``python benchmarks/bench_samples.py``.
"""

from __future__ import annotations

import platform
import tempfile
import time
from pathlib import Path

import torch

from doodle.samples import write_sample
from doodle.scenes import load_scene


def main() -> None:
    print(f"machine: {platform.processor() or platform.machine()}, torch threads {torch.get_num_threads()}")
    with tempfile.TemporaryDirectory() as tmp:
        for name in ("chair", "snowman", "lamp"):
            t0 = time.perf_counter()
            out = write_sample(name, Path(tmp) / name)
            t1 = time.perf_counter()
            scene = load_scene(out)
            t2 = time.perf_counter()
            print(f"{name:8s} render 50 views {t1 - t0:6.2f} s   load {len(scene)} train views {t2 - t1:5.2f} s")


if __name__ == "__main__":
    main()
