"""Texture is not structure: which strokes lie on a smooth face of the object (print, decals, grain).

A printed line is as consistent across the views as a crease: the vote (:mod:`.evidence`) cannot tell them
apart. The carved hull can. Along a crease, a step or a thin part its surface turns; under a printed line it
does not. At every voxel the hull's outward directions within a couple of voxels are summed, and their
coherence ``|Σ n| / Σ |n|`` is 1 on a flat or gently curved face, ``cos(θ / 2)`` across a crease of angle
``θ`` (0.71 for a right angle) and near 0 in a part thinner than that, whose sides face opposite ways. A
stroke with more than :data:`SMOOTH_SHARE` of its samples on the hull's surface where the coherence is above
:data:`SMOOTH_COHERENCE` lies on a smooth face. There it counts only for the outline it draws
(:func:`~doodle.fit.discovery.discover.select_strokes`): where a smooth face turns away from a view, a line on it is the
outline; anywhere else it is paint. A stripe across a face then gains nothing, however strong it is.

Lines inside the hull, away from its surface (concave creases and hollows, which a visual hull bridges), are
not judged: the hull says nothing about the surface there.
"""

from __future__ import annotations

import hashlib
import math

import numpy as np
from scipy import ndimage

from ...strokes.bezier import bezier_points
from ..volume.carve import VoxelGrid

#: Above this coherence of the hull's outward directions the surface is a smooth face: a bend of less than
#: 2 · acos(0.98) ≈ 23° within a couple of voxels (a box's edge is 90°, a sphere of 20 voxels' radius bends
#: about 6° over that reach). At 0.95 (36°) the ABC-NEF nut's 30° chamfer edges counted as paint: 3D recall
#: 0.931 → 0.790 in discovery; at 0.97, 0.922; at 0.98 it is unchanged.
SMOOTH_COHERENCE = 0.98
#: A stroke with more than this share of its samples on smooth faces of the hull lies on a smooth face. Less
#: than half: a visual hull bulges over faces that no view sees edge-on, and the print there lies a few
#: voxels under it, beyond the surface weight (on the parcel, discovery alone, a share of 0.5 left 0.36 of the
#: chosen curves' points on the print, 0.3 left 0.27, against 0.46 unjudged; the nut's edges were unchanged).
SMOOTH_SHARE = 0.3
#: Within how much of a flat face's surface weight a point counts as on the surface (see :func:`hull_coherence`).
SURFACE_WEIGHT = 0.3


#: The last hull's :func:`hull_coherence`, ``(key, (coherence, surface))`` with the hull's bits and the arguments
#: as key: a fit asks for the same hull's in discovery and in the superquadrics' judging (1.2 s each time on a
#: 192-voxel grid). Replaced whole, never changed in place, so threads may share it.
_LAST: tuple | None = None


def hull_coherence(occupied: np.ndarray, sigma: float = 1.5, reach: float = 2.0) -> tuple[np.ndarray, np.ndarray]:
    """Coherence of the hull's outward directions, and how much surface is near, at every voxel.

    Args:
        occupied: ``(X, Y, Z)`` bool, the carved hull.
        sigma: smoothing of the occupancy (voxels) before its gradient: a voxel hull's stairs become a face.
        reach: Gaussian reach (voxels) over which the gradients are summed.

    Returns:
        ``coherence`` ``(X, Y, Z)`` in [0, 1] (``|G * ∇f| / (G * |∇f|)``) and ``surface`` ``(X, Y, Z)``: the
        summed gradient magnitude over a flat face's value (1 on a flat face's surface, falling to 0 a few
        voxels away from any surface). Read-only: the same arrays go to the next caller with this hull.
    """
    global _LAST
    key = (occupied.shape, hashlib.sha1(np.packbits(occupied)).hexdigest(), sigma, reach)
    last = _LAST
    if last is None or last[0] != key:
        fields = _coherence(occupied, sigma, reach)
        for a in fields:
            a.setflags(write=False)  # shared by every caller until the next hull
        last = _LAST = (key, fields)
    return last[1]


def _coherence(occupied: np.ndarray, sigma: float, reach: float) -> tuple[np.ndarray, np.ndarray]:
    f = ndimage.gaussian_filter(occupied.astype(np.float32), sigma)
    grad = np.gradient(f)
    weight = ndimage.gaussian_filter(np.sqrt(sum(g * g for g in grad)), reach)
    summed = np.sqrt(sum(ndimage.gaussian_filter(g, reach) ** 2 for g in grad))
    coherence = summed / np.maximum(weight, 1e-9)
    flat = 1.0 / math.sqrt(2 * math.pi * (sigma**2 + reach**2))  # a step smoothed by both Gaussians
    return coherence, weight / flat


def smooth_face_share(controls: np.ndarray, grid: VoxelGrid, coherence: np.ndarray, surface: np.ndarray,
                      samples: int = 16) -> np.ndarray:
    """``(N,)`` share of each cubic's ``samples`` points ``(N, 4, 3)`` that lie on a smooth face of the hull
    (surface weight above :data:`SURFACE_WEIGHT`, coherence above :data:`SMOOTH_COHERENCE`)."""
    if not len(controls):
        return np.zeros(0)
    pts = bezier_points(controls, np.linspace(0, 1, samples)).reshape(-1, 3)
    ijk = grid.coordinates(pts).T
    c = ndimage.map_coordinates(coherence, ijk, order=1, cval=0.0)
    s = ndimage.map_coordinates(surface, ijk, order=1, cval=0.0)
    return ((c > SMOOTH_COHERENCE) & (s > SURFACE_WEIGHT)).reshape(len(controls), samples).mean(axis=1)


def smooth_shares(controls: np.ndarray, grid: VoxelGrid, occupied: np.ndarray) -> np.ndarray:
    """``(N,)`` the share of each cubic ``(N, 4, 3)`` on smooth faces of the hull ``occupied``: above
    :data:`SMOOTH_SHARE` it lies on a smooth face (:func:`on_smooth_faces`); near 1 it lies on one whole, as
    paint does, not across a junction of parts (:mod:`.salience`)."""
    coherence, surface = hull_coherence(occupied)
    return smooth_face_share(controls, grid, coherence, surface)


def on_smooth_faces(controls: np.ndarray, grid: VoxelGrid, occupied: np.ndarray) -> np.ndarray:
    """``(N,)`` bool: the cubics ``(N, 4, 3)`` that lie on a smooth face of the hull ``occupied`` (see the
    module docstring)."""
    return smooth_shares(controls, grid, occupied) > SMOOTH_SHARE
