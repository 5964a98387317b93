"""Fit polylines (2D or 3D) with as few cubic Béziers as a tolerance allows (Schneider, Graphics Gems 1990).

Used for superquadric silhouettes, whose contours come out of marching squares as dense polylines, and for
3D feature lines linked from edge evidence. The
recursion of Schneider's algorithm runs breadth first and vectorised over every segment of every polyline
given at once: one round fits all open segments (least squares with fixed end points and end tangent
directions), improves the parameters of nearly fitting ones by Newton steps, and splits the rest — at their
worst point when nearly fitting, else into several equal pieces. A batch of silhouettes takes a handful of
rounds of array operations instead of thousands of tiny per-segment calls.
"""

from __future__ import annotations

import numpy as np

from .bezier import bernstein, bezier_derivative, bezier_points

_NEWTON_STEPS = 4
_MAX_ROUNDS = 24


def _unit_rows(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=1, keepdims=True)
    return np.where(n > 1e-12, v / np.where(n > 1e-12, n, 1.0), 0.0)


def _quadratic_tangents(prev: np.ndarray, mid: np.ndarray, nxt: np.ndarray) -> np.ndarray:
    """Unit tangents ``(P, D)`` at ``mid`` of the quadratics through ``prev, mid, nxt`` (chord-length spacing).

    Second-order accurate, where the secant leaves an error floor the fit could only meet by splitting.
    """
    h1 = np.linalg.norm(mid - prev, axis=1, keepdims=True)
    h2 = np.linalg.norm(nxt - mid, axis=1, keepdims=True)
    ok = (h1 > 1e-12) & (h2 > 1e-12)
    h1, h2 = np.where(ok, h1, 1.0), np.where(ok, h2, 1.0)
    d = -h2 / (h1 * (h1 + h2)) * prev + (h2 - h1) / (h1 * h2) * mid + h1 / (h2 * (h1 + h2)) * nxt
    return _unit_rows(np.where(ok, d, nxt - prev))


def _end_tangent(p0: np.ndarray, p1: np.ndarray, p2: np.ndarray) -> np.ndarray:
    """Unit tangent at ``p0`` pointing towards ``p1`` of the quadratic through ``p0, p1, p2``."""
    h1, h2 = np.linalg.norm(p1 - p0), np.linalg.norm(p2 - p1)
    if h1 < 1e-12 or h2 < 1e-12:
        return _unit_rows((p1 - p0)[None])[0]
    d = -(2 * h1 + h2) / (h1 * (h1 + h2)) * p0 + (h1 + h2) / (h1 * h2) * p1 - h1 / (h2 * (h1 + h2)) * p2
    return _unit_rows(d[None])[0]


def _prepare(points: np.ndarray, closed: bool, tangents: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Drop repeated points, close loops, and give every vertex a unit tangent in the direction of travel."""
    pts = np.asarray(points, dtype=np.float64)
    keep = np.r_[True, np.linalg.norm(np.diff(pts, axis=0), axis=1) > 1e-9]
    pts = pts[keep]
    tan = None if tangents is None else np.asarray(tangents, dtype=np.float64)[keep]
    if closed and len(pts) > 2 and np.linalg.norm(pts[0] - pts[-1]) > 1e-9:
        pts = np.vstack([pts, pts[:1]])
        tan = None if tan is None else np.vstack([tan, tan[:1]])
    closed = closed and len(pts) > 3
    if len(pts) < 3:
        t = _unit_rows((pts[-1] - pts[0])[None]) if len(pts) == 2 else np.zeros((1, pts.shape[1]))
        return pts, np.repeat(t, len(pts), axis=0)
    if closed:  # the seam is an ordinary interior vertex of the loop
        prev, nxt = np.vstack([pts[-2:-1], pts[:-2]]), pts[1:]
        est = _quadratic_tangents(prev, pts[:-1], nxt)
        est = np.vstack([est, est[:1]])
    else:
        est = np.empty_like(pts)
        est[1:-1] = _quadratic_tangents(pts[:-2], pts[1:-1], pts[2:])
        est[0] = _end_tangent(pts[0], pts[1], pts[2])
        est[-1] = -_end_tangent(pts[-1], pts[-2], pts[-3])
    if tan is None:
        return pts, est
    # Exact tangents (e.g. from the surface normal) only need their direction of travel fixed.
    tan = _unit_rows(tan)
    sign = np.where(np.einsum("ij,ij->i", tan, est) < 0, -1.0, 1.0)
    tan = tan * sign[:, None]
    bad = np.linalg.norm(tan, axis=1) < 0.5
    tan[bad] = est[bad]
    return pts, tan


def _segment_sum(values: np.ndarray, seg: np.ndarray, n: int) -> np.ndarray:
    return np.bincount(seg, weights=values, minlength=n)


def _segment_max(values: np.ndarray, seg: np.ndarray, n: int) -> np.ndarray:
    out = np.full(n, -1.0)
    np.maximum.at(out, seg, values)
    return out


def _fit_segments(X, seg, u, P0, P3, T0, T1, arc):
    """Least-squares cubics ``(S, 4, D)`` with fixed end points and end tangent directions, all segments.

    ``arc`` ``(S,)``: the polyline length of each segment; a handle longer than that (near-parallel end
    tangents make the normal equations ill-conditioned) would loop far off between the points."""
    n = len(P0)
    b0, b1, b2, b3 = bernstein(u).T
    c00 = _segment_sum(b1 * b1, seg, n)
    c01 = _segment_sum(b1 * b2, seg, n) * np.einsum("ij,ij->i", T0, T1)
    c11 = _segment_sum(b2 * b2, seg, n)
    tmp = X - (b0 + b1)[:, None] * P0[seg] - (b2 + b3)[:, None] * P3[seg]
    x0 = _segment_sum(b1 * np.einsum("ij,ij->i", tmp, T0[seg]), seg, n)
    x1 = _segment_sum(b2 * np.einsum("ij,ij->i", tmp, T1[seg]), seg, n)
    det = c00 * c11 - c01 * c01
    ok = np.abs(det) > 1e-12
    det = np.where(ok, det, 1.0)
    a0 = np.where(ok, (x0 * c11 - x1 * c01) / det, -1.0)
    a1 = np.where(ok, (c00 * x1 - c01 * x0) / det, -1.0)
    chord = np.linalg.norm(P3 - P0, axis=1)
    degenerate = (a0 < 1e-6 * chord) | (a1 < 1e-6 * chord) | (a0 > arc) | (a1 > arc)  # Wu/Barsky heuristic
    a0 = np.where(degenerate, chord / 3, a0)
    a1 = np.where(degenerate, chord / 3, a1)
    return np.stack([P0, P0 + a0[:, None] * T0, P3 + a1[:, None] * T1, P3], axis=1)


def _evaluate(ctrl: np.ndarray, seg: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Each point's segment at its parameter, ``(P, D)``."""
    return bezier_points(ctrl[seg], u[:, None])[:, 0]


def _newton(ctrl: np.ndarray, X: np.ndarray, seg: np.ndarray, u: np.ndarray, first: np.ndarray) -> np.ndarray:
    """One Newton step of each parameter towards its point's closest curve point (kept ordered per segment)."""
    c = ctrl[seg]
    q = bezier_points(c, u[:, None])[:, 0]
    q1 = bezier_derivative(c, u[:, None])[:, 0]
    d1 = 3 * (c[:, 1:] - c[:, :-1])
    d2 = 2 * (d1[:, 1:] - d1[:, :-1])  # the second derivative is linear in u
    q2 = (1 - u)[:, None] * d2[:, 0] + u[:, None] * d2[:, 1]
    num = np.einsum("ij,ij->i", q - X, q1)
    den = np.einsum("ij,ij->i", q1, q1) + np.einsum("ij,ij->i", q - X, q2)
    ok = np.abs(den) > 1e-12
    out = np.clip(u - np.where(ok, num / np.where(ok, den, 1.0), 0.0), 0, 1)
    # Running maximum within each segment: offset every segment so one global accumulate does it. On a grid
    # of 2⁻³⁰ the offset is exact (for up to 2²¹ segments), so a segment's parameters do not depend on how
    # many segments precede it in the batch.
    out = np.round(out * 2.0**30) / 2.0**30
    out = np.maximum.accumulate(out + 2.0 * seg) - 2.0 * seg
    out[first] = 0.0
    return out


def _worst_interior(err: np.ndarray, seg: np.ndarray, idx: np.ndarray, first: np.ndarray,
                    counts: np.ndarray) -> np.ndarray:
    """Per segment, the vertex index of its worst-fitted interior point."""
    interior = err.copy()
    interior[first] = -1.0
    interior[first + counts - 1] = -1.0
    order = np.lexsort((-interior, seg))  # per segment, the worst interior point first
    return idx[order[first]]


def _split(s: np.ndarray, e: np.ndarray, owner: np.ndarray, ratio: np.ndarray, worst_at: np.ndarray,
           arc: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Split failing segments ``[s, e]``: at the worst point when the error is within 16× the tolerance
    (Schneider), else into ``k ≈ ratio^¼`` pieces of equal arc length (a cubic's error shrinks like the fourth
    power of its length), which takes two or three rounds where halving would take eight."""
    if len(s) == 0:
        return s, e, owner
    # a NaN or infinite error (degenerate input) must not become a count of 2⁶³ pieces
    ratio = np.nan_to_num(np.asarray(ratio, dtype=np.float64), nan=16.0, posinf=1e12, neginf=1.0)
    k = np.clip(np.ceil(ratio ** 0.25), 2, e - s).astype(int)
    halve = k == 2
    cut_seg = np.r_[np.flatnonzero(halve), np.repeat(np.flatnonzero(~halve), k[~halve] - 1)]
    frac = np.r_[np.zeros(halve.sum()), np.concatenate([np.arange(1, n) / n for n in k[~halve]] or [np.zeros(0)])]
    target = arc[s[cut_seg]] + frac * (arc[e[cut_seg]] - arc[s[cut_seg]])
    # arc restarts in each polyline, so search each segment's own stretch
    at = np.array([a + np.searchsorted(arc[a:b + 1], x) for a, b, x in zip(s[cut_seg], e[cut_seg], target)], int)
    at = np.where(np.arange(len(cut_seg)) < halve.sum(), worst_at[cut_seg], at)
    at = np.clip(at, s[cut_seg] + 1, e[cut_seg] - 1)
    # Boundaries of each segment in order, duplicates removed; consecutive ones become the new segments.
    b_seg = np.r_[np.arange(len(s)), cut_seg, np.arange(len(s))]
    b_at = np.r_[s, at, e]
    order = np.lexsort((b_at, b_seg))
    b_seg, b_at = b_seg[order], b_at[order]
    fresh = np.r_[True, (np.diff(b_seg) != 0) | (np.diff(b_at) != 0)]
    b_seg, b_at = b_seg[fresh], b_at[fresh]
    pair = b_seg[:-1] == b_seg[1:]
    return b_at[:-1][pair], b_at[1:][pair], owner[b_seg[:-1][pair]]


def fit_cubics_many(polylines: list[np.ndarray], tolerance: float, closed: list[bool] | None = None,
                    tangents: list[np.ndarray | None] | None = None, max_rounds: int = _MAX_ROUNDS) -> list[np.ndarray]:
    """Fit each polyline with consecutive cubics within ``tolerance`` of every vertex.

    Args:
        polylines: ``(P_i, D)`` arrays, ``P_i ≥ 1`` (any dimension ``D``, the same for all).
        tolerance: maximum distance in the points' units.
        closed: per polyline, whether the last point joins the first.
        tangents: per polyline, optional exact tangent directions ``(P_i, D)`` at the vertices (either sign;
            the direction of travel is taken from the points); estimated from the points where ``None``.
    Returns:
        Per polyline, ``(K_i, 4, D)`` control points of consecutive cubics, ``K_i ≥ 1``, joined with
        tangent continuity at every split.
    """
    closed = closed or [False] * len(polylines)
    tangents = tangents or [None] * len(polylines)
    prepared = [_prepare(p, c, t) for p, c, t in zip(polylines, closed, tangents)]
    if not prepared:
        return []
    sizes = np.array([len(p) for p, _ in prepared])
    starts = np.r_[0, np.cumsum(sizes)[:-1]]
    X = np.concatenate([p for p, _ in prepared])
    T = np.concatenate([t for _, t in prepared])
    # Cumulative chord length, from 0 in each polyline: a sum running over the whole array would round each
    # polyline's lengths by what precedes it, and a batch would fit a polyline differently from itself alone.
    arc = np.concatenate([np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))] for p, _ in prepared])

    s, e = starts.copy(), starts + sizes - 1  # open segments: vertex index ranges [s, e]
    owner = np.arange(len(prepared))
    done_s, done_owner, done_ctrl = [], [], []
    for round_ in range(max_rounds + 1):
        if len(s) == 0:
            break
        short = e - s <= 1  # no interior point: the cubic follows the end tangents over a third of the chord
        if short.any():
            ss, es = s[short], e[short]
            d = np.linalg.norm(X[es] - X[ss], axis=1, keepdims=True) / 3
            done_ctrl.append(np.stack([X[ss], X[ss] + d * T[ss], X[es] - d * T[es], X[es]], axis=1))
            done_s.append(ss), done_owner.append(owner[short])
            s, e, owner = s[~short], e[~short], owner[~short]
            if len(s) == 0:
                break
        counts = e - s + 1
        seg = np.repeat(np.arange(len(s)), counts)
        first = np.r_[0, np.cumsum(counts)[:-1]]
        idx = np.arange(len(seg)) - first[seg] + s[seg]
        Xs = X[idx]
        span = arc[e] - arc[s]
        u = (arc[idx] - arc[s][seg]) / np.where(span > 0, span, 1.0)[seg]
        P0, P3, T0, T1 = X[s], X[e], T[s], -T[e]
        ctrl = _fit_segments(Xs, seg, u, P0, P3, T0, T1, span)
        err = np.linalg.norm(_evaluate(ctrl, seg, u) - Xs, axis=1)
        worst = _segment_max(err, seg, len(s))
        near = (worst > tolerance) & (worst <= 16 * tolerance)  # close: improve the parameters first
        if near.any():
            for _ in range(_NEWTON_STEPS):
                pick = near[seg]
                u_new = np.where(pick, _newton(ctrl, Xs, seg, u, first), u)
                ctrl_new = _fit_segments(Xs, seg, u_new, P0, P3, T0, T1, span)
                err_new = np.linalg.norm(_evaluate(ctrl_new, seg, u_new) - Xs, axis=1)
                worst_new = _segment_max(err_new, seg, len(s))
                better = near & (worst_new < worst)
                ctrl[better], worst[better] = ctrl_new[better], worst_new[better]
                u, err = np.where(better[seg], u_new, u), np.where(better[seg], err_new, err)
                near &= better & (worst > tolerance)
                if not near.any():
                    break
        ok = (worst <= tolerance) | (round_ == max_rounds)
        done_ctrl.append(ctrl[ok]), done_s.append(s[ok]), done_owner.append(owner[ok])
        worst_at = _worst_interior(err, seg, idx, first, counts)
        s, e, owner = _split(s[~ok], e[~ok], owner[~ok], worst[~ok] / tolerance, worst_at[~ok], arc)

    ctrl = np.concatenate(done_ctrl)
    order = np.lexsort((np.concatenate(done_s), np.concatenate(done_owner)))
    owners = np.concatenate(done_owner)[order]
    return np.split(ctrl[order], np.flatnonzero(np.diff(owners)) + 1)


def fit_cubics(points: np.ndarray, tolerance: float, closed: bool = False,
               tangents: np.ndarray | None = None) -> np.ndarray:
    """Fit one polyline ``(P, D)`` with cubic Béziers ``(K, 4, D)`` within ``tolerance`` of every point.

    >>> pts = np.stack([np.linspace(0, 1, 20), np.linspace(0, 1, 20) ** 2], 1)
    >>> segs = fit_cubics(pts, 1e-2)
    >>> len(segs), bool(np.allclose(segs[0, 0], pts[0]) and np.allclose(segs[-1, -1], pts[-1]))
    (1, True)
    """
    return fit_cubics_many([points], tolerance, [closed], [tangents])[0]
