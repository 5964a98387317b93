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


def _project_with_derivative(camera: Camera, control: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pixels ``π(B(t))`` and their parameter derivatives ``(T, 2)`` each."""
    P = bezier_points(control, t) @ camera.R.T + camera.t
    D = bezier_derivative(control, t) @ camera.R.T
    f = np.array([camera.fx, camera.fy])
    c = np.array([camera.cx, camera.cy])
    if camera.projection == "orthographic":
        return P[:, :2] * f + c, D[:, :2] * f
    z = P[:, 2:3]
    return P[:, :2] / z * f + c, (D[:, :2] * z - P[:, :2] * D[:, 2:3]) / z**2 * f


def project_curve(control: np.ndarray, camera: Camera, a: float = 0.0, b: float = 1.0,
                  tolerance: float = 0.05, return_breaks: bool = False):
    """2D cubic pieces ``(K, 4, 2)`` drawing the curve ``control (4, 3)`` between parameters ``a`` and ``b``.

    The caller guarantees positive depth on ``[a, b]`` (see :func:`depth_intervals`). With ``return_breaks``
    also returns the ``K + 1`` curve parameters where the pieces meet.
    """
    if camera.projection == "orthographic":
        seg = bezier_segment(control, a, b) if (a, b) != (0.0, 1.0) else control
        out = camera.project(seg)[0][None]
        return (out, np.array([a, b])) if return_breaks else out
    pieces: list[np.ndarray] = []
    breaks = [a]
    stack = [(a, b, 0)]
    while stack:
        lo, hi, depth = stack.pop()
        pts, ders = _project_with_derivative(camera, control, np.r_[lo, hi, lo + _CHECK * (hi - lo)])
        h = (hi - lo) / 3
        cubic = np.stack([pts[0], pts[0] + h * ders[0], pts[1] - h * ders[1], pts[1]])
        truth = pts[2:]
        err = np.linalg.norm(bernstein(_CHECK) @ cubic - truth, axis=1).max()
        if err <= tolerance or depth >= _MAX_DEPTH:
            pieces.append(cubic)
            breaks.append(hi)
        else:
            mid = 0.5 * (lo + hi)
            stack.append((mid, hi, depth + 1))  # pushed first so the first half is drawn first
            stack.append((lo, mid, depth + 1))
    return (np.array(pieces), np.array(breaks)) if return_breaks else np.array(pieces)


def visibility_runs(controls: np.ndarray, intervals: list[tuple[int, float, float]], is_hidden,
                    samples: int = 48, refine: int = 8) -> dict[int, list[tuple[float, float, bool]]]:
    """Split parameter intervals of curves into ``(start, end, hidden)`` runs.

    Args:
        controls: ``(N, 4, 3)`` curves.
        intervals: ``(curve index, a, b)`` triples.
        is_hidden: world points ``(P, 3)`` → bool ``(P,)``; called once for the samples of all intervals and
            once per bisection step for all state changes together.
    Returns:
        Runs per curve index, in parameter order.
    """
    if not intervals:
        return {}
    idx = np.array([i for i, _, _ in intervals])
    a = np.array([x for _, x, _ in intervals])
    b = np.array([x for _, _, x in intervals])
    s = np.linspace(0, 1, samples)
    t = a[:, None] + (b - a)[:, None] * s  # (I, S)
    B = bernstein(t)  # (I, S, 4)
    pts = np.einsum("isk,ikd->isd", B, controls[idx])
    state = is_hidden(pts.reshape(-1, 3)).reshape(len(idx), samples)
    ci, cj = np.nonzero(state[:, 1:] != state[:, :-1])  # changes between sample j and j+1 of interval i
    lo, hi = t[ci, cj], t[ci, cj + 1]
    left = state[ci, cj]
    ctrl = controls[idx[ci]]
    for _ in range(refine if len(ci) else 0):
        mid = 0.5 * (lo + hi)
        p = np.einsum("ik,ikd->id", bernstein(mid), ctrl)
        same = is_hidden(p) == left
        lo, hi = np.where(same, mid, lo), np.where(same, hi, mid)
    cut = 0.5 * (lo + hi)
    runs: dict[int, list[tuple[float, float, bool]]] = {}
    for k in range(len(idx)):
        mine = ci == k
        cuts = np.r_[a[k], cut[mine], b[k]]
        states = np.r_[state[k, 0], ~left[mine]]  # after each change the state flips
        runs.setdefault(int(idx[k]), []).extend(
            (float(cuts[m]), float(cuts[m + 1]), bool(states[m])) for m in range(len(cuts) - 1) if cuts[m + 1] > cuts[m])
    return runs
