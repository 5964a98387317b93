"""Thin plates as occluders: a chair's back, a shelf, an ear hide what lies behind them.

The abstraction (:mod:`.abstraction`) leaves thin parts to curves: a superquadric's rounded outline would draw
a plate worse than the curves along its edges. But a sketch of curves alone shows what a plate hides — the
seat's back edge through the chair's back, the far side of an ear through the ear. A thin part that is broad
in two directions and thin in the third is such a plate; a flat box over it draws nothing and hides what
lies behind it. Each plate is offered as an occluder only: the fit keeps the ones that agree with the hull on
what the views see (:func:`~doodle.fit.volume.outlines.useful_occluders`), as it does the abstraction's own.

The box lies on the plate's principal axes, through the middle of its voxels: across the plate it is a voxel
thick (a visual hull overstates a plate's thickness where no view sees it edge-on, and a sheet hides what is
behind it as well as a slab does), along it it spans the voxels' 1st to 99th percentiles less a voxel each
side, so that the plate's own edges stay in front of it and drawn.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from ...strokes.model import SuperquadricSet
from ...strokes.superquadric import matrix_to_quaternion

#: A thin part is a plate when its second-largest spread is at least this many times its thinnest.
FLATNESS = 3.0
#: ... and when it is at least this many times as wide as the thin parts' threshold width (``2 · radius``
#: voxels): a strip barely wider than a leg hides nothing a curve along it does not draw.
BREADTH = 2.0
#: ε of the boxes: square-edged, as a plate is (its corners hide what a rounded one would show).
BOX_SHAPE = (0.2, 0.2)
#: A voxel is in a sheet where its neighbourhood's second-largest variance is this many times its smallest
#: (spreads 2 : 1; :func:`planar`).
LOCAL_FLATNESS = 4.0
#: Smallest plate: this share of the whole volume's voxels (a sliver the carving leaves on a box's face, 0.2 % of
#: the procedural parcel, is none; Cheburashka's ears are 6 % each, the chair's back 25 %), and at least
#: :data:`MIN_VOXELS` working-grid voxels.
MIN_SHARE = 0.01
MIN_VOXELS = 24


def planar(thin: np.ndarray, radius: int) -> np.ndarray:
    """The voxels of ``thin`` where it is locally a sheet: the second moments of its voxels within a Gaussian
    window of ``2 · radius`` voxels spread at least :data:`LOCAL_FLATNESS` times as far along the window's
    second axis as across it, and at least ``radius`` voxels (a leg's cross-section spreads less). Where a
    sheet and rods meet (a chair's back and its legs, one thin part) this keeps the sheet and drops the rods."""
    f = thin.astype(np.float64)
    blur = lambda a: ndimage.gaussian_filter(a, 2.0 * radius)  # noqa: E731
    mass = blur(f) + 1e-9
    at = np.indices(thin.shape, dtype=np.float64)
    mean = [blur(f * at[i]) / mass for i in range(3)]
    cov = np.empty((int(thin.sum()), 3, 3))
    for i in range(3):
        for j in range(i, 3):
            cov[:, i, j] = cov[:, j, i] = (blur(f * at[i] * at[j]) / mass - mean[i] * mean[j])[thin]
    lam = np.linalg.eigvalsh(cov)  # ascending
    out = np.zeros_like(thin)
    out[thin] = (lam[:, 1] >= LOCAL_FLATNESS * lam[:, 0]) & (lam[:, 1] >= float(radius) ** 2)
    return out


def thin_plates(thin: np.ndarray, origin: np.ndarray, voxel: float, axes: np.ndarray, radius: int,
                limit: int, volume: int | None = None) -> SuperquadricSet:
    """Flat boxes over the plate-like pieces of ``thin`` (``bool (X, Y, Z)``: the volume's thin part on a grid
    whose voxel ``(i, j, k)`` is centred at ``origin + (i, j, k)·voxel @ axes``; ``radius`` voxels: half the
    thin parts' threshold width; ``volume``: the whole volume's voxels, ``thin``'s when not given), the largest
    first, at most ``limit``; none drawn (occluders only)."""
    smallest = max(MIN_VOXELS, MIN_SHARE * (int(thin.sum()) if volume is None else volume))
    labels, n = ndimage.label(planar(thin, radius), structure=np.ones((3, 3, 3), bool))
    if n == 0 or limit <= 0:
        return SuperquadricSet()
    sizes = np.bincount(labels.ravel())[1:]
    rows = []
    for part in np.argsort(-sizes)[:4 * limit] + 1:
        if sizes[part - 1] < smallest:
            break
        pts = origin + (np.argwhere(labels == part) * voxel) @ axes
        centre = pts.mean(axis=0)
        spread, frame = np.linalg.eigh(np.cov((pts - centre).T) + 1e-12 * np.eye(3))  # ascending
        sigma = np.sqrt(np.maximum(spread, 0.0))
        if sigma[1] < FLATNESS * sigma[0] or 2 * np.sqrt(3) * sigma[1] < BREADTH * 2 * radius * voxel:
            continue  # a rod (a leg, a cable) or a lump: no plate
        frame = frame[:, ::-1]  # broadest axis first, the thin one as z
        if np.linalg.det(frame) < 0:
            frame[:, 2] = -frame[:, 2]
        local = (pts - centre) @ frame
        lo, hi = np.percentile(local, [1, 99], axis=0)
        centre = centre + frame @ (0.5 * (lo + hi))
        half = np.maximum(0.5 * (hi - lo) - voxel, 0.5 * voxel)  # inside the plate's own edges (module doc)
        half[2] = 0.5 * voxel  # a voxel thick, through the plate's middle
        rows.append((half, matrix_to_quaternion(frame), centre))
        if len(rows) == limit:
            break
    if not rows:
        return SuperquadricSet()
    m = len(rows)
    return SuperquadricSet(np.array([r[0] for r in rows]), np.tile(BOX_SHAPE, (m, 1)), np.array([r[1] for r in rows]),
                           np.array([r[2] for r in rows]), outline=np.zeros(m, bool))
