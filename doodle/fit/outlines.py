"""Which superquadrics earn their outline: each must draw real silhouette that the curves do not draw.

A superquadric is kept when, over the training views, most of its visible contour lies on the images' lines
— the mask boundary or an edge inside it, where one part hides another — (``min_precision``: it draws the
object's outline, not a rounded guess across a box) and enough of it lies away from the curves' lines
(``min_novelty``: it adds outline the curves miss). The worst one is
dropped and the test repeated, since the others' contours change when one leaves the union.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
from scipy import ndimage

from ..cameras import Camera
from ..strokes.bezier import bezier_points
from ..strokes.model import CurveSet, SceneFrame, StrokeSet, SuperquadricSet


def _raster(drawings, cameras: list[Camera], layer: str, owner_of: Callable[[str], int]) -> list[dict[int, np.ndarray]]:
    """Per view, pixel masks of a layer's paths, grouped by ``owner_of(path id)``."""
    out = []
    for cam, d in zip(cameras, drawings):
        per: dict[int, np.ndarray] = {}
        for op in d.layer(layer):
            img = per.setdefault(owner_of(op.id), np.zeros((cam.height, cam.width), bool))
            for sp in op.subpaths:
                for seg in sp:
                    n = int(np.abs(np.diff(seg, axis=0)).sum()) * 2 + 4
                    p = np.floor(bezier_points(seg, np.linspace(0, 1, n))).astype(int)
                    ok = (p[:, 0] >= 0) & (p[:, 1] >= 0) & (p[:, 0] < cam.width) & (p[:, 1] < cam.height)
                    img[p[ok, 1], p[ok, 0]] = True
        out.append(per)
    return out


def outline_scores(sq: SuperquadricSet, curves: CurveSet, frame: SceneFrame, cameras: list[Camera],
                   lines: list[np.ndarray], tau_px: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """Per superquadric: ``(precision, novelty)`` of its visible contour over the views (see the module doc);
    ``lines`` are the views' line maps (:func:`~doodle.fit.evidence.object_lines`)."""
    from ..exporters.drawing import DrawOptions, draw_many

    drawings = draw_many(StrokeSet(frame, curves, sq), cameras,
                         DrawOptions(hidden="hide", silhouette_grid=(32, 64), tolerance=0.5))
    sil = _raster(drawings, cameras, "silhouettes", lambda pid: int(pid.split("-")[1]))
    crv = _raster(drawings, cameras, "curves", lambda pid: 0)
    on_rim = np.zeros(len(sq))
    novel = np.zeros(len(sq))
    total = np.zeros(len(sq))
    for per, cur, lm in zip(sil, crv, lines):
        rim = ndimage.binary_dilation(lm, iterations=tau_px)
        drawn = ndimage.binary_dilation(cur[0], iterations=tau_px) if 0 in cur else np.zeros_like(lm)
        for i, img in per.items():
            total[i] += img.sum()
            on_rim[i] += (img & rim).sum()
            novel[i] += (img & ~drawn).sum()
    safe = np.maximum(total, 1)
    return np.where(total > 0, on_rim / safe, 0.0), np.where(total > 0, novel / safe, 0.0)


def keep_outlines(sq: SuperquadricSet, curves: CurveSet, frame: SceneFrame, cameras: list[Camera],
                  lines: list[np.ndarray], min_precision: float = 0.7, min_novelty: float = 0.6,
                  log: Callable[[str], None] = lambda m: None) -> SuperquadricSet:
    """Drop superquadrics whose outline is mostly wrong or already drawn by curves, worst first."""
    while len(sq):
        precision, novelty = outline_scores(sq, curves, frame, cameras, lines)
        merit = np.minimum(precision / min_precision, novelty / min_novelty)
        worst = int(np.argmin(merit))
        if merit[worst] >= 1.0:
            break
        log(f"superquadrics: dropping one whose outline is {precision[worst]:.0%} on image lines and "
            f"{novelty[worst]:.0%} new beside the curves")
        sq = sq.subset(np.arange(len(sq)) != worst)
    return sq
