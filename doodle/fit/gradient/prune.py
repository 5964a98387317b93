"""After the distance-field curve stage: keep the curves that lie on the views' lines."""

from __future__ import annotations

import numpy as np
import torch

from ...strokes.model import CurveSet
from .targets import ViewTargets, lookup, project


def prune_curves(curves: CurveSet, targets: ViewTargets, max_distance_px: float, min_length_frac: float = 0.02
                 ) -> tuple[CurveSet, np.ndarray]:
    """Keep curves whose samples lie, in most views, within ``max_distance_px`` of a line and whose median
    projected length is at least ``min_length_frac`` of the image size. Returns the kept set and mask."""
    if len(curves) == 0:
        return curves, np.zeros(0, bool)
    c = torch.tensor(curves.control_points, dtype=torch.float32, device=targets.R.device)
    t = torch.linspace(0, 1, 24, device=c.device)[:, None]
    basis = torch.cat([(1 - t) ** 3, 3 * t * (1 - t) ** 2, 3 * t**2 * (1 - t), t**3], -1)
    pts = torch.einsum("tk,nkd->ntd", basis, c)
    N, T, _ = pts.shape
    with torch.no_grad():
        uv, _ = project(pts.reshape(-1, 3), targets.R, targets.t, targets.K)  # (V, N·T, 2)
        dist = lookup(targets.line_dist, uv).reshape(-1, N, T).mean(-1)  # (V, N)
        length = (uv.reshape(-1, N, T, 2).diff(dim=2).norm(dim=-1).sum(-1))  # (V, N)
    med_dist = dist.median(dim=0).values.cpu().numpy()
    med_len = length.median(dim=0).values.cpu().numpy()
    keep = (med_dist <= max_distance_px) & (med_len >= min_length_frac * max(targets.width, targets.height))
    return CurveSet(curves.control_points[keep], curves.width_px), keep
