"""Benchmark: plotter-ready SVG (``doodle export --plotter``) against the plain SVG of the same views —
paths a view, pieces under 3 px, pen-up travel, held-out F, and whether vpype reads every file.

Target (issue 40): on a smooth toy cow ≤ 15 paths a view on average and none under 3 px at 256 px, held-out F
unchanged (±0.01). Run: ``python benchmarks/bench_plotter.py [STROKES SCENE]`` (default: the procedural cow,
fitted here).
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from doodle.evaluate import evaluate_svgs, natural_sorted
from doodle.exporters.drawing import DrawOptions, draw_many
from doodle.exporters.export import ExportOptions, export_cameras, export_views
from doodle.exporters.plotter import PlotterOptions, chains, pen_up_travel, plot_order
from doodle.scenes import load_scene
from doodle.strokes import read_strokes

SIZE = 256


def plain_figures(strokes, cams) -> tuple[float, float, float]:
    """Subpaths a view, pieces under 3 px a view and pen-up travel (px) a view of the plain SVG, drawn in
    its own order (every subpath its own pen-down)."""
    n = short = travel = 0.0
    for d in draw_many(strokes, cams, DrawOptions()):
        subs = [sp for layer in ("silhouettes", "curves") for op in d.layer(layer) for sp in op.subpaths if len(sp)]
        n += len(subs)
        short += sum(len(chains_of(sp)) == 0 for sp in subs)
        travel += pen_up_travel(subs)
    return n / len(cams), short / len(cams), travel / len(cams)


def chains_of(sp: np.ndarray) -> list[np.ndarray]:
    """``sp`` alone as a chain, or nothing when it is under 3 px (the plotter's cut)."""
    from doodle.exporters.plotter import _length

    return [sp] if _length(sp) >= 3.0 else []


def plotter_figures(strokes, cams) -> tuple[float, float]:
    """Paths a view and pen-up travel (px) a view of the plotter SVG."""
    n = travel = 0.0
    opt = PlotterOptions()
    for d in draw_many(strokes, cams, DrawOptions()):
        paths = plot_order(chains(d, join_px=opt.join_px, max_turn_deg=opt.max_turn_deg,
                                  min_length_px=opt.min_length_px))
        n += len(paths)
        travel += pen_up_travel(paths)
    return n / len(cams), travel / len(cams)


def vpype_reads(files: list[Path]) -> str:
    exe = shutil.which("vpype")
    if exe is None:
        return "vpype: not installed"
    layers = []
    for f in files:
        r = subprocess.run([exe, "read", str(f), "stat"], capture_output=True, text=True)
        if r.returncode != 0:
            return f"vpype: failed on {f.name}: {r.stderr.strip().splitlines()[-1:]}"
        m = re.search(r"Layer \d+.*?Length: [\d.]+", r.stdout, re.S)
        layers.append(bool(m))
    return f"vpype reads {sum(layers)}/{len(files)} files"


def written_paths(files: list[Path]) -> tuple[float, int, float]:
    """From the plotter SVG files as written: paths a view, paths under 3 px, and the shortest path (px; the
    files are in millimetres, their metadata gives the millimetres per pixel)."""
    import json

    from svgelements import Path as SvgPath

    lengths, views = [], 0
    for f in files:
        text = f.read_text(encoding="utf-8")
        mm_per_px = json.loads(re.search(r"<metadata[^>]*>(.*?)</metadata>", text, re.S).group(1))["plotter"]["mm_per_px"]
        lengths += [SvgPath(d).length() / mm_per_px for d in re.findall(r' d="([^"]+)"', text)]
        views += 1
    lengths = np.array(lengths)
    return len(lengths) / max(views, 1), int((lengths < 3.0).sum()), float(lengths.min(initial=np.inf))


def main() -> None:
    tmp = Path(tempfile.mkdtemp(prefix="doodle-bench-plotter-"))
    if len(sys.argv) == 3:
        stroke_file, scene_dir = Path(sys.argv[1]), Path(sys.argv[2])
    else:
        from doodle.samples import write_sample

        scene_dir = tmp / "cow"
        write_sample("cow", scene_dir)
        stroke_file = tmp / "cow.doodleb"
        subprocess.run([sys.executable, "-m", "doodle", "fit", str(scene_dir), "-o", str(stroke_file)],
                       check=True, capture_output=True)
    strokes = read_strokes(stroke_file)
    scene = load_scene(scene_dir, "test")
    cams = export_cameras(strokes, scene_dir=scene_dir, split="test", size=(SIZE, SIZE))
    sub, short, travel_plain = plain_figures(strokes, cams)
    paths, travel_plot = plotter_figures(strokes, cams)
    f = {}
    for label, plot in (("plain", None), ("plotter", PlotterOptions())):
        out = tmp / label
        export_views(strokes, cams, out, ExportOptions(plotter=plot))
        f[label] = evaluate_svgs(natural_sorted(out.glob("*.svg")), scene, size=SIZE)
    print(f"{stroke_file.name} on {len(cams)} held-out views at {SIZE} px")
    print(f"plain SVG:   {sub:.1f} subpaths a view, {short:.1f} under 3 px, pen-up {travel_plain:.0f} px a view, "
          f"F {f['plain']['f_score']:.3f}")
    per_view, under, shortest = written_paths(natural_sorted((tmp / "plotter").glob("*.svg")))
    assert abs(per_view - paths) < 1e-9, (per_view, paths)  # the files hold what the plotter's order gave
    print(f"plotter SVG: {per_view:.1f} paths a view, {under} under 3 px (the shortest {shortest:.1f} px), "
          f"pen-up {travel_plot:.0f} px a view, F {f['plotter']['f_score']:.3f}")
    print(vpype_reads(natural_sorted((tmp / "plotter").glob("*.svg"))))


if __name__ == "__main__":
    main()
