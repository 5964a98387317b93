"""Fit 2D polylines with as few cubic Béziers as a tolerance allows (Schneider, Graphics Gems 1990).

Used for superquadric silhouettes, whose contours come out of marching squares as dense polylines.
"""

from __future__ import annotations

import numpy as np


def bernstein(u: np.ndarray) -> np.ndarray:
    """Cubic Bernstein basis ``(T, 4)`` (numpy only: this module makes thousands of tiny calls)."""
    s = 1.0 - u
    out = np.empty((len(u), 4))
    out[:, 0], out[:, 1], out[:, 2], out[:, 3] = s * s * s, 3 * u * s * s, 3 * u * u * s, u * u * u
    return out


def _chord_params(pts: np.ndarray) -> np.ndarray:
    d = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))]
    return d / d[-1] if d[-1] > 0 else np.linspace(0, 1, len(pts))


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v)
    return v / n if n > 1e-12 else v


def _tangent(p0: np.ndarray, p1: np.ndarray, p2: np.ndarray) -> np.ndarray:
    """Unit tangent at ``p0`` of the quadratic through ``p0, p1, p2`` (chord-length spacing): second-order
    accurate, where the secant ``p1 − p0`` leaves an error floor the fit can only meet by splitting."""
    h1, h2 = np.linalg.norm(p1 - p0), np.linalg.norm(p2 - p1)
    if h1 < 1e-12 or h2 < 1e-12:
        return _unit(p1 - p0)
    d = -(2 * h1 + h2) / (h1 * (h1 + h2)) * p0 + (h1 + h2) / (h1 * h2) * p1 - h1 / (h2 * (h1 + h2)) * p2
    return _unit(d)


def _center_tangent(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Unit tangent at ``b`` (pointing from ``a`` towards ``c``) of the quadratic through the three points."""
    h1, h2 = np.linalg.norm(b - a), np.linalg.norm(c - b)
    if h1 < 1e-12 or h2 < 1e-12:
        return _unit(c - a)
    d = -h2 / (h1 * (h1 + h2)) * a + (h2 - h1) / (h1 * h2) * b + h1 / (h2 * (h1 + h2)) * c
    return _unit(d)


def _fit_one(pts: np.ndarray, u: np.ndarray, t0: np.ndarray, t1: np.ndarray) -> np.ndarray:
    """Least-squares cubic with fixed end points and end tangent directions ``t0`` (out) and ``t1`` (in)."""
    s = 1.0 - u
    b0, b1, b2, b3 = s * s * s, 3 * u * s * s, 3 * u * u * s, u * u * u
    p0, p3 = pts[0], pts[-1]
    # A0 = b1 t0, A1 = b2 t1 (outer products); the 2x2 normal equations in closed form.
    c00 = (b1 @ b1) * (t0 @ t0)
    c01 = (b1 @ b2) * (t0 @ t1)
    c11 = (b2 @ b2) * (t1 @ t1)
    tmp = pts - np.outer(b0 + b1, p0) - np.outer(b2 + b3, p3)
    x0 = b1 @ (tmp @ t0)
    x1 = b2 @ (tmp @ t1)
    det = c00 * c11 - c01 * c01
    seg_len = float(np.hypot(*(p3 - p0)))
    if abs(det) > 1e-12:
        a0, a1 = (x0 * c11 - x1 * c01) / det, (c00 * x1 - c01 * x0) / det
    else:
        a0 = a1 = -1.0
    if a0 < 1e-6 * seg_len or a1 < 1e-6 * seg_len:  # degenerate: Wu/Barsky heuristic
        a0 = a1 = seg_len / 3
    return np.array([p0, p0 + a0 * t0, p3 + a1 * t1, p3])


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
    d = bernstein(u) @ ctrl - pts
    err2 = d[:, 0] ** 2 + d[:, 1] ** 2
    i = int(np.argmax(err2))
    return float(np.sqrt(err2[i])), i


def fit_cubics(points: np.ndarray, tolerance: float, closed: bool = False, max_depth: int = 24) -> np.ndarray:
    """Fit a polyline with cubic Béziers whose distance to every input point is ≤ ``tolerance``.

    Args:
        points: ``(P, 2)`` polyline (``P ≥ 2``); ``closed`` means the last point joins the first.
        tolerance: maximum distance in the points' units.
    Returns:
        ``(K, 4, 2)`` control points of consecutive cubics (``K ≥ 1``).

    >>> pts = np.stack([np.linspace(0, 1, 20), np.linspace(0, 1, 20) ** 2], 1)
    >>> segs = fit_cubics(pts, 1e-2)
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
        t0 = _center_tangent(pts[-2], pts[0], pts[1])
        return np.array(_fit_rec(pts, t0, -t0, tolerance, max_depth))
    if len(pts) >= 3:
        return np.array(_fit_rec(pts, _tangent(pts[0], pts[1], pts[2]), _tangent(pts[-1], pts[-2], pts[-3]),
                                 tolerance, max_depth))
    return np.array(_fit_rec(pts, _unit(pts[1] - pts[0]), _unit(pts[0] - pts[1]), tolerance, max_depth))


def _fit_rec(pts: np.ndarray, t0: np.ndarray, t1: np.ndarray, tol: float, depth: int) -> list[np.ndarray]:
    if len(pts) == 2:
        d = np.linalg.norm(pts[1] - pts[0]) / 3
        return [np.stack([pts[0], pts[0] + d * t0, pts[1] + d * t1, pts[1]])]
    u = _chord_params(pts)
    ctrl = _fit_one(pts, u, t0, t1)
    err, split = _max_error(ctrl, pts, u)
    if err <= tol:
        return [ctrl]
    if err <= 16 * tol:  # close: try improving the parameterisation before splitting
        for _ in range(6):
            u = _reparameterise(ctrl, pts, u)
            ctrl = _fit_one(pts, u, t0, t1)
            prev, (err, split) = err, _max_error(ctrl, pts, u)
            if err <= tol:
                return [ctrl]
            if err > 0.9 * prev:  # Newton has stalled: split instead
                break
    if depth <= 0:
        return [ctrl]
    split = min(max(split, 1), len(pts) - 2)
    tc = -_center_tangent(pts[split - 1], pts[split], pts[split + 1])
    return _fit_rec(pts[: split + 1], t0, tc, tol, depth - 1) + _fit_rec(pts[split:], -tc, t1, tol, depth - 1)
