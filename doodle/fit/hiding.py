"""Which curves may hide themselves: back-face hiding checked against the training views' lines.

A curve's face normals (:mod:`.facing`) hide it where both faces turn away from the camera. They are read
off the visual hull, whose verdict on what a view sees is only as good as the hull: the rim of a thin,
cupped part (an ear, a lamp shade's edge) lies on the outline from both sides, yet its nearby hull normals
all point one way, and the views from behind lose it. The training images know better. Each curve is drawn
in the training views with and without its normals, and the ink the normals hide is sorted: on a line
that the sketch leaves undrawn (what showing it would gain), more than a pixel past the tolerance from any
line (what it would cost), or else beside a drawn line (it would only double that line: a thin plate's far
rim seen edge-on, a leg's back edge) or just past the tolerance (the line drawn a little apart). When the
gain is most of the gain and cost together, the hiding was wrong and the curve keeps zero normals (never
hidden by facing; the superquadrics still hide it).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy import ndimage

from ..arrays import ink_box
from ..cameras import Camera
from ..strokes.model import CurveSet, SceneFrame, StrokeSet, SuperquadricSet, Voxels
from ..exporters.raster import ink_paths, raster_layer

MIN_HIDDEN_ON_LINES = 0.7
"""A curve's normals are dropped when the ink they hide on undrawn lines is at least this share of that ink
plus the hidden ink off the lines, pooled over the training views. Held-out F: Cheburashka 0.839 → 0.855
(its ears' rims, hidden from behind), lamp 0.840 → 0.864 (its base plate's far edges), the other scenes
within ±0.001; at 0.5 and 0.6 a hex nut's bottom chamfer shows through its top face (ABC-NEF 0.906 → 0.894)."""


def wrongly_hidden(curves: CurveSet, sq: SuperquadricSet, frame: SceneFrame, cameras: list[Camera],
                   lines: list[np.ndarray], min_share: float = MIN_HIDDEN_ON_LINES, tau_px: int = 2,
                   occluder: Voxels | None = None, hull: Voxels | None = None) -> np.ndarray:
    """``bool (N,)``: the curves whose facing hides ink that the views' lines confirm (their normals should
    be zeros).

    Args:
        sq: the superquadrics, which hide curves either way (drawn with them, so only facing is judged), as
            does the ``occluder``; the ``hull``'s outline is drawn with them too (lines it draws are not undrawn).
        cameras, lines: training views and their line maps ``bool (H, W)``: the mask's outline and the image's
            strong edges (:func:`.evidence.object_lines` with ``thin=0``). Not thin parts' axes: a thin part's
            hidden edges lie beside its axis as closely as its visible ones (the chair's legs).
        min_share: see :data:`MIN_HIDDEN_ON_LINES`.
    """
    features = curves.gates == 0  # a contour curve's normal decides where it is an outline, not what it hides
    if curves.normals is None or not np.any(curves.normals[features]):
        return np.zeros(len(curves), bool)
    from ..exporters.drawing import DrawOptions, curve_of, draw_many

    opts = DrawOptions(hidden="hide", silhouette_grid=(32, 64), tolerance=0.5, min_mark=0.0)
    drawings = draw_many(StrokeSet(frame, curves, sq, occluder=occluder, hull=hull), cameras, opts)
    facing = raster_layer(drawings, cameras, "curves", curve_of)
    # the curves again without normals; the outlines are the same, so they are not drawn twice
    plain_normals = curves.normals.copy()
    plain_normals[features] = 0.0
    plain = raster_layer(draw_many(StrokeSet(frame, replace(curves, normals=plain_normals), sq, occluder=occluder), cameras,
                                   replace(opts, silhouettes=False)), cameras, "curves", curve_of)
    gain, cost = np.zeros(len(curves)), np.zeros(len(curves))
    for cam, d, with_normals, without, lm in zip(cameras, drawings, facing, plain, lines):
        # Ink on a line the sketch leaves undrawn is what showing the curve gains; ink off the lines (more
        # than a pixel past the tolerance) is what it costs. Ink beside a drawn line (a thin plate's far rim
        # in an edge-on view, a leg's back edge) only doubles that line, and ink a pixel past the tolerance
        # is the line drawn a little apart (a hull-based curve is that accurate): neither counts.
        shown = ink_paths(np.zeros((cam.height, cam.width), bool), [*d.layer("curves"), *d.layer("silhouettes")])
        undrawn = ndimage.binary_dilation(lm & ~ndimage.binary_dilation(shown, iterations=tau_px), iterations=tau_px)
        off = ~ndimage.binary_dilation(lm, iterations=tau_px + 1)
        for i, img in without.items():
            mine = with_normals.get(i)
            box = ink_box(img)  # counted on the ink's box, a pixel wider for the dilation
            if box is None:
                continue
            # ink the normals hide; a pixel beside the shown ink is the same stroke, redrawn a little apart
            extra = img[box] if mine is None else img[box] & ~ndimage.binary_dilation(mine[box])
            gain[i] += (extra & undrawn[box]).sum()
            cost[i] += (extra & off[box]).sum()
    return features & (gain > 0) & (gain >= min_share * (gain + cost))
