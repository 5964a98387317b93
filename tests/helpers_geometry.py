"""Geometry helpers for quality tests: distances between sampled curves and ground-truth edge segments."""

from __future__ import annotations

import numpy as np

from doodle.strokes.bezier import bezier_points


def sample_curves(control: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Points along curves ``(N, 4, 3)`` about ``step`` apart, and the arc length each point stands for."""
    pts, weights = [], []
    for c in control:
        dense = bezier_points(c, np.linspace(0, 1, 400))
        seg = np.linalg.norm(np.diff(dense, axis=0), axis=1)
        n = max(2, int(seg.sum() / step))
        s = np.linspace(0, seg.sum(), n)
        cum = np.r_[0, np.cumsum(seg)]
        idx = np.clip(np.searchsorted(cum, s) - 1, 0, len(seg) - 1)
        f = ((s - cum[idx]) / np.maximum(seg[idx], 1e-12))[:, None]
        pts.append(dense[idx] + f * (dense[idx + 1] - dense[idx]))
        weights.append(np.full(n, seg.sum() / n))
    return np.concatenate(pts), np.concatenate(weights)


def sample_segments(segs: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
    pts, w = [], []
    for a, b in segs:
        L = np.linalg.norm(b - a)
        n = max(1, int(np.ceil(L / step)))
        t = (np.arange(n) + 0.5) / n
        pts.append(a + t[:, None] * (b - a))
        w.append(np.full(n, L / n))
    return np.concatenate(pts), np.concatenate(w)


def point_segment_distance(p: np.ndarray, segs: np.ndarray) -> np.ndarray:
    """Distance of each point ``(P, 3)`` to the nearest segment ``(K, 2, 3)``."""
    a, b = segs[:, 0], segs[:, 1]
    ab = b - a
    out = np.full(len(p), np.inf)
    for chunk in range(0, len(p), 512):
        q = p[chunk:chunk + 512, None, :]
        t = np.clip(((q - a) * ab).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-12), 0, 1)
        d = np.linalg.norm(q - (a + t[..., None] * ab), axis=-1)
        out[chunk:chunk + 512] = d.min(axis=1)
    return out


def edge_scores(control: np.ndarray, gt_edges: np.ndarray, tol: float) -> tuple[float, float]:
    """(share of curve length within ``tol`` of a GT edge, share of GT edge length within ``tol`` of a curve)."""
    if len(control) == 0:
        return 0.0, 0.0
    cp, cw = sample_curves(control, tol / 4)
    precision = float(cw[point_segment_distance(cp, gt_edges) <= tol].sum() / cw.sum())
    gp, gw = sample_segments(gt_edges, tol / 4)
    from scipy.spatial import cKDTree

    d, _ = cKDTree(cp).query(gp)
    recall = float(gw[d <= tol].sum() / gw.sum())
    return precision, recall
