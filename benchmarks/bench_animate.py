"""Benchmark: 36-frame 512 px turntable GIF of 32 curves + 8 superquadrics, per style.

Target (issue 5): ≤ 5 s on 2 CPU cores, GIF ≤ 2 MB. Run: ``python benchmarks/bench_animate.py``.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_export import synthetic  # noqa: E402

from doodle.animate import AnimateOptions, animate  # noqa: E402


def main() -> None:
    strokes = synthetic()
    with tempfile.TemporaryDirectory() as tmp:
        for style in ("ink", "pencil", "sketchy", "charcoal", "blueprint"):
            out = Path(tmp) / f"{style}.gif"
            t0 = time.perf_counter()
            animate(strokes, out, AnimateOptions(frames=36, size=512, style=style))
            print(f"{style:10s} 36 frames at 512 px: {time.perf_counter() - t0:5.2f} s, {out.stat().st_size / 1e6:.2f} MB",
                  flush=True)


if __name__ == "__main__":
    main()
