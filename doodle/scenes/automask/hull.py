"""The views must agree on one object: the hull their masks carve, and each view's share of it.

Every view's mask votes on a voxel grid about the object: a voxel is object when at least :data:`AGREE` of the
views that see it say so (one view's mistake does not carve the object, nor does it add to it), and never on
or below the support (a floor that some cuts took for the object is no part of it). The hull's projection
into a view is what the other views say that view should show.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy import ndimage

from ...cameras import Camera
from ..scene import HULL_DISAGREE
from .cut import disc
from .region import PLANE_TOL, ObjectRegion, in_view

AGREE = 1.0 - HULL_DISAGREE
"""Share of the views seeing a voxel that must call it object in the final masks' hull: the same tolerance as
the fit's hulls carved from these masks (one number for both)."""
FIRST_AGREE = 0.9
"""... and in the hull carved from the generous first masks, where a view's miss is likelier (a highlight, a
shadow): on the DTU skull, the hull's recall of the object 0.92 at :data:`AGREE`, 0.98 at 0.9 (precision 0.93 →
0.91, which the cut seeded by it takes back)."""
HULL_VOXELS = 96
"""Voxels along the longest side of the grid the masks vote on."""
STANDING_AGREE = 0.8
"""Share of the views seeing a voxel that must see it off the floor for it to stand on the support (:func:`standing`)."""


@dataclass(frozen=True)
class VoxelHull:
    """Voxels most views call object: ``occupied bool (X, Y, Z)``; voxel ``(i, j, k)`` has centre
    ``origin + (i, j, k) · voxel`` (world axes)."""

    occupied: np.ndarray
    origin: np.ndarray
    voxel: float

    @cached_property
    def centres(self) -> np.ndarray:
        """World centres ``(K, 3)`` of the occupied voxels."""
        return self.origin + np.argwhere(self.occupied) * self.voxel


def _box(region: ObjectRegion) -> tuple[np.ndarray, np.ndarray]:
    """The box the hull is carved in: the object points' box grown by its own size on every side, and by at
    least 1.2 scene radii (a smooth part without points, a cranium above a face, an object that gave
    few points at all, lies in it), within the scene's sphere about the focus."""
    pts = region.object_points
    lo, hi = np.percentile(pts, 1, axis=0), np.percentile(pts, 99, axis=0)
    r = region.radius
    size = max(float((hi - lo).max()), 1.2 * r)
    return np.maximum(lo - size, region.focus - 1.2 * r), np.minimum(hi + size, region.focus + 1.2 * r)


def reach_mask(cam: Camera, region: ObjectRegion, shape: tuple[int, int]) -> np.ndarray:
    """``bool (H, W)``: the pixels of a ``shape`` image of ``cam`` inside the projection of the box the object
    can reach (:func:`_box`); whatever lies outside is surely not the object."""
    import cv2

    lo, hi = _box(region)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    H, W = shape
    pc = corners @ cam.R.T + cam.t
    if (pc[:, 2] <= 1e-9).any():  # the camera is inside the box, or it reaches behind the camera: all of it
        return np.ones(shape, bool)
    uv = pc[:, :2] / pc[:, 2:] * [cam.fx, cam.fy] + [cam.cx, cam.cy]
    uv *= [W / cam.width, H / cam.height]
    out = np.zeros(shape, np.uint8)
    cv2.fillConvexPoly(out, cv2.convexHull(uv.astype(np.float32)).astype(np.int32), 1)
    return out.astype(bool)


def called_object(cameras: list[Camera], masks: list[np.ndarray], points: np.ndarray, agree: float) -> np.ndarray:
    """``(P,)`` bool: whether at least ``agree`` of the views that see each world point (and at least 3) call
    it object in their ``masks``."""
    seen = np.zeros(len(points), np.int32)
    inside = np.zeros(len(points), np.int32)
    pts = points.astype(np.float32)
    for cam, m in zip(cameras, masks):
        uv, ok = in_view(cam, pts)
        H, W = m.shape
        u = np.clip((uv[ok, 0] * W / cam.width).astype(int), 0, W - 1)
        v = np.clip((uv[ok, 1] * H / cam.height).astype(int), 0, H - 1)
        seen[ok] += 1
        inside[np.flatnonzero(ok)[m[v, u]]] += 1
    return (seen >= 3) & (inside >= agree * seen)


def standing(cameras: list[Camera], off_floor: list[np.ndarray], region: ObjectRegion, n: int = HULL_VOXELS
             ) -> VoxelHull:
    """The voxels above the support that at least :data:`STANDING_AGREE` of the views seeing them (and at least
    three) see off the floor (``off_floor``, :mod:`.floor`: a pixel whose ray meets the support where the other
    views see something else), in the box the object can reach (:func:`_box`). One view's off-floor pixels
    hold ghosts too — the floor its neighbours cannot see past the object — that other views do not confirm;
    a tripod's legs, which a busy carpet's colours hide from the cuts, every view does. Near a bulky object the
    views' ghosts agree into a halo round its foot: what this hull says must be weighed (:mod:`.thin`)."""
    return _voted(cameras, off_floor, region, n, STANDING_AGREE, _box(region))


def _voted(cameras: list[Camera], masks: list[np.ndarray], region: ObjectRegion, n: int, agree: float,
           box: tuple[np.ndarray, np.ndarray]) -> VoxelHull:
    """The voxels of an ``n``-voxel grid over ``box`` (``(lo, hi)``, world) above the support that at least
    ``agree`` of the views seeing them call object in ``masks`` (:func:`called_object`)."""
    lo, hi = box
    voxel = float((hi - lo).max()) / n
    axes = [np.arange(lo[a] + voxel / 2, hi[a], voxel) for a in range(3)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    above = np.flatnonzero(region.height(grid) > PLANE_TOL * region.radius)
    occupied = np.zeros(len(grid), bool)
    occupied[above[called_object(cameras, masks, grid[above], agree)]] = True
    return VoxelHull(occupied.reshape([len(a) for a in axes]), lo + voxel / 2, voxel)


def carve(cameras: list[Camera], masks: list[np.ndarray], region: ObjectRegion, n: int = HULL_VOXELS,
          agree: float = AGREE, box: tuple[np.ndarray, np.ndarray] | None = None) -> VoxelHull:
    """The voxels at least ``agree`` of the views seeing them call object, above the support, in ``box``
    (``(lo, hi)``, world; default: the box the object can reach, :func:`_box`)."""
    voted = _voted(cameras, masks, region, n, agree, _box(region) if box is None else box)
    occupied, origin, voxel = voted.occupied, voted.origin, voted.voxel
    # what stands apart from the object's body is not the object (a patch of floor a few cuts took)
    labels, count = ndimage.label(occupied)
    if count > 1:
        ijk = np.floor((region.object_points - origin) / voxel + 0.5).astype(int)
        ok = np.all((ijk >= 0) & (ijk < occupied.shape), axis=1)
        hits = np.bincount(labels[tuple(ijk[ok].T)], minlength=count + 1)[1:]
        sizes = np.bincount(labels.ravel(), minlength=count + 1)[1:]
        keep_labels = 1 + np.flatnonzero((hits > 0) | (sizes >= 0.2 * sizes.max()))
        occupied = np.isin(labels, keep_labels)
    return VoxelHull(occupied, origin, voxel)


def shadow(cam: Camera, hull: VoxelHull, shape: tuple[int, int]) -> np.ndarray:
    """The pixels of a ``shape`` image of ``cam`` whose ray meets a hull voxel (voxel centres splatted with their
    projected size)."""
    H, W = shape
    m = np.zeros(shape, bool)
    centres = hull.centres
    if not len(centres):
        return m
    uv, ok = in_view(cam, centres)
    if not ok.any():
        return m
    sx, sy = W / cam.width, H / cam.height
    z = (centres[ok] @ cam.R.T + cam.t)[:, 2]
    m[np.minimum((uv[ok, 1] * sy).astype(int), H - 1), np.minimum((uv[ok, 0] * sx).astype(int), W - 1)] = True
    r = 0.6 * hull.voxel * max(cam.fx * sx, cam.fy * sy) / float(np.median(z))
    return ndimage.binary_closing(ndimage.binary_dilation(m, disc(r)), disc(r))


def agreement(masks: list[np.ndarray], shadows: list[np.ndarray]) -> np.ndarray:
    """Per view, the IoU of its mask with ``shadows``'s: with the hull's projection, how much the other views
    agree with it; with true masks, how right it is."""
    return np.array([(m & s).sum() / max((m | s).sum(), 1) for m, s in zip(masks, shadows)])
