"""From an evidence volume to 3D polylines: ridge points (non-maximum suppression), then linking.

Ridge points. A feature line is a height ridge of the (smoothed) evidence: across the line the evidence
peaks, along it it stays high. With the Hessian's eigenvalues ``λ0 ≤ λ1 ≤ λ2`` and eigenvectors
``e0, e1, e2``, a voxel holds a ridge point when ``λ1 < 0`` (the evidence falls off in the two directions
across the line) and one Newton step in the plane ``(e0, e1)`` — ``δ = −Σ (g·e_i / λ_i) e_i`` — stays inside
the voxel. The step gives the ridge's position to a fraction of a voxel, ``e2`` its direction.

Linking. Polylines are traced through the ridge points like streamlines (:func:`trace_ridges`), strongest
first, so a trace stops where lines meet at an angle and the next one starts there. Traces are then joined
across small gaps when their ends face each other, and split at sharp corners.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from ..volume.carve import VoxelGrid


@dataclass
class RidgePoints:
    """Sub-voxel ridge points: ``points (P, 3)`` world, unit ``tangents (P, 3)``, ``strength (P,)``."""

    points: np.ndarray
    tangents: np.ndarray
    strength: np.ndarray


def ridge_points(score: np.ndarray, grid: VoxelGrid, threshold: float, smooth: float = 1.0) -> RidgePoints:
    """Height-ridge points of ``score`` above ``threshold`` (after Gaussian smoothing of ``smooth`` voxels)."""
    S = ndimage.gaussian_filter(score.astype(np.float32), smooth) if smooth > 0 else score.astype(np.float32)
    inner = np.zeros(S.shape, bool)
    inner[1:-1, 1:-1, 1:-1] = True
    ijk = np.argwhere((S > threshold) & inner)
    if len(ijk) == 0:
        return RidgePoints(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0))
    i, j, k = ijk.T

    def at(di: int, dj: int, dk: int) -> np.ndarray:
        return S[i + di, j + dj, k + dk]

    c = at(0, 0, 0)
    g = np.stack([(at(1, 0, 0) - at(-1, 0, 0)) / 2, (at(0, 1, 0) - at(0, -1, 0)) / 2,
                  (at(0, 0, 1) - at(0, 0, -1)) / 2], axis=1)
    H = np.empty((len(ijk), 3, 3), np.float32)
    H[:, 0, 0] = at(1, 0, 0) - 2 * c + at(-1, 0, 0)
    H[:, 1, 1] = at(0, 1, 0) - 2 * c + at(0, -1, 0)
    H[:, 2, 2] = at(0, 0, 1) - 2 * c + at(0, 0, -1)
    H[:, 0, 1] = H[:, 1, 0] = (at(1, 1, 0) - at(1, -1, 0) - at(-1, 1, 0) + at(-1, -1, 0)) / 4
    H[:, 0, 2] = H[:, 2, 0] = (at(1, 0, 1) - at(1, 0, -1) - at(-1, 0, 1) + at(-1, 0, -1)) / 4
    H[:, 1, 2] = H[:, 2, 1] = (at(0, 1, 1) - at(0, 1, -1) - at(0, -1, 1) + at(0, -1, -1)) / 4
    lam, vec = np.linalg.eigh(H)  # ascending
    ridge = lam[:, 1] < -1e-4
    e0, e1, e2 = vec[:, :, 0], vec[:, :, 1], vec[:, :, 2]
    l0 = np.where(ridge, lam[:, 0], -1.0)
    l1 = np.where(ridge, lam[:, 1], -1.0)
    g0 = (g * e0).sum(1)
    g1 = (g * e1).sum(1)
    delta = -(g0 / l0)[:, None] * e0 - (g1 / l1)[:, None] * e1
    keep = ridge & (np.abs(delta).max(axis=1) <= 0.5)
    strength = c + 0.5 * (g * delta).sum(1)
    return RidgePoints(grid.centres(ijk[keep] + delta[keep]), grid.to_world(e2[keep].astype(np.float64)),
                       strength[keep].astype(np.float64))


def trace_ridges(ridges: RidgePoints, voxel: float, step_radius: float = 2.0, gap: float = 5.0,
                 max_angle_deg: float = 35.0, absorb: float = 1.0) -> list[np.ndarray]:
    """Trace polylines through ridge points like streamlines, strongest points first.

    From an unvisited seed the trace steps to the best ridge point ahead (within ``step_radius`` voxels,
    within ``max_angle_deg`` of the current direction, with a similar tangent; farther ahead, up to ``gap``
    voxels, in a cone half as wide, when nothing is near), then does the same backwards from the seed. Points
    within ``absorb`` voxels of the path are marked visited: the parallel duplicates a ridge leaves in
    neighbouring voxels join the trace instead of starting their own.
    """
    P, T, S = ridges.points, ridges.tangents, ridges.strength
    n = len(P)
    if n < 2:
        return []
    visited = np.zeros(n, bool)
    cos_max = np.cos(np.radians(max_angle_deg))
    cos_far = np.cos(np.radians(0.5 * max_angle_deg))
    bonus = 0.5 * voxel * S / max(S.max(), 1e-12)  # stronger points are preferred, by up to half a voxel
    near, far = step_radius * voxel, gap * voxel
    # Every point's neighbours, once (a KD query per step was most of the time): a step looks as far as
    # ``gap`` and absorbs within ``absorb`` of a segment at most ``gap`` long, so ``gap + absorb`` holds both.
    pairs = cKDTree(P).query_pairs(far + absorb * voxel, output_type="ndarray")
    ends = np.concatenate([pairs, pairs[:, ::-1]]) if len(pairs) else np.zeros((0, 2), int)
    ends = ends[np.argsort(ends[:, 0], kind="stable")]
    first = np.searchsorted(ends[:, 0], np.arange(n + 1))
    neighbours = ends[:, 1]

    def around(k: int) -> np.ndarray:
        return neighbours[first[k]:first[k + 1]]

    def walk(start: int, direction: np.ndarray) -> list[int]:
        path, cur, d = [], start, direction
        while True:
            best = -1
            idx = around(cur)
            idx = idx[~visited[idx]]
            if len(idx):
                v = P[idx] - P[cur]
                dist = np.sqrt(np.einsum("ij,ij->i", v, v))
                ok = (dist > 0.3 * voxel) & (np.abs(T[idx] @ d) >= cos_max)
                cos_step = np.where(ok, (v @ d) / np.maximum(dist, 1e-12), -1.0)
                for reach, cone in ((near, cos_max), (far, cos_far)):  # near first; farther, a narrower cone
                    fit = ok & (cos_step >= cone) & (dist <= reach)
                    if fit.any():
                        cost = np.where(fit, dist * (2.0 - cos_step) - bonus[idx], np.inf)
                        best = int(idx[np.argmin(cost)])
                        break
            if best < 0:
                return path
            step = P[best] - P[cur]
            length = float(np.sqrt(step @ step))
            # absorb the duplicates around the segment just walked
            idx = around(cur)
            w = P[idx] - (P[cur] + 0.5 * step)
            visited[idx[np.einsum("ij,ij->i", w, w) <= (absorb * voxel + 0.5 * length) ** 2]] = True
            visited[best] = True
            t = T[best] if T[best] @ d >= 0 else -T[best]
            d = t + step / max(length, 1e-12)  # follow the ridge, steadied by the step taken
            d /= max(float(np.sqrt(d @ d)), 1e-12)
            path.append(best)
            cur = best

    out = []
    for seed in np.argsort(-S):
        if visited[seed]:
            continue
        idx = around(seed)
        w = P[idx] - P[seed]
        visited[idx[np.einsum("ij,ij->i", w, w) <= (absorb * voxel) ** 2]] = True
        visited[seed] = True
        ahead = walk(seed, T[seed])
        behind = walk(seed, -T[seed])
        chain = behind[::-1] + [seed] + ahead
        if len(chain) >= 2:
            out.append(P[chain])
    return out


def _bridge(polys: list[np.ndarray], max_gap: float, max_angle_deg: float, touch: float = 1e-9
            ) -> list[np.ndarray]:
    """Join open polylines whose ends face each other across a gap of at most ``max_gap``, closest first.

    Ends closer than ``touch`` only need to continue each other (their gap has no direction to check).
    Each end joins at most once; joining the two ends of one chain closes it into a loop.
    """
    if len(polys) < 1:
        return polys
    cos_max = np.cos(np.radians(max_angle_deg))
    pos, out_dir = np.zeros((2 * len(polys), 3)), np.zeros((2 * len(polys), 3))
    usable = np.zeros(2 * len(polys), bool)
    for k, p in enumerate(polys):
        if len(p) < 3 or np.linalg.norm(p[0] - p[-1]) <= touch:
            continue
        m = min(len(p) - 1, 4)
        for e, q, inner in ((2 * k, p[0], p[m]), (2 * k + 1, p[-1], p[-1 - m])):
            d = q - inner
            pos[e], out_dir[e], usable[e] = q, d / max(np.linalg.norm(d), 1e-12), True
    ids = np.flatnonzero(usable)
    if len(ids) < 2:
        return polys
    pairs = cKDTree(pos[ids]).query_pairs(max_gap, output_type="ndarray")
    a, b = ids[pairs[:, 0]], ids[pairs[:, 1]]
    gap = pos[b] - pos[a]
    dist = np.linalg.norm(gap, axis=1)
    safe = np.maximum(dist, 1e-9)
    facing = (dist <= touch) | (((gap * out_dir[a]).sum(1) / safe >= cos_max) & ((-gap * out_dir[b]).sum(1) / safe >= cos_max))
    ok = facing & (-(out_dir[a] * out_dir[b]).sum(1) >= cos_max)
    a, b, dist = a[ok], b[ok], dist[ok]
    partner = np.full(2 * len(polys), -1)
    for i in np.argsort(dist, kind="stable"):
        ea, eb = int(a[i]), int(b[i])
        if ea // 2 == eb // 2 or partner[ea] >= 0 or partner[eb] >= 0:
            continue
        partner[ea], partner[eb] = eb, ea
    # walk each group of joined polylines from a free end (or anywhere, for a loop)
    done = np.zeros(len(polys), bool)
    result = []
    starts = [k for k in range(len(polys)) if partner[2 * k] < 0 or partner[2 * k + 1] < 0]
    for k0 in starts + list(range(len(polys))):
        if done[k0]:
            continue
        k, enter = k0, (2 * k0 if partner[2 * k0] < 0 else 2 * k0 + 1)
        if partner[2 * k0] >= 0 and partner[2 * k0 + 1] >= 0:
            enter = 2 * k0  # a loop: start anywhere
        pieces = []
        while True:
            done[k] = True
            p = polys[k] if enter == 2 * k else polys[k][::-1]
            pieces.append(p)
            leave = enter ^ 1
            nxt = partner[leave]
            if nxt < 0 or done[nxt // 2]:
                if nxt >= 0:  # closed a loop
                    pieces.append(pieces[0][:1])
                break
            k, enter = nxt // 2, nxt
        result.append(np.vstack(pieces))
    return result


def split_at_corners(poly: np.ndarray, angle_deg: float, window: float) -> list[np.ndarray]:
    """Split a polyline where its direction turns by more than ``angle_deg`` within ``window`` (arc length).

    The turn at each vertex is measured between the chords to the points ``window`` before and after it;
    a corner is the vertex of largest turn in a run of vertices above the threshold.
    """
    if len(poly) < 5:
        return [poly]
    arc = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(poly, axis=0), axis=1))]
    before = np.searchsorted(arc, arc - window, side="left")
    after = np.minimum(np.searchsorted(arc, arc + window, side="right") - 1, len(poly) - 1)
    a = poly - poly[before]
    b = poly[after] - poly
    na, nb = np.linalg.norm(a, axis=1), np.linalg.norm(b, axis=1)
    ok = (na > 0.5 * window) & (nb > 0.5 * window)
    cos = np.where(ok, (a * b).sum(1) / np.maximum(na * nb, 1e-12), 1.0)
    turn = np.degrees(np.arccos(np.clip(cos, -1, 1)))
    hot = turn > angle_deg
    cuts = []
    k = 0
    while k < len(poly):
        if hot[k]:
            e = k
            while e + 1 < len(poly) and hot[e + 1]:
                e += 1
            cuts.append(k + int(np.argmax(turn[k:e + 1])))
            k = e + 1
        else:
            k += 1
    pieces, s = [], 0
    for c in cuts:
        if c - s >= 1:
            pieces.append(poly[s:c + 1])
            s = c
    pieces.append(poly[s:])
    return [p for p in pieces if len(p) >= 2]


def link_ridges(ridges: RidgePoints, voxel: float, gap: float = 6.0, max_angle_deg: float = 35.0,
                corner_deg: float = 40.0) -> list[np.ndarray]:
    """3D polylines through the ridge points (distances in voxels): traced, gaps bridged, split at corners."""
    polys = trace_ridges(ridges, voxel, max_angle_deg=max_angle_deg)
    polys = _bridge(polys, gap * voxel, max_angle_deg)
    out = []
    for p in polys:
        out.extend(split_at_corners(p, corner_deg, 3.0 * voxel))
    return out
