"""Fit 2D polylines with as few cubic Béziers as a tolerance allows (Schneider, Graphics Gems 1990).

Used for superquadric silhouettes, whose contours come out of marching squares as dense polylines.
"""

from __future__ import annotations

import numpy as np


def bernstein(u: np.ndarray) -> np.ndarray:
    """Cubic Bernstein basis ``(T, 4)`` (numpy only: this module makes thousands of tiny calls)."""
    s = 1.0 - u
    return np.stack([s**3, 3 * u * s**2, 3 * u**2 * s, u**3], axis=1)


def _chord_params(pts: np.ndarray) -> np.ndarray:
    d = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))]
    return d / d[-1] if d[-1] > 0 else np.linspace(0, 1, len(pts))


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v)
    return v / n if n > 1e-12 else v


def _fit_one(pts: np.ndarray, u: np.ndarray, t0: np.ndarray, t1: np.ndarray) -> np.ndarray:
    """Least-squares cubic with fixed end points and end tangent directions ``t0`` (out) and ``t1`` (in)."""
    B = bernstein(u)
    A0, A1 = B[:, 1:2] * t0, B[:, 2:3] * t1
    C = np.array([[np.sum(A0 * A0), np.sum(A0 * A1)], [np.sum(A0 * A1), np.sum(A1 * A1)]])
    tmp = pts - (B[:, :1] + B[:, 1:2]) * pts[0] - (B[:, 2:3] + B[:, 3:4]) * pts[-1]
    X = np.array([np.sum(A0 * tmp), np.sum(A1 * tmp)])
    seg_len = np.linalg.norm(pts[-1] - pts[0])
    det = np.linalg.det(C)
    alpha = np.linalg.solve(C, X) if abs(det) > 1e-12 else np.array([-1.0, -1.0])
    if alpha[0] < 1e-6 * seg_len or alpha[1] < 1e-6 * seg_len:  # degenerate: Wu/Barsky heuristic
        alpha = np.array([seg_len / 3, seg_len / 3])
    return np.stack([pts[0], pts[0] + alpha[0] * t0, pts[-1] + alpha[1] * t1, pts[-1]])


def _reparameterise(ctrl: np.ndarray, pts: np.ndarray, u: np.ndarray) -> np.ndarray:
    """One Newton step of each parameter towards the point's closest curve point."""
    B = bernstein(u)
    q = B @ ctrl
    d1 = 3 * (ctrl[1:] - ctrl[:-1])
    d2 = 2 * (d1[1:] - d1[:-1])
    s = 1 - u[:, None]
    uu = u[:, None]
    q1 = s**2 * d1[0] + 2 * s * uu * d1[1] + uu**2 * d1[2]
    q2 = s * d2[0] + uu * d2[1]
    num = np.sum((q - pts) * q1, axis=1)
    den = np.sum(q1 * q1 + (q - pts) * q2, axis=1)
    step = np.where(np.abs(den) > 1e-12, num / np.where(np.abs(den) > 1e-12, den, 1.0), 0.0)
    out = np.clip(u - step, 0, 1)
    return np.maximum.accumulate(out)  # keep parameters ordered


def _max_error(ctrl: np.ndarray, pts: np.ndarray, u: np.ndarray) -> tuple[float, int]:
    err = np.linalg.norm(bernstein(u) @ ctrl - pts, axis=1)
    i = int(np.argmax(err))
    return float(err[i]), i


def fit_cubics(points: np.ndarray, tolerance: float, closed: bool = False, max_depth: int = 24) -> np.ndarray:
    """Fit a polyline with cubic Béziers whose distance to every input point is ≤ ``tolerance``.

    Args:
        points: ``(P, 2)`` polyline (``P ≥ 2``); ``closed`` means the last point joins the first.
        tolerance: maximum distance in the points' units.
    Returns:
        ``(K, 4, 2)`` control points of consecutive cubics (``K ≥ 1``).

    >>> pts = np.stack([np.linspace(0, 1, 20), np.linspace(0, 1, 20) ** 2], 1)
    >>> segs = fit_cubics(pts, 1e-3)
    >>> len(segs), bool(np.allclose(segs[0, 0], pts[0]) and np.allclose(segs[-1, -1], pts[-1]))
    (1, True)
    """
    pts = np.asarray(points, dtype=np.float64)
    keep = np.r_[True, np.linalg.norm(np.diff(pts, axis=0), axis=1) > 1e-9]
    pts = pts[keep]
    if closed and len(pts) > 2 and np.linalg.norm(pts[0] - pts[-1]) > 1e-9:
        pts = np.vstack([pts, pts[:1]])
    if len(pts) < 2:
        p = pts[0] if len(pts) else np.zeros(2)
        return np.stack([p, p, p, p])[None]
    if closed and len(pts) > 3:
        t0 = t1 = _unit(pts[1] - pts[-2])
        return np.array(_fit_rec(pts, t0, -t1, tolerance, max_depth))
    return np.array(_fit_rec(pts, _unit(pts[1] - pts[0]), _unit(pts[-2] - pts[-1]), tolerance, max_depth))


def _fit_rec(pts: np.ndarray, t0: np.ndarray, t1: np.ndarray, tol: float, depth: int) -> list[np.ndarray]:
    if len(pts) == 2:
        d = np.linalg.norm(pts[1] - pts[0]) / 3
        return [np.stack([pts[0], pts[0] + d * t0, pts[1] + d * t1, pts[1]])]
    u = _chord_params(pts)
    ctrl = _fit_one(pts, u, t0, t1)
    err, split = _max_error(ctrl, pts, u)
    if err <= tol:
        return [ctrl]
    if err <= 4 * tol:  # close: try improving the parameterisation before splitting
        for _ in range(3):
            u = _reparameterise(ctrl, pts, u)
            ctrl = _fit_one(pts, u, t0, t1)
            err, split = _max_error(ctrl, pts, u)
            if err <= tol:
                return [ctrl]
    if depth <= 0:
        return [ctrl]
    split = min(max(split, 1), len(pts) - 2)
    tc = _unit(pts[split - 1] - pts[split + 1])
    return _fit_rec(pts[: split + 1], t0, tc, tol, depth - 1) + _fit_rec(pts[split:], -tc, t1, tol, depth - 1)
