"""Benchmark the fitting core: quality and speed on the procedural scenes and, when present, the real data.

Bars (issue 9, stroke discovery), all with default settings on 2 CPU cores:
- ABC-NEF 00000006: 3D precision ≥ 0.90 and recall ≥ 0.85 at 0.02 (NEF/EMAP protocol), at most 48 curves;
- Lego: ``doodle eval`` F ≥ 0.75 on 10 held-out views, at least 16 curves; images → stroke file ≤ 3 min, the
  evidence and curve extraction together ≤ 20 s; ``--sheet DIR`` writes the contact sheets to look at;
- chair, lamp, snowman: no worse than the README's quality table; the chair's ground-truth edges (24 curves).
- tripod (a microphone on a tripod with a looping cable): every thin part (three legs, the pole, the cable's
  loop) drawn by curves, its axis covered within 0.05, and no superquadric over a thin part or the loop's hole;
  mug: its body a superquadric, its ring handle curves, and the handle's hole open;
  parcel (a box printed with tape, a ball with gores): the share of the sketch's ink on the print in the
  held-out views, and how the feature curves lie on the box's edges (texture is not structure).
- rocker-arm (CAD) and cheburashka (smooth), meshes rendered by Blender, when present: held-out line
  precision ≥ 0.85 and F ≥ 0.88 (the issue's target for real scenes), beside Blender Freestyle's drawings of
  the same test views from the exact mesh (the mesh-based ceiling), scored the same way.

Run: ``python benchmarks/bench_fit.py [--only snowman,chair,lamp,tripod,mug,parcel,abc,blender,lego] [--sheet DIR] [--iterations N]
[--set FIELD=VALUE ...]`` (``--iterations``: distance-field steps after discovery, default the fit's; ``--set``: any
other :class:`~doodle.fit.FitConfig` field, e.g. ``--set evidence_voxels=256``, to measure a setting on every scene).
"""

from __future__ import annotations

import argparse
import dataclasses
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from doodle.evaluate import evaluate, evaluate_svgs, natural_sorted  # noqa: E402
from doodle.exporters import ExportOptions, export_views  # noqa: E402
from doodle.fit import FitConfig, fit  # noqa: E402
from doodle.samples import load_ground_truth, write_sample  # noqa: E402
from doodle.scenes import load_scene, load_scene_at_size  # noqa: E402
from doodle.strokes import write_strokes  # noqa: E402
from helpers_geometry import edge_scores, hole_points, ink_on_print, inside_superquadrics, thin_axes  # noqa: E402

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
LEGO = DATA / "nerf_synthetic" / "lego"
ABC = DATA / "abc-nef" / "00000006"
BLENDER = DATA / "blender"


def quiet(msg: str) -> None:
    print(f"    {msg}", flush=True)


def stages(messages: list[str]) -> str:
    """The discovery timing line of a fit's log, if any."""
    return next((m for m in messages if m.startswith("discovery:") and "(" in m and " s)" in m), "")


def line(name: str, dt: float, s, m: dict) -> str:
    drawn = int(s.superquadrics.drawn.sum()) if len(s.superquadrics) else 0
    return (f"{name:11s} {dt:6.1f} s  {len(s.curves)} curves, {len(s.superquadrics)} superquadrics ({drawn} drawn)  "
            f"eval P {m['line_precision']:.3f} R {m['silhouette_recall']:.3f} F {m['f_score']:.3f}")


def sheet(strokes, cameras, out: Path | None, name: str) -> None:
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        write_strokes(out / f"{name}.doodle", strokes)
        export_views(strokes, cameras, out / name, ExportOptions(svg=False, sheet=out / f"{name}.png"))


def thin_part_report(strokes, primitives) -> str:
    """How well curves draw each thin part (share of its axis within 0.05 of a curve) and whether a
    superquadric grows over one (or over a loop's hole)."""
    sq = strokes.superquadrics
    covered, under_sq = [], 0
    for kind, segs in thin_axes(primitives):
        covered.append(f"{kind} {edge_scores(strokes.curves.control_points, segs, 0.05)[1]:.0%}")
        points = segs[len(segs) // 8:, 0]  # off the end where a part meets the rest
        under_sq += int(inside_superquadrics(sq, points[~np.any([p.contains(points, 0.05) for p in primitives if p.kind != kind], 0)]).any())
    hole = float(inside_superquadrics(sq, hole_points(primitives)).mean())
    return (f"thin parts drawn by curves: {', '.join(covered)}; under a superquadric: {under_sq} thin part(s), "
            f"{hole:.0%} of the loop's hole")


def config_setting(text: str) -> tuple[str, object]:
    """``FIELD=VALUE`` → ``(field, value)`` for :class:`FitConfig`: numbers and true/false are parsed, the rest
    stays text (``auto``, an objective's name).

    >>> config_setting("evidence_voxels=256"), config_setting("superquadrics=auto")
    (('evidence_voxels', 256), ('superquadrics', 'auto'))
    """
    key, sep, raw = text.partition("=")
    names = [f.name for f in dataclasses.fields(FitConfig)]
    if not sep or key not in names:
        raise argparse.ArgumentTypeError(f"{text!r}: expected FIELD=VALUE with FIELD one of {', '.join(names)}")
    for parse in (int, float):
        try:
            return key, parse(raw)
        except ValueError:
            pass
    return key, {"true": True, "false": False}.get(raw.lower(), raw)


def main() -> None:
    procedural = ("snowman", "chair", "lamp", "tripod", "mug", "parcel")
    scenes = (*procedural, "abc", "blender", "lego")
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", type=lambda s: s.split(","), help="comma-separated: " + ",".join(scenes))
    ap.add_argument("--sheet", type=Path, help="write each scene's stroke file and contact sheet here")
    ap.add_argument("--iterations", type=int, help="distance-field steps after discovery (default: the fit's)")
    ap.add_argument("--set", dest="settings", type=config_setting, action="append", default=[], metavar="FIELD=VALUE",
                    help="any other FitConfig field, e.g. evidence_voxels=256 (repeatable)")
    args = ap.parse_args()
    if args.only and set(args.only) - set(scenes):
        ap.error(f"--only: unknown scene(s) {', '.join(sorted(set(args.only) - set(scenes)))}; choose from {','.join(scenes)}")
    only, sheets = args.only, args.sheet
    extra = dict(args.settings) | ({"iterations": args.iterations} if args.iterations is not None else {})
    want = lambda name: only is None or name in only  # noqa: E731
    with tempfile.TemporaryDirectory() as tmp:
        for name in procedural:
            if not want(name):
                continue
            d = write_sample(name, Path(tmp) / name)
            t0 = time.perf_counter()
            res = fit(load_scene(d), FitConfig(**extra), log=quiet, progress=False)
            dt = time.perf_counter() - t0
            test = load_scene(d, split="test")
            out = line(name, dt, res.strokes, evaluate(res.strokes, test))
            if name == "chair":
                gt = load_ground_truth(d)["feature_edges"]
                p, r = edge_scores(res.strokes.curves.control_points, gt, 0.02 * test.frame.radius)
                c24 = fit(load_scene(d), FitConfig(curves=24, superquadrics=0), log=lambda m: None, progress=False)
                p24, r24 = edge_scores(c24.strokes.curves.control_points, gt, 0.02 * test.frame.radius)
                out += (f"  GT edges: {p:.0%} of curve length on an edge, {r:.0%} of edge length covered "
                        f"(24 curves: {p24:.0%}, {r24:.0%})")
            if name == "parcel":
                gt = load_ground_truth(d)
                curves = res.strokes.curves
                p, r = edge_scores(curves.control_points[curves.gates == 0], gt["feature_edges"], 0.03 * test.frame.radius)
                out += (f"  ink on the print: {ink_on_print(res.strokes, gt['primitives'], test.cameras):.0%}; "
                        f"feature curves: {p:.0%} on the box's edges, {r:.0%} of them covered")
            if name in ("tripod", "mug"):
                out += "  " + thin_part_report(res.strokes, load_ground_truth(d)["primitives"])
            print(out, flush=True)
            sheet(res.strokes, test.cameras, sheets, name)
    if want("abc"):
        if not (ABC / "transforms_train.json").exists():
            print("abc: skipped (../shared/data/abc-nef/00000006 not present)")
        else:
            from doodle.curvemetrics import read_abc_ground_truth

            t0 = time.perf_counter()
            scene = load_scene_at_size(ABC, "train", 512)
            res = fit(scene, FitConfig(**extra), log=quiet, progress=False)
            dt = time.perf_counter() - t0
            test = load_scene_at_size(ABC, "test", 256)
            m = evaluate(res.strokes, test, truth=read_abc_ground_truth(ABC / "ground_truth"))
            c3 = m["curves_3d"]
            print(line("abc", dt, res.strokes, m) + f"  3D: P {c3['precision']:.3f} R {c3['recall']:.3f} "
                  f"F {c3['f_score']:.3f} Chamfer {c3['chamfer']:.4f} (NEF: 0.99 / 1.00 / 0.018, 42 curves)",
                  flush=True)
            sheet(res.strokes, test.cameras, sheets, "abc")
    if want("blender"):
        for name in ("rocker-arm", "cheburashka"):
            d = BLENDER / name
            if not (d / "transforms_train.json").exists():
                print(f"{name}: skipped (../shared/data/blender/{name} not present)")
                continue
            t0 = time.perf_counter()
            res = fit(load_scene(d), FitConfig(**extra), log=quiet, progress=False)
            dt = time.perf_counter() - t0
            test = load_scene_at_size(d, "test", 256)
            fs = evaluate_svgs(natural_sorted((d / "freestyle").glob("fs_*.svg")), test)
            print(line(name, dt, res.strokes, evaluate(res.strokes, test)) + f"  (Freestyle from the mesh: P "
                  f"{fs['line_precision']:.3f} R {fs['silhouette_recall']:.3f} F {fs['f_score']:.3f})", flush=True)
            sheet(res.strokes, test.cameras, sheets, name)
    if want("lego"):
        if not (LEGO / "transforms_train.json").exists():
            print("lego: skipped (../shared/data/nerf_synthetic/lego not present)")
            return
        t0 = time.perf_counter()
        scene = load_scene_at_size(LEGO, "train", 512)
        held = np.arange(0, len(scene), 10)
        messages: list[str] = []
        res = fit(scene.subset(np.setdiff1d(np.arange(len(scene)), held)), FitConfig(**extra),
                  log=lambda m: (messages.append(m), quiet(m)), progress=False)
        dt = time.perf_counter() - t0
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2
        test = load_scene_at_size(LEGO, "train", 256).subset(held)
        m = evaluate(res.strokes, test)
        print(line("lego", dt, res.strokes, m) + f"  (images → strokes, 10 views held out; peak memory {peak:.2f} GB; "
              f"{stages(messages)})", flush=True)
        sheet(res.strokes, test.cameras, sheets, "lego")


if __name__ == "__main__":
    main()
