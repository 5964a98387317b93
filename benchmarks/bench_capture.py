"""Benchmark real-capture handling: Lego's photos without poses or masks → SfM → automatic masks → sketch.

The 100 (or ``--photos N``) Lego training images lose their alpha and are composited over textured
backgrounds that differ from photo to photo (as the room behind an object does when one walks around it).
``doodle fit`` then has to pose them (pycolmap SfM), find the object (automatic masks) and sketch it.

Prints: SfM and fit time, automatic-mask IoU with the true alpha (bar: ≥ 0.9), and ``doodle eval`` against the
true masks (bar: silhouette recall ≥ 0.8). ``--keep DIR`` keeps the photos, masks, strokes and a contact sheet.
``--held-out`` also fits again without every 8th registered photo (same SfM poses and automatic masks) and
scores those photos, which the fit has not seen: a change that draws the training photos' outlines better
but new views worse shows there. Skips cleanly when ``../shared/data`` is absent.

Run: ``python benchmarks/bench_capture.py [--photos 100] [--keep DIR] [--held-out]``.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from PIL import Image
from scipy import ndimage

LEGO = Path(__file__).resolve().parents[2] / "shared" / "data" / "nerf_synthetic" / "lego"


def background(shape: tuple[int, int], rng: np.random.Generator) -> np.ndarray:
    """A textured backdrop: coloured blotches, fine grain and a few strong straight edges (furniture)."""
    H, W = shape
    blotch = ndimage.gaussian_filter(rng.random((H // 8, W // 8, 3)), sigma=(2, 2, 0))
    blotch = np.asarray(Image.fromarray((255 * (blotch - blotch.min()) / np.ptp(blotch)).astype(np.uint8)).resize((W, H)))
    img = 0.55 * blotch + 0.3 * 255 * rng.uniform(0.3, 0.9, 3) + 25 * rng.standard_normal((H, W, 1))
    for _ in range(4):
        x0, y0 = rng.integers(0, W), rng.integers(0, H)
        img[y0:y0 + rng.integers(20, 200), x0:x0 + rng.integers(20, 200)] *= rng.uniform(0.5, 1.2)
    return np.clip(img, 0, 255).astype(np.uint8)


def make_photos(n: int, photos: Path, truth: Path) -> None:
    frames = json.loads((LEGO / "transforms_train.json").read_text())["frames"]
    idx = np.linspace(0, len(frames) - 1, n).round().astype(int)
    rng = np.random.default_rng(0)
    photos.mkdir(parents=True)
    truth.mkdir(parents=True)
    for i in idx:
        name = Path(frames[i]["file_path"]).name
        rgba = np.asarray(Image.open(LEGO / f"{frames[i]['file_path']}.png").convert("RGBA")).astype(np.float32)
        a = rgba[..., 3:] / 255
        out = rgba[..., :3] * a + background(rgba.shape[:2], rng) * (1 - a)
        Image.fromarray(np.clip(out + 0.5, 0, 255).astype(np.uint8)).save(photos / f"{name}.jpg", quality=92)
        Image.fromarray(((a[..., 0] > 0.5) * 255).astype(np.uint8)).save(truth / f"{name}.png")


def run(cmd: list[str]) -> tuple[float, str, str]:
    t = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{p.stderr[-2000:]}")
    return time.perf_counter() - t, p.stdout, p.stderr


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--photos", type=int, default=100)
    ap.add_argument("--keep", type=Path)
    ap.add_argument("--held-out", action="store_true", help="also score a fit without every 8th photo on those")
    args = ap.parse_args()
    if not LEGO.is_dir():
        print(f"skipped: {LEGO} not found")
        return
    work = Path(tempfile.mkdtemp(prefix="doodle-bench-capture-")) if args.keep is None else args.keep
    if args.keep is not None:
        shutil.rmtree(work, ignore_errors=True)
    photos, truth = work / "photos", work / "true-masks"
    make_photos(args.photos, photos, truth)
    doodle = [sys.executable, "-m", "doodle"]
    t_fit, _, log = run([*doodle, "fit", str(photos), "-o", str(work / "lego.doodle")])
    sfm = next((ln for ln in log.splitlines() if "registered" in ln), "")
    auto = photos / "doodle-masks"
    ious = []
    for m in sorted(auto.glob("*.png")):
        a = np.asarray(Image.open(m).convert("L")) > 127
        t = Image.open(truth / m.name).convert("L").resize((a.shape[1], a.shape[0]), Image.Resampling.BOX)
        t = np.asarray(t) > 127
        ious.append((a & t).sum() / max((a | t).sum(), 1))
    _, out, _ = run([*doodle, "eval", str(work / "lego.doodle"), str(photos), "--masks", str(truth), "--json", "-"])
    metrics = json.loads(out)
    run([*doodle, "export", str(work / "lego.doodle"), "-o", str(work / "views"), "--views", "12", "--no-svg",
         "--sheet", str(work / "sheet.png")])
    print(f"lego photos   {args.photos} photos, {sfm.strip()}")
    print(f"fit           {t_fit:.0f} s (SfM, automatic masks, discovery)")
    print(f"auto masks    IoU with the true alpha: mean {np.mean(ious):.3f}, min {np.min(ious):.3f} over {len(ious)} photos (bar 0.9)")
    print(f"eval          line precision {metrics['line_precision']:.3f}, silhouette recall "
          f"{metrics['silhouette_recall']:.3f} (bar 0.8), F {metrics['f_score']:.3f}")
    if args.held_out:
        print(held_out(photos, auto, truth))
    print(f"look at       {work / 'sheet.png'}")


def held_out(photos: Path, auto: Path, truth: Path, every: int = 8) -> str:
    """Fit without every ``every``-th registered photo (the run's SfM poses and automatic masks) and score
    those photos against the true masks."""
    from doodle.evaluate import evaluate
    from doodle.fit import FitConfig, fit
    from doodle.scenes.automask import with_masks
    from doodle.scenes import load_scene

    quiet = lambda m: None  # noqa: E731
    scene = load_scene(photos)
    test = list(range(3, len(scene), every))
    train = [i for i in range(len(scene)) if i not in test]
    res = fit(with_masks(scene, auto, log=quiet).subset(train), FitConfig(), log=quiet, progress=False)
    m = evaluate(res.strokes, with_masks(scene, truth, log=quiet).subset(test))
    return (f"held out      {len(test)} photos the fit did not see: line precision {m['line_precision']:.3f}, "
            f"silhouette recall {m['silhouette_recall']:.3f}, F {m['f_score']:.3f} ({m['curves']} curves)")


if __name__ == "__main__":
    main()
