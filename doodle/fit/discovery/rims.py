"""Contour curves: where each training view's outline lies on the object, as view-dependent 3D curves.

A smooth surface has no fixed line where its outline is: the outline of a view is its contour generator,
the curve along which the view's rays graze the surface, and it slides over the surface as the view moves.
No view-independent curve draws it, and a superquadric draws it only where the part is one. But the
training views show it: every point of a mask's boundary is a ray that touches the object, at the point
where the visual hull touches it too (the hull is tangent to the object along each view's rim). So each
boundary pixel's ray, marched through the carved hull, meets it in a short chord around the contour point;
the chord's middle is the point, and the plane through the eye that holds the outline's image tangent is
the surface's tangent plane there, which gives the surface normal exactly.

Chained along the boundary and split where the depth jumps (where one part's outline passes behind
another's), the points make 3D polylines, fitted with cubics. Such a curve is the outline from every view
whose rays graze it — wherever the view ray is nearly perpendicular to its normal — and nowhere else, so
it is stored with its normal and a *contour gate*: the largest ``|cos|`` between normal and view ray at
which it is drawn (:class:`~doodle.strokes.model.CurveSet`). Views between the training views see the
contour curves of their neighbours, which lie within a fraction of a pixel of their own outline where the
surface is smooth.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from skimage import measure

from ...arrays import along_polyline, first_occupied, free_space
from ...cameras import Camera
from ...strokes.fitcurve import fit_cubics_many
from ..volume.carve import VoxelGrid

CONTOUR_GATES = (0.15, 0.3)
"""The contour gates each contour curve is offered with (the largest ``|cos|`` between its normal and the view
ray at which it is drawn: about 9° and 17° from grazing). Which one is chosen is left to the choice of
strokes, judged in the views other than the curve's own: a wide gate lets the views between training views
see their neighbours' contours where the training views are sparse or the surface curves tightly; a
narrow one keeps a curve off where its surface is flat enough that the outline slides away from it."""


@dataclass
class Rims:
    """Contour cubics ``controls (N, 4, 3)``, their normals ``(N, 2, 3)`` at start and end, and the training
    view each came from ``view (N,)``."""

    controls: np.ndarray
    normals: np.ndarray
    view: np.ndarray


def _boundary_rays(cam: Camera, mask: np.ndarray, spacing: float = 1.25):
    """Ordered boundary polylines of a mask: per contour, sub-pixel positions ``(K, 2)`` (x, y) about
    ``spacing`` px apart, the outward 2D normals ``(K, 2)`` and tangents ``(K, 2)``, and whether it is closed."""
    H, W = mask.shape
    padded = np.pad(mask.astype(np.float32), 1, mode="edge")  # no outline along the frame where it cuts the object
    out = []
    for c in measure.find_contours(padded, 0.5):
        if len(c) < 8:
            continue
        xy = c[:, ::-1] - 1.0 + 0.5  # (row, col) of the padded array → pixel coordinates (centres at +0.5)
        closed = np.linalg.norm(xy[0] - xy[-1]) < 1e-6
        if closed:
            xy = xy[:-1]
        xy = _resample(xy, closed, spacing)
        # tangents by central differences over a few points (the marching-squares steps are jagged)
        k = 2
        if closed:
            tan = np.roll(xy, -k, axis=0) - np.roll(xy, k, axis=0)
        else:
            idx = np.arange(len(xy))
            tan = xy[np.minimum(idx + k, len(xy) - 1)] - xy[np.maximum(idx - k, 0)]
        tan /= np.maximum(np.linalg.norm(tan, axis=1, keepdims=True), 1e-12)
        normal = np.stack([tan[:, 1], -tan[:, 0]], axis=1)
        # orient outwards: the mask is behind the normal
        probe = np.floor(xy - 1.5 * normal).astype(int)
        okp = (probe[:, 0] >= 0) & (probe[:, 1] >= 0) & (probe[:, 0] < W) & (probe[:, 1] < H)
        inside = np.zeros(len(xy), bool)
        inside[okp] = mask[probe[okp, 1], probe[okp, 0]]
        if inside.mean() < 0.5:
            normal = -normal
        out.append((xy, normal, tan, closed))
    return out


def _resample(xy: np.ndarray, closed: bool, spacing: float) -> np.ndarray:
    """Points ``(K, 2)`` about ``spacing`` apart along a polyline (marching squares gives about two a pixel)."""
    loop = np.vstack([xy, xy[:1]]) if closed else xy
    length = np.cumsum(np.linalg.norm(np.diff(loop, axis=0), axis=1))[-1]  # summed as along_polyline sums it
    return along_polyline(xy, max(int(length / spacing), 8), closed)


def _chords(cam: Camera, xy: np.ndarray, grid: VoxelGrid, free: np.ndarray, density: np.ndarray, near: float,
            far: float, max_chord: float) -> np.ndarray:
    """Per pixel position, the distance along its ray ``(K,)`` to the middle of the first chord through the
    smoothed hull ``density`` (above one half; crossings interpolated linearly). NaN where the ray misses the
    hull, or where the chord is longer than ``max_chord`` (a face seen edge on: no one contour point).

    A first pass steps a voxel at a time through the hull (nearest voxel, skipping empty space by ``free``, its
    :func:`~doodle.arrays.free_space`) to find where each ray enters; the second samples the smoothed hull at
    half-voxel steps from just before there.
    """
    h = grid.voxel
    origins, dirs = cam.rays_at(xy[:, 0], xy[:, 1])
    c0 = grid.coordinates(origins).astype(np.float32)  # (K, 3): voxel coordinates are linear along a ray
    cd = ((dirs @ grid.axes.T) / h).astype(np.float32)

    def coords(s: np.ndarray) -> np.ndarray:  # (K, S) distances → (K, S, 3) voxel coordinates
        return c0[:, None, :] + s[..., None].astype(np.float32) * cd[:, None, :]

    coarse = np.arange(near, far, h)
    at = coarse.astype(np.float32)
    first = first_occupied(free, lambda rows, j: c0[rows] + at[j][:, None] * cd[rows],
                           np.abs(cd).max(axis=1) * h, np.full(len(xy), len(coarse)))
    hit = first >= 0
    start = coarse[np.maximum(first, 0)] - 2 * h
    s = start[:, None] + np.arange(0.0, max_chord + 4 * h, 0.5 * h)[None, :]  # (K, S)
    occ = ndimage.map_coordinates(density, coords(s).reshape(-1, 3).T, order=1, mode="constant", cval=0.0)
    occ = occ.reshape(s.shape) - 0.5
    inside = occ > 0
    hit &= inside.any(axis=1)
    rows = np.arange(len(xy))
    first = np.argmax(inside, axis=1)
    after = (np.arange(s.shape[1])[None, :] > first[:, None]) & ~inside
    closes = after.any(axis=1)  # the chord ends inside the window
    last = np.where(closes, np.argmax(after, axis=1) - 1, s.shape[1] - 1)

    def crossing(a: np.ndarray, b: np.ndarray) -> np.ndarray:  # the zero of occ between samples a and b
        oa, ob = occ[rows, a], occ[rows, b]
        w = np.where(np.abs(oa - ob) > 1e-9, oa / np.where(np.abs(oa - ob) > 1e-9, oa - ob, 1.0), 0.5)
        return s[rows, a] + np.clip(w, 0, 1) * (s[rows, b] - s[rows, a])

    enter = crossing(np.maximum(first - 1, 0), first)
    leave = crossing(last, np.minimum(last + 1, s.shape[1] - 1))
    depth = 0.5 * (enter + leave)
    depth[~hit | ~closes | (leave - enter > max_chord)] = np.nan
    return depth


def view_rims(cam: Camera, mask: np.ndarray, grid: VoxelGrid, free: np.ndarray, density: np.ndarray,
              center: np.ndarray, radius: float, jump_voxels: float = 4.0, smooth: float = 1.5, inset: float = 1.5,
              max_chord_voxels: float = 40.0) -> list[tuple[np.ndarray, np.ndarray]]:
    """3D contour polylines of one view: ``(points (K, 3), normals (K, 3))`` per piece of its outline.

    ``free``: :func:`~doodle.arrays.free_space` of the carved hull (made once for all views); ``density``: the
    hull smoothed by a voxel. Pieces are split where the depth jumps by more than ``jump_voxels`` from one
    boundary point to the next (a part's outline passing behind another's) and where no contour point is found
    (see :func:`_chords`).
    """
    h = grid.voxel
    dist = float(np.linalg.norm(cam.center - center))
    near, far = max(dist - 1.2 * radius, 1e-6), dist + 1.2 * radius
    out = []
    contours = _boundary_rays(cam, mask)
    if not contours:
        return out
    # the chord is measured a little inside, where the smoothed hull is sure to be met; its middle lies at the
    # depth of the contour point itself, on the boundary pixel's ray (all contours at once: one march)
    depths = _chords(cam, np.concatenate([xy - inset * normal2 for xy, normal2, _, _ in contours]), grid, free,
                     density, near, far, max_chord_voxels * h)
    depths = np.split(depths, np.cumsum([len(c[0]) for c in contours])[:-1])
    for (xy, normal2, tan2, closed), depth in zip(contours, depths):
        filled = np.isfinite(depth)
        if filled.sum() < 6:
            continue
        # voxel noise in the depth is a couple of voxels; a part passing behind another jumps much more
        depth = np.where(filled, depth, np.interp(np.arange(len(depth)), np.flatnonzero(filled), depth[filled]))
        depth = ndimage.median_filter(depth, 7, mode="wrap" if closed else "nearest")
        origins, dirs = cam.rays_at(xy[:, 0], xy[:, 1])
        P = origins + depth[:, None] * dirs  # (the inset ray's depth is nearly the same distance along it)
        # the surface normal: the plane through the eye holding the outline's image tangent (camera frame)
        ray = np.stack([(xy[:, 0] - cam.cx) / cam.fx, (xy[:, 1] - cam.cy) / cam.fy, np.ones(len(xy))], -1)
        along = np.stack([tan2[:, 0] / cam.fx, tan2[:, 1] / cam.fy, np.zeros(len(xy))], -1)
        n_cam = np.cross(ray, along)
        n_cam /= np.maximum(np.linalg.norm(n_cam, axis=1, keepdims=True), 1e-12)
        n_cam[(n_cam[:, 0] * normal2[:, 0] + n_cam[:, 1] * normal2[:, 1]) < 0] *= -1
        N = n_cam @ cam.R  # camera → world
        cut = ~filled | np.r_[np.linalg.norm(np.diff(P, axis=0), axis=1) > jump_voxels * h, closed and
                              np.linalg.norm(P[0] - P[-1]) > jump_voxels * h]  # cut[i]: break after point i
        if closed and cut.any():  # start the loop just after a break, so no piece straddles the seam
            r = int(np.flatnonzero(cut)[-1]) + 1
            P, N, cut, filled = (np.roll(a, -r, axis=0) for a in (P, N, cut, filled))
        elif closed:
            cut[-1] = False
        ends = np.flatnonzero(cut)
        for a, b in zip(np.r_[0, ends + 1], np.r_[ends + 1, len(P)]):
            keep = filled[a:b]
            if keep.sum() < 6:
                continue
            pts = ndimage.gaussian_filter1d(P[a:b][keep], smooth, axis=0, mode="nearest")
            nrm = ndimage.gaussian_filter1d(N[a:b][keep], smooth, axis=0, mode="nearest")
            out.append((pts, nrm / np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-12)))
    return out


def _turns(normals: np.ndarray, max_turn_deg: float) -> list[tuple[int, int]]:
    """Index ranges ``[lo, hi)`` along a polyline, sharing their end points, over each of which its unit
    ``normals (K, 3)`` turn by at most ``max_turn_deg`` from the first."""
    cos_max = np.cos(np.radians(max_turn_deg))
    out, lo = [], 0
    while lo < len(normals) - 1:
        far = np.flatnonzero(normals[lo + 1:] @ normals[lo] < cos_max)
        hi = lo + 1 + int(far[0]) if len(far) else len(normals)
        hi = max(hi, lo + 2)
        out.append((lo, hi))
        lo = hi - 1
    return out


def find_rims(cameras: list[Camera], masks: list[np.ndarray], grid: VoxelGrid, occupied: np.ndarray,
              center: np.ndarray, radius: float, min_length: float, tolerance: float,
              max_turn_deg: float = 30.0) -> Rims:
    """Contour cubics of every view (see the module docstring). Pieces shorter than ``min_length`` are
    dropped, the rest fitted within ``tolerance`` (both in scene units) and split where their normal has
    turned by ``max_turn_deg``: the exporters interpolate a curve's normal linearly between its ends, which
    over a longer arc would stray by more than the contour gate allows (over 120° of a ball's outline, by
    14°)."""
    from concurrent.futures import ThreadPoolExecutor

    from ...workers import cpu_count

    density = ndimage.gaussian_filter(occupied.astype(np.float32), 1.0)
    free = free_space(occupied)
    with ThreadPoolExecutor(min(cpu_count(), 8)) as pool:  # numpy and scipy release the GIL: threads, no fork
        per_view = list(pool.map(lambda cm: view_rims(cm[0], cm[1], grid, free, density, center, radius),
                                 zip(cameras, masks)))
    polys, normals, views = [], [], []
    for v, found in enumerate(per_view):
        for pts, nrm in found:
            if np.linalg.norm(np.diff(pts, axis=0), axis=1).sum() < min_length:
                continue
            for lo, hi in _turns(nrm, max_turn_deg):
                polys.append(pts[lo:hi]), normals.append(nrm[lo:hi]), views.append(v)
    if not polys:
        return Rims(np.zeros((0, 4, 3)), np.zeros((0, 2, 3)), np.zeros(0, int))
    pieces = fit_cubics_many(polys, tolerance)
    controls, ends, owner = [], [], []
    for pts, nrm, v, cubics in zip(polys, normals, views, pieces):
        # each cubic's end normals: those of the polyline points nearest its ends
        d0 = np.linalg.norm(pts[None] - cubics[:, 0][:, None], axis=2).argmin(1)
        d3 = np.linalg.norm(pts[None] - cubics[:, 3][:, None], axis=2).argmin(1)
        controls.append(cubics)
        ends.append(np.stack([nrm[d0], nrm[d3]], axis=1))
        owner.append(np.full(len(cubics), v))
    return Rims(np.concatenate(controls), np.concatenate(ends), np.concatenate(owner))
