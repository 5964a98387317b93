"""Benchmark the fitting core on the procedural scenes and (when present) the real Lego scene.

Targets (issue 4): Lego, 32 curves, default settings, images → stroke file ≤ 3 min and ≤ 4 GB peak memory on
2 CPU cores; snowman with superquadrics ≤ 2 min. Prints quality figures: ground-truth edge precision/recall
for the chair (24 curves, 2 % of the radius), silhouette IoU for the snowman, and ``doodle eval`` metrics on
10 Lego views held out from fitting. Run: ``python benchmarks/bench_fit.py [--no-lego] [--only snowman,lamp,lego]``.
"""

from __future__ import annotations

import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from doodle.evaluate import evaluate  # noqa: E402
from doodle.fit import FitConfig, fit  # noqa: E402
from doodle.fit.pipeline import silhouette_iou  # noqa: E402
from doodle.fit.targets import working_scene  # noqa: E402
from doodle.samples import load_ground_truth, write_sample  # noqa: E402
from doodle.scenes import load_scene, load_scene_at_size  # noqa: E402
from helpers_geometry import edge_scores  # noqa: E402

LEGO = Path(__file__).resolve().parents[2] / "shared" / "data" / "nerf_synthetic" / "lego"


def quiet(msg: str) -> None:
    print(f"    {msg}")


def main() -> None:
    only = sys.argv[sys.argv.index("--only") + 1].split(",") if "--only" in sys.argv else None
    with tempfile.TemporaryDirectory() as tmp:
        for name, cfg in (("snowman", FitConfig()), ("chair", FitConfig(curves=24, superquadrics=0)), ("lamp", FitConfig())):
            if only is not None and name not in only:
                continue
            d = write_sample(name, Path(tmp) / name)
            t0 = time.perf_counter()
            res = fit(load_scene(d), cfg, log=quiet, progress=False)
            dt = time.perf_counter() - t0
            s = res.strokes
            test = load_scene(d, split="test")
            m = evaluate(s, test)
            line = (f"{name:8s} {dt:6.1f} s  {len(s.curves)} curves {len(s.superquadrics)} superquadrics  "
                    f"eval P {m['line_precision']:.3f} R {m['silhouette_recall']:.3f} F {m['f_score']:.3f}")
            if len(s.superquadrics):
                w = working_scene(test, 256)
                line += f"  test IoU {silhouette_iou(s.superquadrics, w.cameras, w.masks):.3f}"
            if name == "chair":
                p, r = edge_scores(s.curves.control_points, load_ground_truth(d)["feature_edges"], 0.02 * test.frame.radius)
                line += f"  GT edges: {p:.0%} of curve length on an edge, {r:.0%} of edge length covered"
            print(line, flush=True)
    if (only is not None and "lego" not in only) or "--no-lego" in sys.argv or not (LEGO / "transforms_train.json").exists():
        print("lego: skipped (../shared/data/nerf_synthetic/lego not present)" if "--no-lego" not in sys.argv else "")
        return
    t0 = time.perf_counter()
    scene = load_scene_at_size(LEGO, "train", 256)
    held = np.arange(0, len(scene), 10)
    fit_views = np.setdiff1d(np.arange(len(scene)), held)
    res = fit(scene.subset(fit_views), FitConfig(curves=32), log=quiet, progress=False)
    dt = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2
    m = evaluate(res.strokes, scene.subset(held))
    s = res.strokes
    print(f"lego     {dt:6.1f} s images → strokes, peak memory {peak:.2f} GB; {len(s.curves)} curves "
          f"{len(s.superquadrics)} superquadrics; 10 held-out views: P {m['line_precision']:.3f} "
          f"R {m['silhouette_recall']:.3f} F {m['f_score']:.3f} IoU {m['silhouette_iou']}")


if __name__ == "__main__":
    main()
