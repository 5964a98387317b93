"""Which superquadrics earn their outline: each must draw real silhouette that the curves do not draw.

A superquadric's outline is drawn when, over the training views, most of its visible contour lies on the
images' lines — the mask boundary or an edge inside it, where one part hides another — (``min_precision``:
it draws the object's outline, not a rounded guess across a box) and enough of it lies away from the
curves' lines (``min_novelty``: it adds outline the curves miss). The others still hide what lies behind
them (occluders for hidden-line removal), unless they spill out of the silhouettes, where they would hide
lines in plain view.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
from scipy import ndimage

from ..cameras import Camera
from ..strokes.bezier import bezier_points
from ..strokes.model import CurveSet, SceneFrame, StrokeSet, SuperquadricSet


def raster_layer(drawings, cameras: list[Camera], layer: str, owner_of: Callable[[str], int]) -> list[dict[int, np.ndarray]]:
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
    sil = raster_layer(drawings, cameras, "silhouettes", lambda pid: int(pid.split("-")[1]))
    crv = raster_layer(drawings, cameras, "curves", lambda pid: 0)
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


def inside_share(sq: SuperquadricSet, cameras: list[Camera], masks: list[np.ndarray], size: int = 96,
                 max_views: int = 12) -> np.ndarray:
    """Per superquadric, the share of its own silhouette that lies inside the (slightly grown) masks."""
    from PIL import Image

    from ..exporters.visibility import union_mask

    step = max(1, len(cameras) // max_views)
    inside, total = np.zeros(len(sq)), np.zeros(len(sq))
    for cam, mask in zip(cameras[::step], masks[::step]):
        c = cam.scaled(size / max(cam.width, cam.height))
        m = np.asarray(Image.fromarray(mask.astype(np.uint8) * 255).resize((c.width, c.height), Image.Resampling.BOX)) > 0
        m = ndimage.binary_dilation(m, iterations=1)
        for i in range(len(sq)):
            u = union_mask(sq.subset(np.array([i])), c, samples=24)
            inside[i] += (u & m).sum()
            total[i] += u.sum()
    return np.where(total > 0, inside / np.maximum(total, 1), 0.0)


def keep_outlines(sq: SuperquadricSet, curves: CurveSet, frame: SceneFrame, cameras: list[Camera],
                  lines: list[np.ndarray], masks: list[np.ndarray], min_precision: float = 0.7,
                  min_novelty: float = 0.6, min_inside: float = 0.9,
                  log: Callable[[str], None] = lambda m: None) -> SuperquadricSet:
    """Decide each superquadric's role (see the module doc): a drawn outline, an occluder only, or dropped.

    A superquadric whose silhouette spills out of the masks (less than ``min_inside`` of it inside) would
    hide lines that are in plain view, so it is dropped. Of the rest, those whose contour fails
    ``min_precision`` or ``min_novelty`` keep hiding what is behind them, but draw nothing.
    """
    if len(sq) == 0:
        return sq
    inside = inside_share(sq, cameras, masks)
    keep = inside >= min_inside
    for i in np.flatnonzero(~keep):
        log(f"superquadrics: dropping one that spills out of the silhouettes ({inside[i]:.0%} inside)")
    sq = sq.subset(keep)
    if len(sq) == 0:
        return sq
    precision, novelty = outline_scores(sq, curves, frame, cameras, lines)
    drawn = (precision >= min_precision) & (novelty >= min_novelty)
    for i in np.flatnonzero(~drawn):
        log(f"superquadrics: one hides what is behind it but draws no outline ({precision[i]:.0%} of its outline "
            f"on image lines, {novelty[i]:.0%} new beside the curves)")
    sq.outline = drawn
    return sq


def useful_occluders(sq: SuperquadricSet, curves: CurveSet, frame: SceneFrame, cameras: list[Camera],
                     depth: list[np.ndarray], hull_margin: float, occlusion_margin: float = 0.03,
                     samples_per_curve: int = 12) -> SuperquadricSet:
    """Keep the superquadrics that draw an outline, and of the occluder-only ones those that help: on points
    of the curves, over the views, an occluder must agree with the visual hull on what is hidden (``depth``:
    the hull's depth maps of ``cameras``) more often than it disagrees — hiding a visible point counts
    double, hiding one the face normals already hide counts nothing.
    """
    from ..exporters.drawing import back_facing
    from ..exporters.visibility import occluded
    from .evidence import _project

    if len(sq) == 0 or sq.drawn.all():
        return sq
    if len(curves) == 0:
        return sq.subset(sq.drawn)
    t = np.linspace(0.05, 0.95, samples_per_curve)
    pts = bezier_points(curves.control_points, t).reshape(-1, 3)
    tt = np.tile(t, len(curves))
    normals = np.repeat(curves.normals, samples_per_curve, axis=0) if curves.normals is not None else None
    rows, views, truth, shown = [], [], [], []
    for v, (cam, zb) in enumerate(zip(cameras, depth)):
        u, w, z = _project(cam, pts.astype(np.float32))
        ok = (z > 1e-6) & (u >= 0) & (w >= 0) & (u < cam.width) & (w < cam.height)
        idx = np.flatnonzero(ok)
        vis = z[idx] <= zb[w[idx], u[idx]] + hull_margin
        facing = np.ones(len(idx), bool)
        if normals is not None:
            n = len(idx)
            facing = ~back_facing(pts[idx], tt[idx], normals[idx], np.repeat(cam.center[None], n, 0),
                                  np.repeat(cam.forward[None], n, 0), np.full(n, cam.projection == "orthographic"))
        rows.append(idx), views.append(np.full(len(idx), v)), truth.append(vis), shown.append(facing)
    idx, view = np.concatenate(rows), np.concatenate(views)
    truth, shown = np.concatenate(truth), np.concatenate(shown)
    margin = occlusion_margin * frame.radius
    keep = sq.drawn.copy()
    for i in np.flatnonzero(~sq.drawn):
        hides = occluded(pts[idx], view, cameras, sq.subset(np.array([i])), margin) & shown
        gain = int((hides & ~truth).sum()) - 2 * int((hides & truth).sum())
        keep[i] = gain > 0
    return sq.subset(keep)
