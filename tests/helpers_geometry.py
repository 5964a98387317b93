"""Geometry helpers for quality tests: distances between sampled curves and ground-truth edge segments, and the
axes of a sample scene's thin parts."""

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


def thin_axes(primitives, max_radius: float = 0.05) -> list[tuple[str, np.ndarray]]:
    """``(kind, segments (K, 2, 3))`` of every thin part: the axis of a cylinder (a leg, a pole) and the centre
    circle of a torus (a cable's loop) whose tube radius is at most ``max_radius``."""
    out = []
    for p in primitives:
        if p.kind == "cylinder" and p.radius <= max_radius:
            ends = np.array([[0.0, 0, 0], [0, 0, p.height]])
        elif p.kind == "torus" and p.minor <= max_radius:
            a = np.linspace(0, 2 * np.pi, 73)
            ends = np.stack([p.major * np.cos(a), p.major * np.sin(a), 0 * a], -1)
        else:
            continue
        world = ends @ p.R.T + p.center
        out.append((p.kind, np.stack([world[:-1], world[1:]], 1)))
    return out


def hole_points(primitives, margin: float = 0.05) -> np.ndarray:
    """Points ``(P, 3)`` filling the holes of the tori among ``primitives`` (each centre disc, short of the tube
    by a tube radius) that lie more than ``margin`` outside every other primitive: what no superquadric may
    cover (a mug's handle half inside its body leaves the outer half of its hole)."""
    out = []
    for ring in (p for p in primitives if p.kind == "torus"):
        r, a = np.meshgrid(np.linspace(0, ring.major - 2 * ring.minor, 12), np.linspace(0, 2 * np.pi, 36))
        pts = ring.center + np.stack([r * np.cos(a), r * np.sin(a), 0 * a], -1).reshape(-1, 3) @ ring.R.T
        for other in primitives:
            if other is not ring:
                pts = pts[~other.contains(pts, margin)]
        out.append(pts)
    return np.concatenate(out) if out else np.zeros((0, 3))


def inside_superquadrics(sq, points: np.ndarray) -> np.ndarray:
    """``(P,)`` bool: which points ``(P, 3)`` lie inside the union of a :class:`SuperquadricSet`."""
    from doodle.strokes.superquadric import union_log_inside_outside

    return union_log_inside_outside(points, sq.scale, sq.shape, sq.rotation, sq.translation) < 0


def ink_on_print(strokes, primitives, cameras, tau: float = 2.0) -> float:
    """Share of a sketch's ink, over ``cameras``, that lies on the primitives' print and on no structure: within
    ``tau`` px of a boundary of the print's ink and farther than ``tau`` from the silhouette and from every
    boundary between primitives or faces (what a viewer sees as drawn texture)."""
    from scipy import ndimage

    from doodle.evaluate import _inked
    from doodle.exporters import DrawOptions, draw_many, to_svg
    from doodle.samples.raycast import shade_rays

    on, total = 0, 0
    for cam, drawing in zip(cameras, draw_many(strokes, cameras, DrawOptions(tolerance=0.25))):
        ink = _inked(to_svg(drawing, 0.25), (cam.width, cam.height))
        o, d = cam.rays()
        _, face, dark = shade_rays(primitives, o.reshape(-1, 3), d.reshape(-1, 3))
        face, dark = face.reshape(cam.height, cam.width), dark.reshape(cam.height, cam.width)
        edges = lambda a: (ndimage.maximum_filter(a, 3) != a) | (ndimage.minimum_filter(a, 3) != a)  # noqa: E731
        structure = ndimage.distance_transform_edt(~edges(face)) <= tau
        paint = ndimage.distance_transform_edt(~edges(dark.astype(int))) <= tau
        on += int((ink & paint & ~structure).sum())
        total += int(ink.sum())
    return on / max(total, 1)
