"""Benchmark the features people draw inside the outline: recall of painted boundaries, line precision,
silhouette F and bytes, per ``--detail`` level, on procedural scenes whose paint is known.

Scenes: ``calf`` (the toy cow painted as a cartoon: eyes, a muzzle with nostrils, patches on its hide),
``mouse`` (button seams, grips, a scroll wheel) and, for what the choice must not lose, ``cow`` and ``parcel``
(printed tape and gores, which are not eyes); ``skull``: DTU's scan65 (real photos, true masks; skipped
without ``../shared/data``), whose hollows are the features.
``painted``: the share of the painted boundaries the held-out views see (:func:`doodle.samples.painted_boundaries`)
within 2 px of a drawn stroke at 256 px; ``P``, ``R``, ``F``: ``doodle eval`` on the held-out views (the
skull's on its 49 photos, which the fit saw: DTU has no held-out split). ``hollows``: of the skull's eye
sockets, nose and missing tooth, as marked on its frontal photo, how many the drawing of that view encloses.

Bars (issue 49), default settings on 2 CPU cores: painted recall ≥ 0.8, line precision ≥ 0.92, silhouette F
≥ 0.94, binary ≤ 2.5 kB; the levels visibly differ (``--figure``).

Run: ``python benchmarks/bench_features.py [--only calf,mouse,cow,parcel,skull] [--levels low,medium,high] [--figure PNG]
[--keep DIR]``.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

from bench_abstraction import keep, photo, views_png  # the same figure cells and files as the abstraction's
from doodle.evaluate import boundary_recall, evaluate
from doodle.fit import FitConfig, fit
from doodle.samples import load_ground_truth, painted_boundaries, write_sample
from doodle.scenes import load_scene
from doodle.strokes.binary import encode

SCENES = ("calf", "mouse", "cow", "parcel", "skull")
LEVELS = ("low", "medium", "high")
DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
SKULL = DATA / "dtu" / "scan65"
#: The skull's hollows on its frontal photo (000024.png, 800 × 600): right and left eye socket, nose, the gap of
#: a missing tooth (read off the photo).
SKULL_VIEW, SKULL_HOLLOWS = 24, ((280, 285), (430, 295), (330, 355), (300, 487))


def enclosed(strokes, camera, points, most: float = 0.02) -> int:
    """How many image ``points`` ``(x, y)`` the drawing of ``camera`` encloses: the region of undrawn pixels
    round each is smaller than ``most`` of the image and off its border."""
    import numpy as np
    from scipy import ndimage

    from doodle.evaluate import drawn_pixels

    ink = ndimage.binary_dilation(drawn_pixels(strokes, [camera])[0])
    labels, _ = ndimage.label(~ink)
    border = set(np.unique(np.r_[labels[0], labels[-1], labels[:, 0], labels[:, -1]]))
    count = 0
    for x, y in points:
        k = labels[int(y), int(x)]
        count += bool(k) and k not in border and (labels == k).sum() < most * ink.size
    return count


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", default=",".join(SCENES))
    ap.add_argument("--levels", default=",".join(LEVELS))
    ap.add_argument("--figure", type=Path, help="one PNG: per scene a held-out image, then that view at each level")
    ap.add_argument("--views", default="1,3", help="held-out views of --figure")
    ap.add_argument("--keep", type=Path, help="write every stroke file here (SCENE-LEVEL.doodleb)")
    args = ap.parse_args()
    levels = args.levels.split(",")
    picks = [int(v) for v in args.views.split(",")]
    print(f"{'scene':8s} {'level':7s} {'s':>6s} {'bytes':>6s} {'curves':>6s} {'sq':>3s} {'painted':>7s} "
          f"{'P':>6s} {'R':>6s} {'F':>6s} {'hollows':>7s}")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.only.split(","):
            if name == "skull":
                if not SKULL.is_dir():
                    print(f"skull: {SKULL} is not here, skipped")
                    continue
                train = test = load_scene(SKULL)
                truth, views = [], (SKULL_VIEW, 10)
            else:
                d = write_sample(name, Path(tmp) / name)
                train, test = load_scene(d), load_scene(d, split="test")
                truth, views = [painted_boundaries(p, cam) for p in [load_ground_truth(d)["primitives"]]
                                for cam in test.cameras], picks
            row = []
            if args.figure:
                row += [photo(test, v) for v in views]
            for level in levels:
                t0 = time.perf_counter()
                res = fit(train, FitConfig(detail=level), log=lambda m: None, progress=False)
                dt = time.perf_counter() - t0
                s = res.strokes
                m = evaluate(s, test)
                painted = boundary_recall(s, test.cameras, truth) if any(t.any() for t in truth) else float("nan")
                hollows = f"{enclosed(s, test.cameras[SKULL_VIEW], SKULL_HOLLOWS)}/{len(SKULL_HOLLOWS)}" \
                    if name == "skull" else ""
                print(f"{name:8s} {level:7s} {dt:6.1f} {len(encode(s)):6d} {len(s.curves):6d} {len(s.superquadrics):3d} "
                      f"{painted:7.3f} {m['line_precision']:6.3f} {m['silhouette_recall']:6.3f} {m['f_score']:6.3f} "
                      f"{hollows:>7s}", flush=True)
                if args.keep:
                    keep(args.keep, f"{name}-{level}", s)
                if args.figure:
                    row.append(views_png(s, test, views))
            rows.append(row)
    if args.figure and rows:
        from PIL import Image

        width = max(sum(im.width for im in r) for r in rows)
        out = Image.new("RGB", (width, 256 * len(rows)), "white")
        for r, row in enumerate(rows):
            x = 0
            for im in row:
                out.paste(im, (x, 256 * r))
                x += im.width
        out.save(args.figure)


if __name__ == "__main__":
    sys.exit(main())
