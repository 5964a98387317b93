"""The outline of a stroke set's ``hull``: the silhouette the object's visual hull casts in any view.

A superquadric draws the outline of the part it fits and a contour curve the outline one training view saw;
neither draws an outline as intricate as a bulldozer's (bucket teeth, the holes of an arm's linkage), and
between the training views contour curves leave gaps. The visual hull carved from the masks projects, in
every training view, onto that view's mask, and in a view between them onto the silhouette of all the
views agree on, which with views all around is the object's own within a voxel or two. A fit stores that
hull (:attr:`~doodle.strokes.model.StrokeSet.hull`) and every view draws the outline of its projection.

How. The occupancy is smoothed (a Gaussian of :data:`SMOOTH` voxels) and the voxels of its shell are
projected onto a raster whose pixel is as wide as the nearest voxel's image; a raster pixel keeps the
largest value landing in it, which is the smoothed volume's maximum along the rays through it. The 0.5 level
of that image, traced by marching squares (and moved in by :data:`RASTER_BIAS`: a pixel keeps its largest
value), is the outline to a fraction of a voxel; it is smoothed along its
length by a voxel's image (the staircase of the voxels goes, corners round by a voxel) and fitted with cubics
to :data:`FIT_TOLERANCE` of a voxel's image. Where another stroke already draws the outline (a feature
curve along a box's edge, a superquadric's exact outline), the hull's outline gives way to it
(:func:`uncovered_runs`): it draws what the strokes leave undrawn.
"""

from __future__ import annotations

import hashlib

import numpy as np
from scipy import ndimage
from skimage import measure

from ..arrays import along_polyline
from ..cameras import Camera
from ..strokes.model import Voxels
from .silhouettes import split_runs

SMOOTH = 0.7
"""Standard deviation (voxels) of the Gaussian that smooths the occupancy before it is projected. At 0.7 the
0.5 level passes midway between an occupied voxel's centre and an empty neighbour's."""
SHELL = (0.02, 0.98)
"""Smoothed values of the voxels projected: the shell around the surface (inside it, the shell's front already
covers every pixel with values above 0.5)."""
ALONG = 1.0
"""Standard deviation, in voxel images, of the smoothing along the outline (the voxels' staircase)."""
FIT_TOLERANCE = 0.4
"""Cubic fitting tolerance, in voxel images: the outline is only as exact as the hull."""
GIVE_WAY = 0.75
"""The hull's outline gives way to other ink within this many voxel images (at least :data:`GIVE_WAY_PX`)."""
GIVE_WAY_PX = 1.5
RASTER_BIAS = 0.35
"""How far (raster pixels) the 0.5 level of the raster lies outside the hull's: a raster pixel keeps the
largest value landing anywhere in it. Measured on voxelised balls seen from many sides, grids turned or not:
0.32–0.37 (spread 0.1); the outline is moved in by this much."""
MAX_RASTER = 4096
#: Raster pixels the hull's projection is traced past the frame before its outline is cut at the frame.
FRAME_MARGIN = 4


_SHELLS: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}  # the last hulls' shells: batches of views share them


def hull_shell(hull: Voxels) -> tuple[np.ndarray, np.ndarray]:
    """Centres ``(P, 3)`` (world) and smoothed occupancies ``(P,)`` of the voxels around the hull's surface.

    Kept for the last two hulls seen: a file's views are drawn in batches, each asking again (0.2 s for Lego's
    3 million voxels)."""
    key = hashlib.sha1(b"".join([np.packbits(hull.occupied).tobytes(), str(hull.occupied.shape).encode(),
                                 np.asarray(hull.origin, np.float64).tobytes(), np.float64(hull.voxel).tobytes(),
                                 np.asarray(hull.axes, np.float64).tobytes()])).digest()
    if key not in _SHELLS:
        smooth = ndimage.gaussian_filter(np.pad(hull.occupied, 2).astype(np.float32), SMOOTH)
        shell = (smooth > SHELL[0]) & (smooth < SHELL[1])
        ijk = np.argwhere(shell)
        while len(_SHELLS) >= 2:
            _SHELLS.pop(next(iter(_SHELLS)))
        _SHELLS[key] = (hull.centres(ijk - 2), smooth[shell])  # the padding shifts the indices by 2
    return _SHELLS[key]


def outline_polylines(hull: Voxels, cameras: list[Camera]) -> list[tuple[list[np.ndarray], float]]:
    """Per camera, the hull's outline as smoothed polylines ``(P, 2)`` in pixels (closed ones repeat their first
    point last) and the width in pixels of the nearest voxel's image (the outline's accuracy).

    A camera among the voxels, or one that sees none of them, gets no outline (and a width of 0).
    """
    centres, values = hull_shell(hull)
    out: list[tuple[list[np.ndarray], float]] = []
    for cam in cameras:
        uv, z = cam.project(centres) if len(centres) else (np.zeros((0, 2)), np.zeros(0))
        ortho = cam.projection == "orthographic"
        if not len(z) or (not ortho and (z <= 1e-9).any()):
            out.append(([], 0.0))  # a camera among the voxels: no silhouette to speak of
            continue
        foot = float(cam.fx * hull.voxel / (1.0 if ortho else z.min()))
        scale = min(1.0 / foot, MAX_RASTER / max(cam.width, cam.height))  # raster pixels per image pixel
        pad = 1 + FRAME_MARGIN  # traced past the frame, then cut at it: where the hull runs out of the view,
        # the raster's edge is no outline of it
        shape = (int(np.ceil(cam.height * scale)) + 2 * pad, int(np.ceil(cam.width * scale)) + 2 * pad)
        col = np.floor(uv[:, 0] * scale).astype(np.intp) + pad
        row = np.floor(uv[:, 1] * scale).astype(np.intp) + pad
        ok = (col >= 1) & (row >= 1) & (col < shape[1] - 1) & (row < shape[0] - 1)
        if not ok.any():
            out.append(([], 0.0))
            continue
        image = np.zeros(shape, np.float32)
        np.maximum.at(image, (row[ok], col[ok]), values[ok])
        polys = []
        for c in measure.find_contours(image, 0.5):
            if len(c) < 4:
                continue
            closed = bool(np.allclose(c[0], c[-1]))
            c = c - RASTER_BIAS * _outward(image, c, closed)
            xy = np.stack([c[:, 1], c[:, 0]], axis=1) - (pad - 0.5)  # raster pixel k's centre is k - pad + 0.5
            xy /= scale
            if closed:
                xy = ndimage.gaussian_filter1d(xy[:-1], ALONG, axis=0, mode="wrap")
                xy = np.vstack([xy, xy[:1]])
            else:
                xy = ndimage.gaussian_filter1d(xy, ALONG, axis=0, mode="nearest")
            inside = (xy[:, 0] >= 0) & (xy[:, 1] >= 0) & (xy[:, 0] <= cam.width) & (xy[:, 1] <= cam.height)
            polys += split_runs(xy, inside)
        out.append((polys, foot))
    return out


def _outward(image: np.ndarray, contour: np.ndarray, closed: bool) -> np.ndarray:
    """Unit normals ``(P, 2)`` (row, column) of a level line of ``image`` pointing to its lower side."""
    nxt = np.roll(contour, -1, axis=0) if closed else np.vstack([contour[1:], contour[-1:]])
    prv = np.roll(contour, 1, axis=0) if closed else np.vstack([contour[:1], contour[:-1]])
    tangent = nxt - prv
    normal = np.stack([-tangent[:, 1], tangent[:, 0]], axis=1)
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-12)
    ahead = ndimage.map_coordinates(image, (contour + 0.5 * normal).T, order=1, mode="nearest")
    behind = ndimage.map_coordinates(image, (contour - 0.5 * normal).T, order=1, mode="nearest")
    return normal * np.where(ahead <= behind, 1.0, -1.0)[:, None]


def uncovered_runs(polys: list[np.ndarray], ink: np.ndarray, reach: float) -> list[tuple[np.ndarray, bool]]:
    """The runs of outline polylines (resampled about a pixel apart) farther than ``reach`` px from every point
    of other strokes' ``ink`` ``(Q, 2)``, each with whether it is a closed loop."""
    from scipy.spatial import cKDTree  # here, as in drop_small_marks: workers start without it (70 ms)

    tree = cKDTree(ink) if len(ink) else None
    runs = []
    for poly in polys:
        length = float(np.cumsum(np.linalg.norm(np.diff(poly, axis=0), axis=1))[-1])
        pts = along_polyline(poly, int(np.ceil(length)) + 1) if length > 0 else poly[:1]  # a pixel apart
        closed = len(pts) > 3 and bool(np.allclose(poly[0], poly[-1]))
        if closed:
            pts[-1] = pts[0]  # split_runs keeps a loop joined at its seam when both ends are kept
        free = np.ones(len(pts), bool) if tree is None else ~np.isfinite(tree.query(pts, distance_upper_bound=reach)[0])
        runs += [(run, closed and bool(free.all())) for run in split_runs(pts, free)]
    return runs
