"""Tubes: a handle — a curved thin part drawn as a person draws it, its two sides.

A thin part bent in a plane (a mug's or a teapot's handle) has two outlines that every view sees about where
they are: its outer and inner side in that plane. Seen square to the plane they are its silhouette; seen at
a slant they come nearer each other as the tube's own outline does. The evidence's ridges along such a part
are many and short — each view's two rims vote where that view saw them, so the choice picked 13 of the
teapot's 27 cubics along its handle, a tangle — while these two curves, each in one piece, draw it whole
in every view. They are offered as candidates; the choice takes them when they explain the views' lines.

The tube's axis is the skeleton of the hull's thin part (what an opening by a ball of the thin parts' radius
takes away), its radius the hull's depth along it; a straight part (a leg, a pole) has no plane and keeps
its one line along the axis (:func:`.evidence.object_lines`), and a cable a few voxels thick (the tripod's
loop) is drawn by that line too.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.sparse import csgraph, coo_matrix
from scipy.spatial import cKDTree

from ...arrays import along_polyline
from ..volume.carve import VoxelGrid, coarsened

#: Sides offered per tube: the outer and the inner one in its plane.
SIDES = 2
#: A tube stands off the thick part: the median of its axis at least this many thin radii from it.
STAND_OFF = 2.0
#: A tube at least this thick (voxels of the full grid): a thinner one's sides are a pixel or two apart.
MIN_RADIUS = 2.0
#: Voxels along the hull's longest side of the grid the thin parts are found on.
VOXELS = 96
#: Parts thinner than this share of the hull's box diagonal are thin (as :data:`doodle.fit.config` ``thin``).
THIN = 0.06
#: A tube's axis at least this many times its radius long...
MIN_LENGTH = 6.0
#: ...bent: its farthest point from the chord between its ends at least this many radii away...
MIN_BEND = 2.0
#: ...and planar: the axis at most this many radii out of its plane anywhere. A hull carved from automatic
#: masks wanders more (the carpet mug's handle: 1.06, 0.35 in the root mean square), and there its two sides
#: drew less of the handle than the pieces along it (F 0.935 → 0.920, the teapot's 0.922 → 0.900): it stays
#: pieces.
MAX_OUT_OF_PLANE = 0.75


@dataclass
class Tube:
    """A curved, planar thin part: its axis ``(A, 3)`` and radius (world units), and its two sides."""

    axis: np.ndarray
    radius: float
    sides: list[np.ndarray]
    """``(S, 3)`` polylines: its two sides in its plane (see the module doc)."""


def find_tubes(grid: VoxelGrid, occupied: np.ndarray) -> list[Tube]:
    """The curved, planar thin parts of the hull ``occupied`` on ``grid`` (see the module doc)."""
    coarse, occ = coarsened(grid, occupied, VOXELS)
    if occ.sum() < 64:
        return []
    ijk = np.argwhere(occ)
    diag = float(np.linalg.norm(ijk.max(0) - ijk.min(0) + 1))
    r = max(1.5, 0.5 * THIN * diag)
    depth = ndimage.distance_transform_edt(np.pad(occ, 1))[1:-1, 1:-1, 1:-1]
    # the opening by a ball of radius r, by distance transforms: what a ball that fits inside can reach
    core = depth >= r
    opened = ndimage.distance_transform_edt(~core) <= r if core.any() else np.zeros_like(occ)
    thin = occ & ~opened
    labels, _ = ndimage.label(thin, np.ones((3, 3, 3)))
    away = None
    tubes = []
    for k, box in enumerate(ndimage.find_objects(labels), start=1):
        if box is None:
            continue
        part = labels[box] == k
        if part.sum() < MIN_LENGTH * r * r:  # a speck, or a fragment of a part a few pixels across
            continue
        axis = _axis(part)
        if axis is None:
            continue
        axis += [b.start for b in box]
        if away is None:
            away = ndimage.distance_transform_edt(~opened) if opened.any() else np.full(occ.shape, np.inf)
        if np.median(away[tuple(np.rint(axis).astype(int).T)]) < STAND_OFF * r:
            continue  # a sliver the opening took off an edge of the body (a cylinder's rim), not a part
        fine_radius = _fine_radius(grid, occupied, coarse.centres(axis), 2 * r * coarse.voxel,
                                   max(1, int(round(coarse.voxel / grid.voxel))))
        if fine_radius < MIN_RADIUS:
            continue
        radius = fine_radius * grid.voxel / coarse.voxel
        sides = _sides(axis, radius, opened)
        if sides is not None:
            tubes.append(Tube(coarse.centres(axis), radius * coarse.voxel, [coarse.centres(p) for p in sides]))
    return tubes


def in_tubes(polylines: list[np.ndarray], tubes: list[Tube], reach: float = 1.5,
             share: float = 0.6) -> np.ndarray:
    """``(N,)`` bool: which polylines lie mostly (``share`` of their points) within ``reach`` radii of a tube's
    axis: the evidence's pieces along a handle that its two sides draw."""
    inside = np.zeros(len(polylines), bool)
    for tube in tubes:
        tree = cKDTree(tube.axis)
        for i, p in enumerate(polylines):
            d, _ = tree.query(p)
            inside[i] |= (d <= reach * tube.radius).mean() >= share
    return inside


def _fine_radius(grid: VoxelGrid, occupied: np.ndarray, axis: np.ndarray, margin: float, reach: int) -> float:
    """The tube's radius on the full grid (voxels; the coarse one's are 2 px at 256): the median along the
    ``axis`` ``(A, 3)`` (world) of the hull's depth at the deepest voxel within ``reach`` voxels (a coarse one)
    of each point (the coarse skeleton is not centred on the full grid), on a crop ``margin`` round the axis."""
    ijk = grid.coordinates(axis)
    pad = int(np.ceil(margin / grid.voxel)) + 2
    lo = np.maximum(np.floor(ijk.min(0)).astype(int) - pad, 0)
    hi = np.minimum(np.ceil(ijk.max(0)).astype(int) + pad + 1, occupied.shape)
    crop = occupied[tuple(slice(a, b) for a, b in zip(lo, hi))]
    depth = ndimage.distance_transform_edt(np.pad(crop, 1))[1:-1, 1:-1, 1:-1]
    at = np.rint(ijk).astype(int) - lo
    deepest = [depth[tuple(slice(max(c - reach, 0), c + reach + 1) for c in p)].max(initial=0.0) for p in at]
    return float(np.median(deepest)) - 0.5  # a voxel centre's distance is half a voxel more


def _axis(part: np.ndarray) -> np.ndarray | None:
    """``(P, 3)`` voxel coordinates along the longest path of ``part``'s skeleton, or ``None``."""
    from skimage.morphology import skeletonize

    skel = skeletonize(part)
    pts = np.argwhere(skel)
    if len(pts) < 4:
        return None
    index = -np.ones(part.shape, int)
    index[tuple(pts.T)] = np.arange(len(pts))
    rows, cols, weights = [], [], []
    for d in np.argwhere(np.ones((3, 3, 3))) - 1:
        if not d.any():
            continue
        q = pts + d
        ok = ((q >= 0) & (q < part.shape)).all(1)
        j = np.full(len(pts), -1)
        j[ok] = index[tuple(q[ok].T)]
        hit = j >= 0
        rows.append(np.flatnonzero(hit))
        cols.append(j[hit])
        weights.append(np.full(hit.sum(), float(np.linalg.norm(d))))
    g = coo_matrix((np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))), shape=(len(pts),) * 2)
    # the longest shortest path: from any point to its farthest, then from there to its farthest
    d0 = csgraph.dijkstra(g, indices=0)
    a = int(np.argmax(np.where(np.isfinite(d0), d0, -1)))
    da, pred = csgraph.dijkstra(g, indices=a, return_predecessors=True)
    b = int(np.argmax(np.where(np.isfinite(da), da, -1)))
    path = [b]
    while path[-1] != a and pred[path[-1]] >= 0:
        path.append(int(pred[path[-1]]))
    return pts[path].astype(np.float64) if len(path) >= 4 else None


def _sides(axis: np.ndarray, radius: float, thick: np.ndarray) -> list[np.ndarray] | None:
    """The axis's two sides in its plane, ``radius`` out (voxel units), carried on past its ends to where they
    meet the ``thick`` part (a handle's sides run into the body); ``None`` when it is short, straight or not
    planar."""
    length = float(np.linalg.norm(np.diff(axis, axis=0), axis=1).sum())
    if length < MIN_LENGTH * radius:
        return None
    a = ndimage.uniform_filter1d(along_polyline(axis, max(8, int(length)), closed=False), 5, axis=0, mode="nearest")
    chord = _unit(a[-1] - a[0])
    rel = a - a[0]
    bend = float(np.linalg.norm(rel - np.outer(rel @ chord, chord), axis=1).max())
    if bend < MIN_BEND * radius:
        return None
    centred = a - a.mean(0)
    normal = np.linalg.svd(centred, full_matrices=False)[2][2]
    if float(np.abs(centred @ normal).max()) > MAX_OUT_OF_PLANE * radius:
        return None
    # on past both ends, along the end's direction, as far as the thin part's radius reaches into the body
    steps = np.arange(0.5, EXTEND * radius + 0.25, 0.5)
    head = a[0] - np.outer(steps[::-1], _unit(a[min(3, len(a) - 1)] - a[0]))
    tail = a[-1] + np.outer(steps, _unit(a[-1] - a[max(len(a) - 4, 0)]))
    a = np.concatenate([head, a, tail])
    side = np.cross(normal, np.gradient(a, axis=0))
    side /= np.maximum(np.linalg.norm(side, axis=1, keepdims=True), 1e-9)
    out = []
    for n in (side, -side):
        s = a + radius * n
        idx = np.rint(s).astype(int)
        ok = ((idx >= 0) & (idx < thick.shape)).all(1)
        inside = np.zeros(len(s), bool)
        inside[ok] = thick[tuple(idx[ok].T)]
        run = _longest_run(~inside)
        if run is None or run[1] - run[0] < 4:
            return None
        out.append(s[run[0]:run[1]])
    return out


#: How far past its ends (radii) a tube's sides are carried toward the body they join.
EXTEND = 3.0


def _unit(v: np.ndarray) -> np.ndarray:
    return v / max(float(np.linalg.norm(v)), 1e-9)


def _longest_run(flags: np.ndarray) -> tuple[int, int] | None:
    """``(start, stop)`` of the longest run of True in ``flags``, or ``None``."""
    best, start = None, None
    for i, f in enumerate(np.r_[flags, False]):
        if f and start is None:
            start = i
        elif not f and start is not None:
            if best is None or i - start > best[1] - best[0]:
                best = (start, i)
            start = None
    return best
