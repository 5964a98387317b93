"""The thick part of an object, which superquadrics may explain; thin parts are left to curves.

The visual hull is opened in 3D (eroded, then dilated back) by a radius that is a few percent of the
object's size: cables, legs, handles, rims and spokes vanish, bodies stay, and so do small compact parts
(a knob, a bulb), whose outlines no curve can draw. The opened volume is projected
into every view; a superquadric's silhouette target is the mask restricted to that projection, so pixels of
thin parts (and holes and loops between them) count as empty and no superquadric grows over them. Opening
in 3D rather than per image keeps the targets consistent across views: a plate stays thin when seen from
above, where its mask is a wide region.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy import ndimage

from ...scenes import Scene
from ...strokes.fileio import MAX_VOXEL_SIDE
from ...strokes.model import Voxels
from .carve import VoxelGrid, coarsened, project_points
from .abstraction import thick_part


@dataclass
class Volume:
    """``interior``: centres ``(P, 3)`` of the thick voxels; ``masks``: per view, the object's thick pixels."""

    interior: np.ndarray
    masks: list[np.ndarray]
    thin_share: float
    """Share of the mask pixels (over the views) that belong to thin parts."""


def thick_volume(scene: Scene, grid: VoxelGrid, occupied: np.ndarray, thin: float = 0.06, max_voxels: int = 96
                 ) -> Volume:
    """Open the carving (``occupied`` on ``grid``, brought to at most ``max_voxels`` a side) by ``thin`` × its box's
    diagonal and project it into the views of ``scene``."""
    grid, occupied = coarsened(grid, occupied, max_voxels)
    size = grid.voxel * float(np.linalg.norm(occupied.shape))
    r = max(1, int(round(0.5 * thin * size / grid.voxel)))
    opened = thick_part(occupied, r)
    pts = grid.centres(np.argwhere(opened)).astype(np.float32)
    masks, thin_px, all_px = [], 0, 0
    for cam, mask in zip(scene.cameras, scene.masks):
        masks.append(mask & _splat(cam, pts, grid))
        thin_px += int((mask & ~masks[-1]).sum())
        all_px += int(mask.sum())
    return Volume(pts.astype(np.float64), masks, thin_px / max(all_px, 1))


OCCLUDER_VOXELS = 96
"""Voxels along the longest side of the occluder volume a fit stores. Shrunk by a voxel and marched with
1.5 voxels of slack, a coarse volume hides only what lies a few voxels behind the object's surface: on Lego,
held-out line precision 0.778 / 0.795 / 0.804 at 64 / 96 / 128 voxels (F 0.794 / 0.802 / 0.803), the
chair 0.879 → 0.892 and the lamp 0.945 → 0.954 from 64 to 96. At 96 the volume takes 0.3–5 kB of the binary
file (Lego 4.8 kB), at 128 Lego's takes 10 kB."""


def occluder_voxels(size: int) -> int:
    """Occluder voxels for a fit at working size ``size`` (px, the images' larger side): :data:`OCCLUDER_VOXELS`
    at the default 256 px, fewer for smaller working images, whose masks carve no finer (a voxel is kept
    to at least 8/3 working pixels; on the tests' 128 px chair of 12 views, a 96-voxel hull let three
    superquadric outlines pass by a hair)."""
    return int(min(OCCLUDER_VOXELS, max(16, round(size * 3 / 8))))


def hull_occluder(grid: VoxelGrid, occupied: np.ndarray, max_voxels: int = OCCLUDER_VOXELS) -> Voxels:
    """The carving (``occupied`` on ``grid``) on a coarse grid, as the stroke set's occluder: it hides the curves
    and outlines behind the object's bulk where no superquadric stands (a box's back edges seen through its
    front, a tripod's far leg behind its microphone)."""
    grid, occupied = coarsened(grid, occupied, max_voxels)
    # A voxel in: the hull fills concavities no view looks into (beside Lego's tracks, on its plate), where
    # visible edges lie inside it; shrunk, it hides them less (Lego held-out recall 0.77 → 0.80).
    return grid.volume(ndimage.binary_erosion(occupied))


def outline_hull(grid: VoxelGrid, occupied: np.ndarray) -> Voxels:
    """The stroke file's ``hull``, whose outline every view draws: the visual hull ``occupied`` on ``grid``
    opened by a voxel (6-connected). That takes the thin webs the views never carve apart (between the
    chair's legs under its seat, from 40 views: an arc drawn under the seat in a view between them) and parts
    under three voxels across, which curves draw along their axes (a tripod's legs, drawn by their axis and a
    narrow outline beside it). Held-out F, the hull opened against as carved, same strokes: chair 0.904 →
    0.907, Lego 0.893 → 0.895, tripod 0.965 → 0.959, lamp 0.967 → 0.962, the others within 0.002; opened by
    two voxels, Lego 0.866 and the tripod 0.936 (the arm's and the legs' outline lost). A carving finer than
    the stroke files hold (``--evidence-voxels`` above :data:`~doodle.strokes.fileio.MAX_VOXEL_SIDE`) is
    coarsened to it first, so that every fit's file reads back."""
    if max(occupied.shape) > MAX_VOXEL_SIDE:
        grid, occupied = coarsened(grid, occupied, MAX_VOXEL_SIDE)
    return grid.volume(ndimage.binary_opening(occupied, structure=ndimage.generate_binary_structure(3, 1)))


def clear_seen(occluder: Voxels, grid: VoxelGrid, free: np.ndarray) -> Voxels:
    """The occluder without the voxels whose centres fall in voxels of ``grid`` marked ``free`` (the hull the views
    see through, :mod:`.sightlines`): what the training views show must not be hidden in the drawings."""
    ijk = np.argwhere(occluder.occupied)
    if not len(ijk) or not free.any():
        return occluder
    fine = grid.index(occluder.centres(ijk))
    inside = np.all((fine >= 0) & (fine < np.array(free.shape)), axis=1)
    seen = np.zeros(len(ijk), bool)
    seen[inside] = free[tuple(fine[inside].T)]
    occupied = occluder.occupied.copy()
    occupied[tuple(ijk[seen].T)] = False
    return replace(occluder, occupied=occupied)


def _splat(cam, pts: np.ndarray, grid: VoxelGrid) -> np.ndarray:
    """The pixels covered by voxels centred at ``pts`` (each drawn as a disc of its projected size)."""
    img = np.zeros((cam.height, cam.width), bool)
    if len(pts) == 0:
        return img
    u, v, z = project_points(cam, pts)
    ok = (z > 1e-6) & (u >= 0) & (v >= 0) & (u < cam.width) & (v < cam.height)
    img[v[ok], u[ok]] = True
    footprint = max(cam.fx, cam.fy) * grid.voxel / float(np.median(z[ok])) if ok.any() else 1.0
    k = int(np.ceil(0.5 * footprint * np.sqrt(3)))
    if k > 0:
        img = ndimage.binary_dilation(img, iterations=k)
    return ndimage.binary_closing(img, iterations=1)
