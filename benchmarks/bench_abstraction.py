"""Benchmark the compact abstraction: bytes, strokes and held-out quality at each ``--detail`` level and with the
hull's outline (``--outline hull``), side by side, on every scene at hand.

Columns: ``hull``: whether the hull's outline is drawn; ``drawn``: the share of the training silhouettes that
the superquadrics and curves draw (``FitResult.outline_drawn``: under 0.7 the default falls back to the hull's
outline); ``bent``: superquadrics tapered or bent (the ``plain`` configuration, ``--no-deform``, fits none).

Bars (issue 38), default settings (``detail="medium"``, superquadric outline) on 2 CPU cores:
- a teapot, a CAD part and a toy cow: binary stroke file ≤ 2,048 B, held-out line precision ≥ 0.90 and F ≥ 0.94
  at 256 px, at least 2 superquadrics drawn on the teapot and 4 on the cow (the procedural ``teapot`` and
  ``cow`` and the rocker arm stand in for them here);
- a microphone on a tripod (``tripod``): binary ≤ 6 kB, F ≥ 0.92;
- ABC-NEF 00000006: 3D curve F ≥ 0.95, binary ≤ 2 kB;
- Lego ≤ 90 s.

Run: ``python benchmarks/bench_abstraction.py [--only teapot,cow,...,abc,rocker-arm,cheburashka,lego]
[--configs low,medium,high,hull,plain] [--sheet DIR]``. ``--sheet`` writes, per scene, one PNG with the same held-out
views drawn at each configuration (the figure in ``docs/``).
"""

from __future__ import annotations

import argparse
import io
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from doodle.evaluate import evaluate
from doodle.exporters import DrawOptions, draw, svg_to_png, to_svg
from doodle.fit import FitConfig, fit
from doodle.samples import SCENES, write_sample
from doodle.scenes import load_scene, load_scene_at_size
from doodle.strokes.binary import encode

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
REAL = {"abc": (DATA / "abc-nef" / "00000006", 512), "rocker-arm": (DATA / "blender" / "rocker-arm", 400),
        "cheburashka": (DATA / "blender" / "cheburashka", 400), "lego": (DATA / "nerf_synthetic" / "lego", 512)}
#: The levels as a user gets them (``--outline auto``: the hull's outline when the abstraction draws too little),
#: the compact abstraction whatever it draws, and the hull's outline.
CONFIGS = {"low": dict(detail="low"), "medium": dict(), "high": dict(detail="high"),
           "compact": dict(outline="superquadrics"), "hull": dict(outline="hull"), "plain": dict(deform=False)}


def scenes(only: set[str] | None, tmp: Path):
    """``(name, train scene, test scene, ground-truth folder or None)`` for each scene at hand."""
    for name in SCENES:
        if only is None or name in only:
            d = write_sample(name, tmp / name)
            yield name, load_scene(d), load_scene(d, split="test"), None
    for name, (d, size) in REAL.items():
        if only is not None and name not in only:
            continue
        if not (d / "transforms_train.json").exists():
            print(f"{name}: skipped ({d} not present)")
            continue
        if name == "lego":  # no test split: every tenth view held out
            scene = load_scene_at_size(d, "train", size)
            held = np.arange(0, len(scene), 10)
            yield name, scene.subset(np.setdiff1d(np.arange(len(scene)), held)), \
                load_scene_at_size(d, "train", 256).subset(held), None
        else:
            yield name, load_scene_at_size(d, "train", size), load_scene_at_size(d, "test", 256), \
                (d / "ground_truth" if name == "abc" else None)


def keep(folder: Path, name: str, strokes) -> None:
    """Write ``strokes`` to ``folder/NAME.doodleb`` (``--keep``)."""
    from doodle.strokes import write_strokes

    folder.mkdir(parents=True, exist_ok=True)
    write_strokes(folder / f"{name}.doodleb", strokes)


def views_png(strokes, test, picks=(0, 3, 6)) -> "Image.Image":
    from PIL import Image

    row = Image.new("RGB", (256 * len(picks), 256), "white")
    for k, v in enumerate(picks):
        cam = test.cameras[v % len(test)]
        cam = cam.scaled(256 / max(cam.width, cam.height))
        im = Image.open(io.BytesIO(svg_to_png(to_svg(draw(strokes, cam, DrawOptions()), 1.0)))).convert("RGBA")
        row.paste(im, (256 * k, 0), im)
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", help="comma-separated scenes")
    ap.add_argument("--configs", default=",".join(CONFIGS), help="comma-separated: " + ", ".join(CONFIGS))
    ap.add_argument("--sheet", type=Path, help="write one PNG per scene, a row per configuration")
    ap.add_argument("--figure", type=Path, help="write one PNG with a row per scene: a held-out photo, then that "
                                                  "view drawn at each configuration (docs/levels.png)")
    ap.add_argument("--view", type=int, default=3, help="the held-out view of --figure")
    ap.add_argument("--keep", type=Path, help="write every fit's stroke file here (SCENE-CONFIG.doodleb)")
    args = ap.parse_args()
    only = set(args.only.split(",")) if args.only else None
    configs = args.configs.split(",")
    print(f"{'scene':12s} {'config':7s} {'s':>6s} {'bytes':>6s} {'curves':>6s} {'sq':>5s} {'hull':>4s} {'drawn':>5s} "
          f"{'bent':>4s} {'P':>6s} {'R':>6s} {'F':>6s}")
    figure = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, train, test, truth in scenes(only, Path(tmp)):
            rows = []
            if args.figure:
                figure.append([photo(test, args.view)])
            for c in configs:
                t0 = time.perf_counter()
                res = fit(train, FitConfig(**CONFIGS[c]), log=lambda m: None, progress=False)
                dt = time.perf_counter() - t0
                s = res.strokes
                gt = None
                if truth is not None:
                    from doodle.curvemetrics import read_abc_ground_truth

                    gt = read_abc_ground_truth(truth)
                m = evaluate(s, test, truth=gt)
                sq = f"{int(s.superquadrics.drawn.sum())}/{len(s.superquadrics)}"
                bent = int(s.superquadrics.deformed.sum()) if len(s.superquadrics) else 0
                extra = ""
                if "curves_3d" in m:
                    extra = f"  3D P {m['curves_3d']['precision']:.3f} R {m['curves_3d']['recall']:.3f} " \
                            f"F {m['curves_3d']['f_score']:.3f}"
                drawn = "" if res.outline_drawn is None else f"{res.outline_drawn:.2f}"
                print(f"{name:12s} {c:7s} {dt:6.1f} {len(encode(s)):6d} {len(s.curves):6d} {sq:>5s} "
                      f"{'yes' if s.hull is not None else 'no':>4s} {drawn:>5s} {bent:4d} "
                      f"{m['line_precision']:6.3f} {m['silhouette_recall']:6.3f} {m['f_score']:6.3f}{extra}",
                      flush=True)
                if args.keep:
                    keep(args.keep, f"{name}-{c}", s)
                if args.sheet:
                    rows.append(views_png(s, test))
                if args.figure:
                    figure[-1].append(views_png(s, test, (args.view,)))
            if args.sheet and rows:
                from PIL import Image

                args.sheet.mkdir(parents=True, exist_ok=True)
                sheet = Image.new("RGB", (rows[0].width, 256 * len(rows)), "white")
                for k, r in enumerate(rows):
                    sheet.paste(r, (0, 256 * k))
                sheet.save(args.sheet / f"{name}.png")
    if args.figure and figure:
        from PIL import Image

        out = Image.new("RGB", (256 * len(figure[0]), 256 * len(figure)), "white")
        for r, row in enumerate(figure):
            for c, im in enumerate(row):
                out.paste(im, (256 * c, 256 * r))
        out.save(args.figure)


def photo(test, v: int) -> "Image.Image":
    """A held-out image at 256 px, over white."""
    from PIL import Image

    im = Image.fromarray(np.asarray(test.images[v % len(test)])[..., :3])
    return im.resize((256, round(256 * im.height / im.width)) if im.width >= im.height else
                     (round(256 * im.width / im.height), 256))


if __name__ == "__main__":
    sys.exit(main())
