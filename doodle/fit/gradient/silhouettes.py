"""The superquadrics' silhouettes against the views: how well their union's silhouette matches the masks (the
silhouette fit's score), and the pixels their drawn outlines take (left out of the curve stage's targets)."""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from ...arrays import silhouette_boundary
from ...strokes.model import CurveSet, SceneFrame, StrokeSet, SuperquadricSet, Voxels
from ...exporters.raster import raster_layer


def silhouette_pixels(sq: SuperquadricSet, frame: SceneFrame, cameras, grow_px: int = 3,
                      occluder: Voxels | None = None, hull: Voxels | None = None) -> list[np.ndarray]:
    """Per camera, the pixels within ``grow_px`` of the outline as the exporter draws it: the union's visible
    silhouette and the ``hull``'s."""
    from ...exporters.drawing import DrawOptions, draw_many

    strokes = StrokeSet(frame, CurveSet(), sq, occluder=occluder, hull=hull)
    drawings = draw_many(strokes, cameras, DrawOptions(curves=False, hidden="hide", silhouette_grid=(32, 64), tolerance=0.5))
    out = []
    for cam, per in zip(cameras, raster_layer(drawings, cameras, "silhouettes", lambda _: 0)):
        img = per.get(0, np.zeros((cam.height, cam.width), bool))
        out.append(ndimage.binary_dilation(img, iterations=grow_px) if grow_px else img)
    return out


def silhouette_scores(sq: SuperquadricSet, cameras, masks, size: int = 96, max_views: int = 12,
                      tau: float = 1.5) -> tuple[float, float]:
    """Mean mask IoU and boundary F-score (τ px) of the union's ray-cast silhouette against the masks.

    Cameras are scaled to ``size`` px; at most ``max_views`` views, evenly picked. The boundary score is the
    one that sees a missing neck between two balls, which barely changes the IoU.
    """
    from PIL import Image

    from ...exporters.visibility import union_mask

    step = max(1, len(cameras) // max_views)
    ious, fs = [], []
    for cam, mask in zip(cameras[::step], masks[::step]):
        c = cam.scaled(size / max(cam.width, cam.height))
        m = np.asarray(Image.fromarray(mask.astype(np.uint8) * 255).resize((c.width, c.height), Image.Resampling.BOX)) > 127
        u = union_mask(sq, c, samples=32) if len(sq) else np.zeros_like(m)
        union = (u | m).sum()
        ious.append((u & m).sum() / union if union else 1.0)
        bu, bm = silhouette_boundary(u), silhouette_boundary(m)
        if not bu.any() or not bm.any():
            fs.append(0.0)
            continue
        p = (ndimage.distance_transform_edt(~bm)[bu] <= tau).mean()
        r = (ndimage.distance_transform_edt(~bu)[bm] <= tau).mean()
        fs.append(2 * p * r / (p + r) if p + r else 0.0)
    return float(np.mean(ious)), float(np.mean(fs))


def silhouette_iou(sq: SuperquadricSet, cameras, masks) -> float:
    """Mean silhouette IoU of the union against the masks (see :func:`silhouette_scores`)."""
    return silhouette_scores(sq, cameras, masks)[0]
