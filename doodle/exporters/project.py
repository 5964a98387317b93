"""Exact projection of 3D cubic Béziers to 2D cubic paths (DESIGN.md "Projection to SVG").

Orthographic: the projected control points, exactly. Perspective: the image of a cubic is a rational cubic
(weights = depths), which SVG cannot draw; it is split at parameter values until each piece is within
``tolerance`` pixels of a cubic that has the true end points and end tangents (checked at 15 interior
parameters per piece, a parametric distance that bounds the geometric one). Parts nearer than the near
plane are clipped off exactly at the roots of the cubic depth polynomial.
"""

from __future__ import annotations

import numpy as np

from ..cameras import Camera
from ..strokes.bezier import bernstein, bezier_derivative, bezier_points, bezier_segment

_CHECK = np.linspace(0, 1, 17)[1:-1]
_MAX_DEPTH = 16


def depth_intervals(control: np.ndarray, camera: Camera, near: float) -> list[tuple[float, float]]:
    """Parameter intervals of a curve ``(4, 3)`` whose camera depth exceeds ``near``."""
    z = (control @ camera.R.T + camera.t)[:, 2] - near
    if z.min() > 0:  # the curve lies in the hull of its control points: wholly in front
        return [(0.0, 1.0)]
    # Bernstein → power basis of z(t) − near, then its real roots in (0, 1).
    M = np.array([[1, 0, 0, 0], [-3, 3, 0, 0], [3, -6, 3, 0], [-1, 3, -3, 1]], float)
    coeffs = (M @ z)[::-1]
    roots = np.roots(coeffs) if np.abs(coeffs).max() > 0 else np.array([])
    roots = np.sort(roots[np.isreal(roots)].real)
    cuts = np.r_[0.0, roots[(roots > 1e-12) & (roots < 1 - 1e-12)], 1.0]
    out = []
    for a, b in zip(cuts[:-1], cuts[1:]):
        mid = bernstein(np.array([(a + b) / 2]))[0] @ z
        if mid > 0 and b - a > 1e-9:
            out.append((float(a), float(b)))
    return out


def project_curve(control: np.ndarray, camera: Camera, a: float = 0.0, b: float = 1.0,
                  tolerance: float = 0.05, return_breaks: bool = False):
    """2D cubic pieces ``(K, 4, 2)`` drawing the curve ``control (4, 3)`` between parameters ``a`` and ``b``.

    The caller guarantees positive depth on ``[a, b]`` (see :func:`depth_intervals`). With ``return_breaks``
    also returns the ``K + 1`` curve parameters where the pieces meet.
    """
    (pieces, breaks), = project_curves(control[None], [(0, 0, a, b)], [camera], tolerance)
    return (pieces, breaks) if return_breaks else pieces


def project_curves(controls: np.ndarray, intervals: list[tuple[int, int, float, float]], cameras: list[Camera],
                   tolerance: float = 0.05) -> list[tuple[np.ndarray, np.ndarray]]:
    """:func:`project_curve` for many ``(camera index, curve index, a, b)`` intervals at once.

    The adaptive splitting runs breadth first over all intervals of all cameras together. Returns per interval
    the pieces ``(K, 4, 2)`` and the ``K + 1`` parameters where they meet.
    """
    out: list[tuple[np.ndarray, np.ndarray] | None] = [None] * len(intervals)
    persp = []
    for k, (v, n, a, b) in enumerate(intervals):
        if cameras[v].projection == "orthographic":  # exact: the projected control points of the sub-curve
            seg = bezier_segment(controls[n], a, b) if (a, b) != (0.0, 1.0) else controls[n]
            out[k] = (cameras[v].project(seg)[0][None], np.array([a, b]))
        else:
            persp.append(k)
    if persp:
        view = np.array([intervals[k][0] for k in persp])
        curve = np.array([intervals[k][1] for k in persp])
        lo = np.array([intervals[k][2] for k in persp], float)
        hi = np.array([intervals[k][3] for k in persp], float)
        pieces = _split_perspective(controls, curve, view, lo, hi, cameras, tolerance)
        for k, piece in zip(persp, pieces):
            out[k] = piece
    return out


def _split_perspective(controls, curve, view, lo, hi, cameras, tolerance):
    """Adaptive splitting of the perspective images of curve intervals, breadth first over all of them."""
    R = np.array([cam.R for cam in cameras])[view]  # per interval
    t = np.array([cam.t for cam in cameras])[view]
    focal = np.array([[cam.fx, cam.fy] for cam in cameras])[view]
    principal = np.array([[cam.cx, cam.cy] for cam in cameras])[view]
    ctrl_cam = controls[curve] @ R.transpose(0, 2, 1) + t[:, None]  # (I, 4, 3) in camera space
    which = np.arange(len(curve))  # the interval each open piece belongs to
    done_w, done_lo, done_hi, done_c = [], [], [], []
    ts = np.concatenate([[0.0, 1.0], _CHECK])
    for depth in range(_MAX_DEPTH + 1):
        ctrl = ctrl_cam[which]
        tt = lo[:, None] + (hi - lo)[:, None] * ts  # (K, T)
        # Pixels and their derivatives along the piece's own parameter s ∈ [0, 1] (d/ds = (hi − lo) d/dt).
        P = bezier_points(ctrl, tt)  # (K, T, 3)
        D = bezier_derivative(ctrl, tt) * (hi - lo)[:, None, None]
        z = P[..., 2:3]
        fk, ck = focal[which][:, None], principal[which][:, None]
        uv = P[..., :2] / z * fk + ck
        duv = (D[..., :2] * z - P[..., :2] * D[..., 2:3]) / z**2 * fk
        cubic = np.stack([uv[:, 0], uv[:, 0] + duv[:, 0] / 3, uv[:, 1] - duv[:, 1] / 3, uv[:, 1]], axis=1)
        err = np.linalg.norm(bezier_points(cubic, _CHECK) - uv[:, 2:], axis=-1).max(axis=1)
        ok = (err <= tolerance) | (depth == _MAX_DEPTH)
        done_w.append(which[ok]), done_lo.append(lo[ok]), done_hi.append(hi[ok]), done_c.append(cubic[ok])
        mid = 0.5 * (lo + hi)
        bad = ~ok
        which = np.concatenate([which[bad], which[bad]])
        lo, hi = np.concatenate([lo[bad], mid[bad]]), np.concatenate([mid[bad], hi[bad]])
        if len(which) == 0:
            break
    w, a, b, cub = (np.concatenate(x) for x in (done_w, done_lo, done_hi, done_c))
    order = np.lexsort((a, w))
    w, a, b, cub = w[order], a[order], b[order], cub[order]
    cuts = np.flatnonzero(np.diff(w)) + 1
    return [(pc, np.append(pa[0], pb)) for pc, pa, pb in zip(np.split(cub, cuts), np.split(a, cuts), np.split(b, cuts))]


def visibility_runs(controls: np.ndarray, intervals: list[tuple[int, float, float]], is_hidden,
                    samples: int = 48, refine: int = 2, split: int = 16) -> list[list[tuple[float, float, bool]]]:
    """Split parameter intervals of curves into ``(start, end, hidden)`` runs.

    Args:
        controls: ``(N, 4, 3)`` curves.
        intervals: ``(curve index, a, b)`` triples.
        is_hidden: ``(points (P, 3), rows (P,), t (P,))`` → bool ``(P,)``, where ``rows`` gives the interval
            each point belongs to and ``t`` its curve parameter; called once for the samples of all intervals
            and once per refinement round for all state changes together.
        refine, split: each round cuts the bracket around every state change into ``split`` parts (a
            ``split``-ary search: two rounds of 16 locate a change as well as eight bisection steps, in a
            quarter of the calls).
    Returns:
        Per interval, its runs in parameter order.
    """
    if not intervals:
        return []
    idx = np.array([i for i, _, _ in intervals])
    a = np.array([x for _, x, _ in intervals])
    b = np.array([x for _, _, x in intervals])
    s = np.linspace(0, 1, samples)
    t = a[:, None] + (b - a)[:, None] * s  # (I, S)
    pts = bezier_points(controls[idx], t)  # (I, S, 3)
    state = is_hidden(pts.reshape(-1, 3), np.repeat(np.arange(len(idx)), samples), t.ravel()).reshape(len(idx), samples)
    ci, cj = np.nonzero(state[:, 1:] != state[:, :-1])  # changes between sample j and j+1 of interval i
    lo, hi = t[ci, cj], t[ci, cj + 1]
    left = state[ci, cj]
    ctrl = controls[idx[ci]]
    inner = np.arange(1, split) / split
    for _ in range(refine if len(ci) else 0):
        tm = lo[:, None] + (hi - lo)[:, None] * inner  # (C, split − 1)
        p = bezier_points(ctrl, tm)
        same = is_hidden(p.reshape(-1, 3), np.repeat(ci, split - 1), tm.ravel()).reshape(tm.shape) == left[:, None]
        # The first sample that differs from the left state ends the bracket (the state changes once inside).
        first = np.where(same.all(axis=1), split - 1, np.argmin(same, axis=1))
        rows = np.arange(len(tm))
        new_lo = np.where(first > 0, tm[rows, np.maximum(first - 1, 0)], lo)
        hi = np.where(first < split - 1, tm[rows, np.minimum(first, split - 2)], hi)
        lo = new_lo
    cut = 0.5 * (lo + hi)
    runs: list[list[tuple[float, float, bool]]] = [[(float(a[k]), float(b[k]), bool(state[k, 0]))] for k in range(len(idx))]
    for k in np.unique(ci):  # only intervals with state changes need cutting
        mine = ci == k
        cuts = np.concatenate([[a[k]], cut[mine], [b[k]]])
        states = np.concatenate([[state[k, 0]], ~left[mine]])  # after each change the state flips
        runs[k] = [(float(cuts[m]), float(cuts[m + 1]), bool(states[m])) for m in range(len(cuts) - 1) if cuts[m + 1] > cuts[m]]
    return runs
