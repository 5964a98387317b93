"""Benchmark own-photo captures end to end: photos without poses or masks → SfM → automatic masks → sketch.

Captures (``--captures``, comma-separated; default ``dtu,carpet-parcel,carpet-cow``):

- ``dtu``: DTU scan65 (a skull on a brown table before a dark room), its 49 real photos as a plain folder;
  its true masks score the automatic ones. Needs ``../shared/data``.
- ``dtu-neus``: the same photos in DTU's NeuS/IDR layout with its cameras (``cameras_sphere.npz``) and
  without its masks: a posed scene whose masks doodle makes (its points triangulated with the known poses).
- ``carpet-parcel``, ``carpet-cow``, ``carpet-calf``, ``planks-chair`` (and ``carpet-teapot``, ``-mug``, ``-lamp``,
  ``-mouse``, ``-tripod``): the package's procedural phone captures (``doodle sample
  NAME --capture --floor carpet|planks``: 40 JPEGs at 400 px with lens distortion, portrait and EXIF-rotated
  shots) given as a plain folder of photos; a busy red carpet has more features than the object.
- ``lego``: the 100 Lego training renders over textured backdrops that differ from photo to photo.

Per capture it prints the photos registered, the time ``doodle fit`` spends in SfM, in the automatic masks and
in the fit (from the moments its log lines arrive), the automatic masks' IoU with the true masks (bar 0.9 in
the mean) and ``doodle eval`` of the sketch against the true masks on the photos (silhouette recall bar 0.8).
With ``--keep DIR`` it keeps everything and draws ``DIR/NAME/sheet.png``: four photos, their automatic masks and
the sketch from the same cameras. ``--held-out`` also fits again without every 8th registered photo (same
poses and masks) and scores those photos. Captures needing ``../shared/data`` skip cleanly without it; a
capture ``doodle fit`` refuses (SfM placing none of its photos) prints its one-line error and the others still
run (exit 1 at the end).

Run: ``python benchmarks/bench_capture.py [--captures dtu,carpet-cow] [--keep DIR] [--held-out]``.
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
from PIL import Image, ImageOps
from scipy import ndimage

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
LEGO = DATA / "nerf_synthetic" / "lego"
DTU = DATA / "dtu" / "scan65"
UPRIGHT = {3: Image.Transpose.ROTATE_180, 6: Image.Transpose.ROTATE_270, 8: Image.Transpose.ROTATE_90}  # EXIF turns
PROCEDURAL = {"carpet-parcel": ("parcel", "carpet"), "carpet-cow": ("cow", "carpet"), "carpet-calf": ("calf", "carpet"),
              "planks-chair": ("chair", "planks"),
              # objects no part of the masks' tuning saw: a lamp with a gold finial, a microphone on a tripod
              **{f"carpet-{name}": (name, "carpet") for name in ("teapot", "mug", "lamp", "mouse", "tripod")}}


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


def lego_photos(photos: Path, truth: Path, n: int = 100) -> None:
    frames = json.loads((LEGO / "transforms_train.json").read_text())["frames"]
    rng = np.random.default_rng(0)
    for i in np.linspace(0, len(frames) - 1, n).round().astype(int):
        name = Path(frames[i]["file_path"]).name
        rgba = np.asarray(Image.open(LEGO / f"{frames[i]['file_path']}.png").convert("RGBA")).astype(np.float32)
        a = rgba[..., 3:] / 255
        out = rgba[..., :3] * a + background(rgba.shape[:2], rng) * (1 - a)
        Image.fromarray(np.clip(out + 0.5, 0, 255).astype(np.uint8)).save(photos / f"{name}.jpg", quality=92)
        Image.fromarray(((a[..., 0] > 0.5) * 255).astype(np.uint8)).save(truth / f"{name}.png")


def dtu_photos(photos: Path, truth: Path) -> None:
    for p in sorted((DTU / "image").glob("*.png")):
        shutil.copy(p, photos / p.name)
    for i, p in enumerate(sorted((DTU / "mask").glob("*.png"))):
        Image.open(p).convert("L").point(lambda v: 255 * (v > 127)).save(truth / f"{i:06d}.png")


def dtu_neus(scene: Path, truth: Path) -> None:
    (scene / "image").mkdir()
    dtu_photos(scene / "image", truth)
    shutil.copy(DTU / "cameras_sphere.npz", scene)


def procedural_photos(name: str, floor: str, photos: Path, truth: Path, work: Path) -> None:
    from doodle.samples.capture import write_capture

    cap = write_capture(name, work / "capture", n=40, size=400, floor=floor)
    for p in sorted((cap / "images").glob("*.jpg")):
        shutil.copy(p, photos / p.name)
        with Image.open(p) as im:  # the true masks as the photos are shown (upright), as a user draws them
            turn = im.getexif().get(0x0112, 1)
        m = Image.open(cap / "true_masks" / f"{p.stem}.png")
        if turn in UPRIGHT:
            m = m.transpose(UPRIGHT[turn])
        m.save(truth / f"{p.stem}.png")
    shutil.rmtree(cap)


class CaptureFailed(Exception):
    """``doodle fit`` refused a capture (its one-line error): reported, and the other captures still run."""


def fit_timed(cmd: list[str]) -> tuple[dict[str, float], list[str]]:
    """Run ``doodle fit``; the seconds at which SfM, the automatic masks and the fit ended (from its log)."""
    t0 = time.perf_counter()
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    marks, lines = {}, []
    for line in p.stdout:
        lines.append(line.rstrip())
        now = time.perf_counter() - t0
        if line.startswith("loaded ") and "sfm" not in marks:
            marks["sfm"] = now
        if line.startswith("automatic masks written"):
            marks["masks"] = now
    if p.wait() != 0:
        raise CaptureFailed(next((ln for ln in reversed(lines) if ln.startswith("Error:")), lines[-1] if lines else
                                 f"exit {p.returncode}"))
    marks["total"] = time.perf_counter() - t0
    return marks, lines


def mask_ious(auto: Path, truth: Path) -> np.ndarray:
    out = []
    for m in sorted(auto.glob("*.png")):
        a = np.asarray(Image.open(m).convert("L")) > 127
        t = Image.open(truth / m.name).convert("L").resize((a.shape[1], a.shape[0]), Image.Resampling.BOX)
        t = np.asarray(t) > 127
        out.append((a & t).sum() / max((a | t).sum(), 1))
    return np.array(out)


def sheet(photos: Path, auto: Path, views: Path, out: Path, n: int = 4, width: int = 320) -> None:
    """Rows: photos, automatic masks over the photos (object kept, the rest dimmed), the sketch."""
    import cairosvg

    names = sorted(p.stem for p in auto.glob("*.png"))
    pick = [names[i] for i in np.linspace(0, len(names) - 1, n).round().astype(int)]
    svgs = {p.stem: p for p in views.glob("*.svg")}
    svg_names = sorted(svgs)
    tiles = []
    for name in pick:
        photo = ImageOps.exif_transpose(Image.open(next(photos.glob(name + ".*")))).convert("RGB")
        mask = Image.open(auto / f"{name}.png").convert("L").resize(photo.size)
        dim = Image.blend(photo, Image.new("RGB", photo.size, "white"), 0.8)
        svg = svgs[svg_names[names.index(name)]] if len(svg_names) == len(names) else None
        png = out.parent / f"_{name}.png"
        if svg is not None:
            cairosvg.svg2png(url=str(svg), write_to=str(png), output_width=photo.size[0], output_height=photo.size[1],
                             background_color="white")
        sketch = Image.open(png).convert("RGB").resize(photo.size) if svg is not None else Image.new("RGB", photo.size, "white")
        tiles.append([ImageOps.contain(im, (width, width)) for im in (photo, Image.composite(photo, dim, mask), sketch)])
    canvas = Image.new("RGB", (width * n, 3 * width), "white")
    for i, col in enumerate(tiles):  # each tile centred in a square cell: landscape and portrait photos mix
        for j, im in enumerate(col):
            canvas.paste(im, (i * width + (width - im.size[0]) // 2, j * width + (width - im.size[1]) // 2))
    canvas.save(out)
    for p in out.parent.glob("_*.png"):
        p.unlink()


def bench(name: str, work: Path, keep: bool, held: bool) -> str | None:
    photos, truth = work / "photos", work / "true-masks"
    for d in (photos, truth):
        d.mkdir(parents=True)
    if name in ("dtu", "dtu-neus"):
        if not DTU.is_dir():
            return None
        (dtu_photos if name == "dtu" else dtu_neus)(photos, truth)
    elif name == "lego":
        if not LEGO.is_dir():
            return None
        lego_photos(photos, truth)
    else:
        procedural_photos(*PROCEDURAL[name], photos, truth, work)
    doodle = [sys.executable, "-m", "doodle"]
    strokes = work / f"{name}.doodleb"
    marks, log = fit_timed([*doodle, "fit", str(photos), "-o", str(strokes)])
    registered = next((ln.split(": ", 1)[1] for ln in log if ln.startswith("structure-from-motion") and "registered" in ln),
                      "the scene's own poses" if name == "dtu-neus" else "?")
    auto = photos / "doodle-masks"
    ious = mask_ious(auto, truth)
    p = subprocess.run([*doodle, "eval", str(strokes), str(photos), "--split", "train", "--masks", str(truth),
                        "--json", "-"], capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"doodle eval failed on {name}: {p.stderr[-500:]}")
    m = json.loads(p.stdout)
    sfm, masks = marks.get("sfm", 0.0), marks.get("masks", marks.get("sfm", 0.0))
    lines = [
        f"{name:14s} SfM: {registered}",
        f"{'':14s} time: SfM {sfm:.0f} s, masks {masks - sfm:.0f} s, fit {marks['total'] - masks:.0f} s, "
        f"total {marks['total']:.0f} s; {strokes.stat().st_size:,} B",
        f"{'':14s} automatic masks: IoU with the true masks mean {ious.mean():.3f}, min {ious.min():.3f} "
        f"over {len(ious)} views (bar 0.9)",
        f"{'':14s} eval on the photos: line precision {m['line_precision']:.3f}, silhouette recall "
        f"{m['silhouette_recall']:.3f} (bar 0.8), F {m['f_score']:.3f}",
    ]
    if held:
        lines.append(f"{'':14s} {held_out(photos, auto, truth)}")
    if keep:
        subprocess.run([*doodle, "export", str(strokes), "--cameras", str(photos), "--split", "train", "-o",
                        str(work / "views")], capture_output=True, check=True)
        sheet(photos / "image" if name == "dtu-neus" else photos, auto, work / "views", work / "sheet.png")
        lines.append(f"{'':14s} look at {work / 'sheet.png'}")
    return "\n".join(lines)


def held_out(photos: Path, auto: Path, truth: Path, every: int = 8) -> str:
    """Fit without every ``every``-th registered photo (the run's SfM poses and automatic masks) and score
    those photos against the true masks."""
    from doodle.evaluate import evaluate
    from doodle.fit import FitConfig, fit
    from doodle.scenes import load_scene
    from doodle.scenes.automask import with_masks

    quiet = lambda m: None  # noqa: E731
    scene = load_scene(photos)
    test = list(range(3, len(scene), every))
    train = [i for i in range(len(scene)) if i not in test]
    res = fit(with_masks(scene, auto, log=quiet).subset(train), FitConfig(), log=quiet, progress=False)
    m = evaluate(res.strokes, with_masks(scene, truth, log=quiet).subset(test))
    return (f"held out: {len(test)} photos the fit did not see: line precision {m['line_precision']:.3f}, "
            f"silhouette recall {m['silhouette_recall']:.3f}, F {m['f_score']:.3f} ({m['curves']} curves)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--captures", default="dtu,carpet-parcel,carpet-cow",
                    help="comma-separated: dtu, dtu-neus, lego, " + ", ".join(PROCEDURAL))
    ap.add_argument("--keep", type=Path, help="keep photos, masks, strokes and a sheet here")
    ap.add_argument("--held-out", action="store_true", help="also score a fit without every 8th photo on those")
    args = ap.parse_args()
    names = [n.strip() for n in args.captures.split(",") if n.strip()]
    unknown = [n for n in names if n not in ("dtu", "dtu-neus", "lego", *PROCEDURAL)]
    if unknown:
        sys.exit(f"unknown capture {unknown[0]!r}")
    root = args.keep or Path(tempfile.mkdtemp(prefix="doodle-bench-capture-"))
    failed = []
    for name in names:
        work = root / name
        shutil.rmtree(work, ignore_errors=True)
        try:
            report = bench(name, work, args.keep is not None, args.held_out)
        except CaptureFailed as exc:
            failed.append(name)
            report = f"{name:14s} failed: {exc}"
        print(report if report is not None else f"{name:14s} skipped: {DATA} not found", flush=True)
    if args.keep is None:
        shutil.rmtree(root, ignore_errors=True)
    if failed:
        sys.exit(f"{len(failed)} of {len(names)} captures failed: {', '.join(failed)}")


if __name__ == "__main__":
    main()
