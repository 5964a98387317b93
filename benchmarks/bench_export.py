"""Benchmark: draw 32 curves + 8 superquadrics for 36 orbit views (SVG), and rasterise them at 512 px.

Targets (issue 3): all 36 SVGs ≤ 1 s, all 36 PNGs at 512 px ≤ 3 s, on 2 CPU cores.
Run: ``python benchmarks/bench_export.py [STROKES.doodle]`` (default: a synthetic stroke set).
"""

from __future__ import annotations

import sys
import tempfile
import time

import numpy as np

from doodle.cameras import orbit_cameras
from doodle.exporters import DrawOptions, ExportOptions, draw, draw_many, export_views, to_svg
from doodle.exporters.raster import svg_to_png
from doodle.strokes import CurveSet, SceneFrame, StrokeSet, SuperquadricSet, read_strokes
from doodle.strokes.superquadric import matrix_to_quaternion


def synthetic(seed: int = 0) -> StrokeSet:
    """32 curves on and around 8 overlapping superquadrics (an object-like union, as a fit produces)."""
    rng = np.random.default_rng(seed)
    rots = np.stack([matrix_to_quaternion(q * np.sign(np.linalg.det(q))) for q in np.linalg.qr(rng.normal(size=(8, 3, 3)))[0]])
    sq = SuperquadricSet(rng.uniform(0.15, 0.45, (8, 3)), rng.uniform(0.2, 1.5, (8, 2)), rots, rng.uniform(-0.45, 0.45, (8, 3)))
    start = rng.uniform(-0.8, 0.8, (32, 1, 3))
    curves = start + np.cumsum(rng.normal(scale=0.15, size=(32, 4, 3)), axis=1)
    return StrokeSet(SceneFrame(radius=1.0), CurveSet(curves), sq)


def main() -> None:
    strokes = read_strokes(sys.argv[1]) if len(sys.argv) > 1 else synthetic()
    cams = orbit_cameras(strokes.frame, 36, width=512)
    draw_many(strokes, cams[:1])  # the view-independent surface grids are cached from here on
    t0 = time.perf_counter()
    for c in cams:
        draw(strokes, c)
    print(f"36 drawings one at a time (draw):    {time.perf_counter() - t0:5.2f} s")
    for mode in ("hide", "dash", "show"):
        t0 = time.perf_counter()
        svgs = [to_svg(d) for k in range(0, len(cams), 12) for d in draw_many(strokes, cams[k:k + 12], DrawOptions(hidden=mode))]
        t1 = time.perf_counter()
        print(f"36 SVGs in batches of 12, hidden={mode:4s}: {t1 - t0:5.2f} s  ({np.mean([len(s) for s in svgs]) / 1024:.1f} KiB each)")
    t0 = time.perf_counter()
    for s in svgs:
        svg_to_png(s)
    print(f"36 PNGs at 512 px (cairosvg, from SVG): {time.perf_counter() - t0:5.2f} s")
    for workers in (1, 2):
        for png in (False, True):
            with tempfile.TemporaryDirectory() as tmp:
                t0 = time.perf_counter()
                export_views(strokes, cams, tmp, ExportOptions(svg=True, png=png, workers=workers))
                what = "SVG+PNG" if png else "SVG    "
                print(f"export_views 36 views {what}, {workers} process(es): {time.perf_counter() - t0:5.2f} s")


if __name__ == "__main__":
    main()
