"""The compact file's size: the curves that tell least are left out until the file fits ``--max-bytes``.

The choice of strokes (:mod:`.discovery.discover`) stops on what a stroke adds, not on bytes: where the
superquadrics draw little of an object's outline, outline strokes are chosen past the level's budget until
80 % of it is drawn, and a busy object (a skull: its sockets, nose, cranial cut, a jaw in pieces) can end
over the size the compact file promises. Then the file is cut to size the way a person would thin a
sketch: the stroke whose loss the drawing would miss least goes first. What a curve tells is the ink it puts
on the training views' lines (within a pixel) that no other stroke puts there — no other curve, no
superquadric's outline — pooled over the views that judge the fit; the curve with the least is left out, the others
recounted (what it shared with one other curve is that curve's alone now), until the file fits. A closed
chain of curves (a hollow's ring, an eye) goes whole or not at all: a ring with a piece missing is no longer
the thing it drew (the skull's `high` lost a socket's ring that way).
"""

from __future__ import annotations

from typing import Callable

import numpy as np
from scipy import ndimage

from ..arrays import ink_box
from ..cameras import Camera
from ..exporters.raster import ink_paths
from ..strokes.model import CurveSet, SceneFrame, StrokeSet, SuperquadricSet, Voxels


def closed_chains(control: np.ndarray, tolerance: float) -> np.ndarray:
    """``int (N,)``: a label per cubic of ``control`` ``(N, 4, 3)``: the cubics of a closed chain (consecutive,
    each starting within ``tolerance`` of where the one before ends, the last ending at the first's start) share
    one; every other cubic has its own."""
    N = len(control)
    labels = np.arange(N)
    start = 0
    for i in range(1, N + 1):
        if i < N and np.linalg.norm(control[i, 0] - control[i - 1, 3]) <= tolerance:
            continue
        if i - start > 1 and np.linalg.norm(control[start, 0] - control[i - 1, 3]) <= tolerance:
            labels[start:i] = start
        start = i
    return labels


def telling_ink(curves: CurveSet, sq: SuperquadricSet, frame: SceneFrame, cameras: list[Camera],
                lines: list[np.ndarray], occluder: Voxels | None = None, units: np.ndarray | None = None
                ) -> tuple[list[list[np.ndarray]], list[np.ndarray]]:
    """Each unit's ink on the views' lines, and how many units ink each line pixel.

    Args:
        curves, sq, frame, occluder: the drawing (superquadrics' outlines drawn, hidden parts left out).
        cameras, lines: views and their line maps ``bool (H, W)``.
        units: ``int (N,)`` which unit each curve belongs to (``0 … U−1``; :func:`closed_chains`, renumbered);
            ``None``: each curve is one.

    Returns:
        ``ink[v][u]``: flat pixel indices of view ``v``'s line pixels within a pixel of unit ``u``'s ink, and
        ``count[v]`` ``(H·W,)``: how many units ink each pixel there, a large number where a superquadric's
        outline does (never any unit's alone).
    """
    from ..exporters.drawing import DrawOptions, curve_of, draw_many

    units = np.arange(len(curves)) if units is None else np.asarray(units)
    n_units = int(units.max()) + 1 if len(units) else 0
    opts = DrawOptions(hidden="hide", silhouette_grid=(32, 64), tolerance=0.5, min_mark=0.0)
    drawings = draw_many(StrokeSet(frame, curves, sq, occluder=occluder), cameras, opts)
    ink, count = [], []
    for cam, drawing, lm in zip(cameras, drawings, lines):
        shape = (cam.height, cam.width)
        per = [np.zeros(shape, bool) for _ in range(n_units)]
        outline = np.zeros(shape, bool)
        for op in drawing.paths:
            if op.layer == "hidden":
                continue
            owner = curve_of(op.id)
            ink_paths(outline if owner is None else per[units[owner]], [op])
        near = [_near_lines(img, lm) for img in per]
        n = np.zeros(shape[0] * shape[1], np.int64)
        for pix in near:
            n[pix] += 1
        n[np.flatnonzero(ndimage.binary_dilation(outline) & lm)] += n_units + 1
        ink.append(near)
        count.append(n)
    return ink, count


def _near_lines(ink: np.ndarray, lines: np.ndarray) -> np.ndarray:
    """Flat indices of ``lines`` pixels within a pixel of ``ink`` (``binary_dilation(ink) & lines``), found on
    the ink's box."""
    box = ink_box(ink)
    if box is None:
        return np.zeros(0, np.int64)
    ys, xs = np.nonzero(ndimage.binary_dilation(ink[box]) & lines[box])
    return (ys + box[0].start) * ink.shape[1] + xs + box[1].start


def least_telling_first(ink: list[list[np.ndarray]], count: list[np.ndarray], fits: Callable[[np.ndarray], bool]
                        ) -> np.ndarray:
    """``bool (U,)`` the units kept: the one with the least ink no other stroke shares is left out, the counts
    updated, until ``fits(keep)`` (see the module docstring). Pure in its arguments (``count`` is copied)."""
    N = len(ink[0]) if ink else 0
    keep = np.ones(N, bool)
    count = [c.copy() for c in count]
    while keep.any() and not fits(keep):
        alone = np.array([sum(int((c[pix[i]] == 1).sum()) for pix, c in zip(ink, count)) if keep[i] else np.inf
                          for i in range(N)], float)
        worst = int(np.argmin(alone))
        keep[worst] = False
        for pix, c in zip(ink, count):
            c[pix[worst]] -= 1
    return keep


def within_bytes(curves: CurveSet, size_of: Callable[[CurveSet], int], max_bytes: int, sq: SuperquadricSet,
                 frame: SceneFrame, cameras: list[Camera], lines: list[np.ndarray], occluder: Voxels | None = None
                 ) -> CurveSet:
    """``curves`` thinned until ``size_of`` the file with them is at most ``max_bytes`` (unchanged when it is
    already; every curve left out when even the superquadrics alone are larger). ``cameras``, ``lines``: the
    training views in which the ink is counted (the fit's judging views: 24, evenly spread) and their line maps."""
    if size_of(curves) <= max_bytes or not len(curves):
        return curves
    _, units = np.unique(closed_chains(curves.control_points, 1e-6 * frame.radius), return_inverse=True)
    ink, count = telling_ink(curves, sq, frame, cameras, lines, occluder, units)
    kept = least_telling_first(ink, count, lambda keep: size_of(curves.subset(keep[units])) <= max_bytes)
    return curves.subset(kept[units])
