"""Thin parts the cuts lose: ears, a tail, an antenna.

A graph cut pays for every pixel of boundary, so a part a few pixels across costs more boundary than its
colour gains and is cut off (GrabCut's shrinking bias); the hull the cut views then carve has no such part,
and the next cuts, seeded by that hull, lose it for good. The generous first masks (:func:`.cut.likely_object`,
by colour alone) still hold it, along with a fringe of the floor round the object that changes from view to
view, and the floor seen in a crease between two parts. What the views agree on in those masks, on a grid fine
enough for a part a few pixels across, and what stands out of the final hull farther than a fringe does,
joined to it at a base rather than along its length, is a thin part: each view gets back the pixels of its
first mask that part covers.

A thin part that comes down to the floor (a tripod's legs) cannot be told that way from a patch of floor the
first masks agree on; the floor cue can (:func:`standing_parts`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy import ndimage

from ...cameras import Camera
from .hull import AGREE, FIRST_AGREE, VoxelHull, called_object, carve, shadow, standing
from .region import ObjectRegion

THIN_VOXELS = 128
"""Voxels along the longest side of the grid thin parts are looked for on (the hull's box grown by
:data:`MARGIN`): an ear or a tail a few pixels across in the photos is a voxel or two."""
MARGIN = 0.25
"""The grid's box: the final hull's grown by this share of its largest side on every side."""
FRINGE = 2
"""Voxels of that grid a fringe of the floor (or a mask a pixel too wide) stands out of the hull at most."""
MIN_OUT = 5
"""Voxels of that grid a thin part reaches out of the hull at least (about 5 % of the object's size; the
painted calf's ears and tail reach farther, the fringes along its legs and belly that the views agree on
not as far). At 160 voxels and 6 the masks came out the same (calf IoU 0.922, cow 0.893, parcel 0.971) at
twice the cost."""
MAX_PART = 0.05
"""A thin part holds at most this share of the hull's volume (an ear, a tail: well under 1 %)."""
MAX_BASE = 1.2
"""A thin part joins the body at its base: the voxels by which it does (within the fringe of the body) are at
most this many times its own beyond the fringe. The carpet cow's and calf's ears and tails measure 0.5-0.9;
a fillet of floor in a crease between two parts (the corner between a parcel's box and the ball on it, which
the generous first masks agree on) lies along the body its whole length: 1.7-3.2."""


STANDING_REACH = 0.3
"""Scene radii a part standing on the support (:func:`standing_parts`) reaches out of the hull, and rises above
the support, at least: the ghosts of the floor cue round a bulky object's foot agree on a halo that reaches
0.1-0.2 out and up (a patch at the carpet parcel's box's corner: 0.32 out, 0.17 up); a tripod's legs reach a
radius out and rise to its head (1.2)."""
STANDING_BASE = 0.35
"""... and the voxels by which it joins the hull at most this many times its own: it joins at a narrow base (the
carpet tripod's legs: 0.05; a thin leg of a few voxels across, whose base is as thick as it: 0.3), while the
halo round the carpet teapot's body lies along it (0.48) and rises up its side."""


def protrusions(fine: VoxelHull, body: VoxelHull, height: Callable[[np.ndarray], np.ndarray] | None = None,
                fringe: int = FRINGE, min_out: int = MIN_OUT, max_part: float = MAX_PART,
                max_base: float = MAX_BASE) -> VoxelHull:
    """The voxels of ``fine`` that stand out of ``body`` (on the same grid) as a thin part does: the pieces of
    it farther than ``fringe`` voxels from ``body`` that reach at least ``min_out`` voxels out, hold at most
    ``max_part`` of ``body``'s volume, join it at a base (``max_base``) and do not come down to the
    support (within ``fringe + 1`` voxels of it by ``height``, world points → height above the support: a patch
    of floor the generous masks agree on beside the object's foot, rising a few voxels up its side, is no thin
    part; a thin part standing on the floor cannot be told from one), with what joins them to ``body``
    (``fine``'s voxels within ``fringe + 1`` of them). A piece must start where a fringe ends (come within
    ``fringe + 1.5`` voxels of ``body``): what floats apart is no part of the object."""
    inside = body.occupied
    out = fine.occupied & ~inside
    if not out.any() or not inside.any():
        return VoxelHull(np.zeros_like(fine.occupied), fine.origin, fine.voxel)
    reach = ndimage.distance_transform_edt(~inside)
    labels, n = ndimage.label(out & (reach > fringe), np.ones((3, 3, 3), bool))
    if n == 0:
        return VoxelHull(np.zeros_like(fine.occupied), fine.origin, fine.voxel)
    index = np.arange(1, n + 1)
    far = np.asarray(ndimage.maximum(reach, labels, index))
    size = np.bincount(labels.ravel(), minlength=n + 1)[1:]
    near = np.asarray(ndimage.minimum(reach, labels, index))  # attached: it starts where the fringe ends
    ok = (far >= min_out) & (near <= fringe + 1.5) & (size <= max_part * inside.sum())
    rim = out & (reach <= fringe + 1)
    boxes = ndimage.find_objects(labels)
    for k in np.flatnonzero(ok):
        ok[k] = _base(labels, k + 1, boxes[k], rim, fringe) <= max_base * size[k]
    if height is not None and ok.any():
        h = height(fine.origin + np.argwhere(labels > 0) * fine.voxel)
        ok &= np.asarray(ndimage.minimum(h, labels[labels > 0], index)) > (fringe + 1) * fine.voxel
    parts = np.isin(labels, index[ok])
    return VoxelHull(ndimage.binary_dilation(parts, iterations=fringe + 1) & out, fine.origin, fine.voxel)


def _base(labels: np.ndarray, k: int, piece: tuple[slice, ...], rim: np.ndarray, fringe: int) -> int:
    """Voxels of ``rim`` (what stands out of the body within its fringe) within ``fringe + 1`` of piece ``k``
    of ``labels`` (its box ``piece``): what joins the piece to the body."""
    box = tuple(slice(max(b.start - fringe - 2, 0), b.stop + fringe + 2) for b in piece)
    grown = ndimage.binary_dilation(labels[box] == k, iterations=fringe + 1)
    return int((grown & rim[box]).sum())


def restore_thin_parts(cameras: list[Camera], first: list[np.ndarray], final: list[np.ndarray],
                       region: ObjectRegion, body: VoxelHull) -> tuple[list[np.ndarray], int]:
    """``final`` masks with the thin parts they lost (see the module doc) put back from the ``first`` masks;
    ``body``: the hull ``final`` carve (its box is where thin parts are looked for). Returns the masks and the
    thin parts' voxel count."""
    if not body.occupied.any():
        return final, 0
    ijk = np.argwhere(body.occupied)
    lo = body.origin + (ijk.min(axis=0) - 0.5) * body.voxel
    hi = body.origin + (ijk.max(axis=0) + 0.5) * body.voxel
    grow = MARGIN * float((hi - lo).max())
    both = [f | m for f, m in zip(first, final)]
    fine = carve(cameras, both, region, n=THIN_VOXELS, agree=FIRST_AGREE, box=(lo - grow, hi + grow))
    # the body on the same grid (a box's edges and corners, which a coarser hull rounds, stand out of nothing),
    # voted on at ``fine``'s voxels only: the final masks lie within ``both``, so the body within ``fine``
    inside = np.zeros_like(fine.occupied)
    inside[tuple(np.argwhere(fine.occupied)[called_object(cameras, final, fine.centres, AGREE)].T)] = True
    thin = protrusions(fine, VoxelHull(inside, fine.origin, fine.voxel), region.height)
    count = int(thin.occupied.sum())
    if count == 0:
        return final, 0
    return [_attached(m, f & shadow(c, thin, m.shape)) for c, f, m in zip(cameras, first, final)], count


def standing_parts(cameras: list[Camera], first: list[np.ndarray], final: list[np.ndarray], region: ObjectRegion,
                   off_floor: list[np.ndarray]) -> tuple[list[np.ndarray], int]:
    """``final`` masks with the parts standing on the support that the cuts lost put back from the ``first``
    masks: a tripod's legs on a busy carpet, as dark as its pattern, which the cuts took away with the carpet
    between them, and which :func:`restore_thin_parts` may not tell from a patch of floor (they come down to
    it). The floor cue tells them (:func:`.hull.standing`): a piece of what every view sees off the floor that
    stands out of the final masks' hull farther than the halo of agreeing ghosts round a bulky object's foot
    does (:data:`STANDING_REACH`) and joins it at a narrow base (:data:`STANDING_BASE`). Returns the masks and
    the parts' voxel count. ``off_floor``: each view's off-floor pixels."""
    stands = standing(cameras, off_floor, region)
    if not stands.occupied.any():
        return final, 0
    # the final masks' hull on the same grid, where it matters: near what stands
    near = np.argwhere(ndimage.binary_dilation(stands.occupied, iterations=FRINGE + 2))
    body = np.zeros_like(stands.occupied)
    body[tuple(near[called_object(cameras, final, stands.origin + near * stands.voxel, AGREE)].T)] = True
    reach = int(np.ceil(STANDING_REACH * region.radius / stands.voxel))
    parts = protrusions(VoxelHull(stands.occupied | body, stands.origin, stands.voxel),
                        VoxelHull(body, stands.origin, stands.voxel), None, min_out=reach, max_part=np.inf,
                        max_base=STANDING_BASE)
    # and it rises from the support: a patch of floor the halo holds at a box's corner stays at its foot
    labels, n = ndimage.label(parts.occupied, np.ones((3, 3, 3), bool))
    if n:
        top = ndimage.maximum(region.height(parts.origin + np.argwhere(labels > 0) * parts.voxel),
                              labels[labels > 0], np.arange(1, n + 1))
        parts = VoxelHull(np.isin(labels, 1 + np.flatnonzero(np.asarray(top) >= STANDING_REACH * region.radius)),
                          parts.origin, parts.voxel)
    count = int(parts.occupied.sum())
    if count == 0:
        return final, 0
    return [_attached(m, f & shadow(c, parts, m.shape)) for c, f, m in zip(cameras, first, final)], count


def _attached(mask: np.ndarray, extra: np.ndarray) -> np.ndarray:
    """``mask`` with the pieces of ``extra`` that touch it."""
    labels, n = ndimage.label(extra & ~mask)
    if n == 0:
        return mask
    touching = np.unique(labels[ndimage.binary_dilation(mask) & (labels > 0)])
    return mask | np.isin(labels, touching)
