"""Soak test: many fit → export → animate rounds in ONE Python process, each under a watchdog.

This is the README's Python example run back to back: torch's OpenMP pool is busy in the parent (the fit),
then export and animate start worker processes. Forked workers used to hang in libgomp's barrier; doodle's
workers come from a fork server that never imported torch. A round that takes longer than ``--limit``
seconds counts as a hang: the watchdog prints the stacks of every thread and exits 3.

Target (issue 11): 20 rounds, 0 hangs, on a loaded 2-core machine (run ``--load 2`` to add two busy
processes beside it).
Run: ``python benchmarks/bench_soak.py [--rounds 20] [--load 2] [--limit 300]``
"""

from __future__ import annotations

import argparse
import faulthandler
import multiprocessing as mp
import os
import sys
import tempfile
import time
from pathlib import Path


def _burn(stop, parent: int) -> None:
    """A busy process: the machine is loaded as a shared CI runner is. Ends with the soak, even a killed one."""
    x = 0
    while not stop.is_set() and os.getppid() == parent:
        for _ in range(100_000):
            x = (x * 1103515245 + 12345) & 0xFFFFFFFF


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=20)
    ap.add_argument("--load", type=int, default=0, help="busy processes to run beside the soak")
    ap.add_argument("--limit", type=float, default=300.0, help="seconds after which a round counts as hung")
    args = ap.parse_args()

    from doodle.animate import AnimateOptions, animate
    from doodle.exporters import ExportOptions, export_cameras, export_views
    from doodle.fit import FitConfig, fit
    from doodle.samples import write_sample
    from doodle.scenes import load_scene

    ctx = mp.get_context("spawn")
    stop = ctx.Event()
    burners = [ctx.Process(target=_burn, args=(stop, os.getpid()), daemon=True) for _ in range(args.load)]
    for p in burners:
        p.start()
    times = []
    try:
        with tempfile.TemporaryDirectory() as tmp:
            root = Path(tmp)
            scene = load_scene(write_sample("chair", root / "chair", n_train=12, n_test=2, size=128))
            cfg = FitConfig(size=96, evidence_size=96, evidence_voxels=64, sq_iterations=40, views_per_step=4)
            for k in range(args.rounds):
                faulthandler.dump_traceback_later(args.limit, exit=True)  # a hang prints every stack and ends
                t0 = time.perf_counter()
                strokes = fit(scene, cfg, progress=False, log=lambda m: None).strokes
                t1 = time.perf_counter()
                export_views(strokes, export_cameras(strokes, 12, size=(160, None)), root / "views",
                             ExportOptions(png=True, workers=2))
                t2 = time.perf_counter()
                animate(strokes, root / "turn.gif", AnimateOptions(frames=12, size=128, workers=2))
                t3 = time.perf_counter()
                faulthandler.cancel_dump_traceback_later()
                times.append(t3 - t0)
                print(f"round {k + 1:2d}/{args.rounds}: fit {t1 - t0:5.1f} s, export {t2 - t1:4.1f} s, "
                      f"animate {t3 - t2:4.1f} s ({len(strokes.curves)} curves)", flush=True)
    finally:
        stop.set()
        for p in burners:
            p.join(5)
    print(f"{len(times)} rounds, 0 hangs (limit {args.limit:.0f} s), load {args.load}: "
          f"round mean {sum(times) / len(times):.1f} s, max {max(times):.1f} s")


if __name__ == "__main__":
    sys.exit(main())
