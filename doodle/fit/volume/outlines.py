"""Which superquadrics earn their outline: each must make the sketch better than the curves alone draw it.

A superquadric's contour is a rounded guess; the discovered curves are exact. So an outline is drawn only
where it pays: over the training views, the sketch's F-score (line precision against the images' lines,
recall of the masks' boundary — what ``doodle eval`` measures on held-out views) must rise with it, with the
curves chosen beside it (they leave lines the outline already draws). A smooth part whose rim no curve can
draw wins; a rounded box across a CAD part's sharp edges loses, because the edges it would displace draw the
same outline better. And most of the outline must lie on the object's lines: an ellipsoid across a boxy
part can raise F by covering much of its outline, yet it reads as a blob. The others still hide what lies
behind them (occluders for hidden-line removal), unless they spill out of the silhouettes, where they would
hide lines in plain view. Last, a drawn outline is kept only where the views confirm it
(:func:`confirm_outlines`): on a coarse grid over its surface, the cells whose contour lands on the object's
lines in most of the views that see it.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Callable

import numpy as np
from scipy import ndimage

from ...arrays import silhouette_boundary
from ...cameras import Camera
from ...exporters.raster import ink_paths, raster_layer
from ..gradient.silhouettes import silhouette_pixels
from ...strokes.bezier import bezier_points
from ...strokes.model import OUTLINE_CELLS, CurveSet, SceneFrame, StrokeSet, SuperquadricSet, Voxels

MIN_OUTLINE_GAIN = 0.002
"""A superquadric's outline is drawn when it raises the training views' sketch F by at least this much."""

HALVING_LOSS = 0.015
"""An outline that at least halves the curves beside it is drawn even when the sketch F falls by up to this
much: one exact outline, not a bundle of contour curves from many views that a view between them draws as
dashes. The snowman's head, once strokes on smooth faces count only for the outline (:mod:`.texture`): 17
curves beside its ball at F 0.956 against 43 at 0.962; held out, F 0.973 with the ball and 0.977 without,
where the head read as a ring of ticks."""

MIN_OUTLINE_PRECISION = 0.7
"""...and when at least this share of its own outline lies on the object's lines or outline (within 0.8 % of
the image size). A rounded guess across a boxy part can still raise F by covering much of the outline, but
it reads as a blob: on the Lego photos the ellipsoids across the cab and bucket had 0.47–0.64, while the
outlines that draw smooth parts well had 0.73–1.0 (Cheburashka, the rocker arm, the snowman, the lamp)."""


MIN_CELL_SHARE = 0.5
"""A cell of a superquadric's surface (:data:`~doodle.strokes.model.OUTLINE_CELLS`) keeps its outline when at
least this share of the contour drawn through it, pooled over the views, lies on the object's lines or outline.
Held-out F with it: Cheburashka 0.813 → 0.833, rocker arm 0.815 → 0.819, snowman 0.937 → 0.947; 0.4 trims too
little, 0.6 and 0.7 cost more outline than they gain precision."""


def sketch_score(strokes: StrokeSet, cameras: list[Camera], lines: list[np.ndarray], masks: list[np.ndarray],
                 tau_px: int = 2, traced: np.ndarray | None = None) -> tuple[float, float, float]:
    """``(F, precision, recall)`` of a sketch drawn in ``cameras``, pooled over the views, as ``doodle eval``
    measures it: precision is the share of inked pixels within ``tau_px`` of the views' ``lines``, recall the
    share of the ``masks``' boundary pixels within ``tau_px`` of ink.

    ``traced`` ``(N,)``: per curve, the index into ``cameras`` of the view a contour curve was traced in
    (``-1``: none). It is left out of that view, where it lies on the outline by construction: the score is
    then that of views between the training views, as ``doodle eval`` sees them.
    """
    from ...exporters.drawing import DrawOptions, draw_many

    drawings = draw_many(strokes, cameras,
                         DrawOptions(hidden="hide", silhouette_grid=(32, 64), tolerance=0.5, min_mark=0.0))
    ink = on = rim = reached = 0
    for k, (cam, d, lm, m) in enumerate(zip(cameras, drawings, lines, masks)):
        ops = [*d.layer("curves"), *d.layer("silhouettes")]
        if traced is not None:
            ops = [op for op in ops if not (op.id.startswith("contour-") and traced[int(op.id[8:])] == k)]
        img = ink_paths(np.zeros((cam.height, cam.width), bool), ops)
        boundary = silhouette_boundary(m)
        ink += int(img.sum())
        on += int((img & ndimage.binary_dilation(lm, iterations=tau_px)).sum())
        rim += int(boundary.sum())
        if img.any():
            reached += int((ndimage.binary_dilation(img, iterations=tau_px) & boundary).sum())
    p, r = on / max(ink, 1), reached / max(rim, 1)
    return (2 * p * r / (p + r) if p + r > 0 else 0.0), p, r


def outline_layers(sq: SuperquadricSet, frame: SceneFrame, cameras: list[Camera], occluder: Voxels | None = None
                   ) -> list[dict[int, np.ndarray]]:
    """Per view, each superquadric's own visible outline as drawn alone, ``{index: bool (H, W)}``. Hiding uses
    every superquadric whether drawn or not (and the ``occluder``), so one drawing of all of them, split by
    owner, gives each one's outline."""
    from ...exporters.drawing import DrawOptions, draw_many, superquadric_of

    every = replace(sq, outline=np.ones(len(sq), bool))
    drawings = draw_many(StrokeSet(frame, CurveSet(), every, occluder=occluder), cameras,
                         DrawOptions(curves=False, hidden="hide", silhouette_grid=(32, 64), tolerance=0.5,
                                     min_mark=0.0))
    return raster_layer(drawings, cameras, "silhouettes", superquadric_of)


def outline_precision(sq: SuperquadricSet, frame: SceneFrame, cameras: list[Camera], lines: list[np.ndarray],
                      masks: list[np.ndarray], tau: float = 0.008, occluder: Voxels | None = None,
                      layers: list[dict[int, np.ndarray]] | None = None) -> np.ndarray:
    """Per superquadric, the share of its own visible outline (the others and the ``occluder`` hiding what lies
    behind it) within ``tau`` of the image size (at least a pixel) of the views' ``lines`` or the masks'
    boundary, pooled over ``cameras``. ``layers``: :func:`outline_layers` of the same, when already drawn."""
    if layers is None:
        layers = outline_layers(sq, frame, cameras, occluder)
    on, ink = np.zeros(len(sq)), np.zeros(len(sq))
    for cam, per, lm, m in zip(cameras, layers, lines, masks):
        reach = max(1, round(tau * max(cam.width, cam.height)))
        near = ndimage.binary_dilation(lm | silhouette_boundary(m), iterations=reach)
        for i, img in per.items():
            on[i] += (img & near).sum()
            ink[i] += img.sum()
    return on / np.maximum(ink, 1)


def outline_on_curves(layers: list[dict[int, np.ndarray]], n: int, curves: CurveSet, frame: SceneFrame,
                      cameras: list[Camera], reach_px: int = 2) -> np.ndarray:
    """Per superquadric (``n`` of them, their outlines ``layers`` as :func:`outline_layers` draws them), the
    share of its outline within ``reach_px`` of where ``curves`` are drawn, pooled over ``cameras``: how much
    of it the curves draw."""
    from ...exporters.drawing import DrawOptions, draw_many

    drawn = draw_many(StrokeSet(frame, curves), cameras,
                      DrawOptions(hidden="hide", silhouette_grid=(32, 64), tolerance=0.5, min_mark=0.0))
    on, ink = np.zeros(n), np.zeros(n)
    for cam, per, d in zip(cameras, layers, drawn):
        lines = ink_paths(np.zeros((cam.height, cam.width), bool), [*d.layer("curves"), *d.layer("silhouettes")])
        near = ndimage.binary_dilation(lines, iterations=reach_px) if lines.any() else lines
        for i, img in per.items():
            on[i] += (img & near).sum()
            ink[i] += img.sum()
    return on / np.maximum(ink, 1)


ABSTRACT_MIN_PRECISION = 0.6
"""Beside the abstraction, a superquadric draws its outline when this share of it lies on the object's lines
(the older judge, :func:`keep_outlines`, asks :data:`MIN_OUTLINE_PRECISION`): the views then confirm it cell
by cell, so a rough one (the lamp's shade, a cone no superquadric fits: 63 %) draws where it is right."""

MAX_OUTLINE_ON_CURVES = 0.75
"""Beside the abstraction, a superquadric whose outline the crisp feature curves draw this much of only hides."""
#: A tapered or bent superquadric whose outline lies this much on the object's lines draws it, whatever the
#: crisp curves draw (see ``_drawn``).
DEFORMED_MIN_PRECISION = 0.9
#: Both shape exponents at least this: a superquadric without edges of its own (0.1 is a box's, 1 a ball's).
SMOOTH_SHAPE = 0.5
#: ...and a plain one this round in both profiles, an ellipsoid more than a rounded box, draws its outline on
#: the same terms (see ``_drawn``): Cheburashka's feet, whose outline the traced curves drew as ticks (held-out
#: F 0.907 → 0.923), but not a rounded piece of a hex nut (ε 0.98, 0.59), whose edges the curves draw.
ROUND_SHAPE = 0.75


def abstraction_outlines(sq: SuperquadricSet, crisp: CurveSet, frame: SceneFrame, cameras: list[Camera],
                         lines: list[np.ndarray], masks: list[np.ndarray], occluder: Voxels | None = None,
                         log: Callable[[str], None] = lambda m: None, plain: SuperquadricSet | None = None
                         ) -> SuperquadricSet:
    """Which superquadrics of the abstraction draw their outline (``sq`` with ``outline`` set): every one
    unless it reads as a blob (under :data:`ABSTRACT_MIN_PRECISION` of it on the object's ``lines``), or the
    ``crisp`` feature curves already draw :data:`MAX_OUTLINE_ON_CURVES` of it — a crisp edge beats the rounded
    outline along it (a CAD part's box). The others only hide what lies behind them.

    ``plain`` (row for row, where some of ``sq`` are tapered or bent: their plain fits) makes the judgement
    part by part: a deformed one is kept where it draws its outline and that outline lies on the object's lines
    at least as well as the plain one's, else the plain one takes its place — a deformation is there to draw
    a part (a spout, a shade), and one that draws nothing is only a stranger occluder (a lamp shade's visual
    hull bulges under the shade: a tapered fit of that bulge outlines nothing better)."""
    precision, on_curves = _outline_scores(sq, crisp, frame, cameras, lines, masks, occluder)
    drawn = _drawn(sq, precision, on_curves)
    if plain is not None and sq.deformed.any():
        p_plain, c_plain = _outline_scores(plain, crisp, frame, cameras, lines, masks, occluder)
        drawn_plain = _drawn(plain, p_plain, c_plain)
        keep = ~sq.deformed | (drawn & (~drawn_plain | (precision >= p_plain)))
        for i in np.flatnonzero(sq.deformed):
            log(f"superquadrics: one {'tapered or bent' if keep[i] else 'left plain'} (its outline "
                f"{precision[i]:.0%} on the object's lines, {'drawn' if drawn[i] else 'not drawn'}; plain "
                f"{p_plain[i]:.0%}, {'drawn' if drawn_plain[i] else 'not drawn'})")
        if not keep.all():
            sq = sq.where(keep, plain)
            precision, on_curves = np.where(keep, precision, p_plain), np.where(keep, on_curves, c_plain)
            drawn = np.where(keep, drawn, drawn_plain)
    for i in np.flatnonzero(precision < ABSTRACT_MIN_PRECISION):
        log(f"superquadrics: one hides what is behind it but draws no outline (only {precision[i]:.0%} "
            "of its outline lies on the object's lines)")
    for i in np.flatnonzero((on_curves >= MAX_OUTLINE_ON_CURVES) & (precision >= ABSTRACT_MIN_PRECISION) & ~drawn):
        log(f"superquadrics: one hides what is behind it but draws no outline (the feature curves draw "
            f"{on_curves[i]:.0%} of it)")
    return replace(sq, outline=drawn)


def _drawn(sq: SuperquadricSet, precision: np.ndarray, on_curves: np.ndarray) -> np.ndarray:
    """Whose outline the abstraction draws, from :func:`_outline_scores`: one on the object's lines that the
    crisp curves do not already draw, or a smooth (both ε at least :data:`SMOOTH_SHAPE`), tapered or bent one
    — or a plain one as round as an ellipsoid (:data:`ROUND_SHAPE`) — whose outline lies on the lines almost
    everywhere (:data:`DEFORMED_MIN_PRECISION`): a spout's, a horn's or a foot's closed outline in one piece
    beats the lines traced along its sides, which leave its end open and read as ticks; a box-like one has
    edges of its own that the crisp curves draw better (a lamp's base: F 0.922 → 0.909 when its rounded
    outline replaced them)."""
    drawn = (precision >= ABSTRACT_MIN_PRECISION) & (on_curves < MAX_OUTLINE_ON_CURVES)
    if not len(sq):
        return drawn
    roundness = sq.shape.min(axis=1)
    smooth = np.where(sq.deformed, roundness >= SMOOTH_SHAPE, roundness >= ROUND_SHAPE)
    return drawn | (smooth & (precision >= DEFORMED_MIN_PRECISION))


def _outline_scores(sq: SuperquadricSet, crisp: CurveSet, frame: SceneFrame, cameras: list[Camera],
                    lines: list[np.ndarray], masks: list[np.ndarray], occluder: Voxels | None
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Per superquadric, :func:`outline_precision` and :func:`outline_on_curves` (the ``crisp`` curves)."""
    layers = outline_layers(sq, frame, cameras, occluder)
    precision = outline_precision(sq, frame, cameras, lines, masks, occluder=occluder, layers=layers)
    on_curves = np.zeros(len(sq))
    if len(crisp):
        # measured on the outlines as drawn without the occluder
        plain = layers if occluder is None else outline_layers(sq, frame, cameras)
        on_curves = outline_on_curves(plain, len(sq), crisp, frame, cameras)
    return precision, on_curves


def confirmed_cells(sq: SuperquadricSet, frame: SceneFrame, cameras: list[Camera], lines: list[np.ndarray],
                    masks: list[np.ndarray], tau: float = 0.008, min_share: float = MIN_CELL_SHARE,
                    grid: tuple[int, int] = (32, 64), occluder: Voxels | None = None) -> np.ndarray:
    """``(M, *OUTLINE_CELLS)`` bool: the cells of each superquadric's surface where its contour is confirmed.

    Every superquadric's contour is found in every view (as if all were drawn; each hidden by the others as the
    exporters hide it, with the ``occluder``), and each visible contour vertex votes in its cell: on (within ``tau`` of the image size,
    at least a pixel, of the view's ``lines`` or the mask's boundary) or off. A cell is kept when at least
    ``min_share`` of its votes are on; a cell no view saw is kept.
    """
    from ...exporters.drawing import silhouette_hidden
    from ...exporters.silhouettes import contour_samples

    m, n_cells = len(sq), OUTLINE_CELLS[0] * OUTLINE_CELLS[1]
    on, seen = np.zeros((m, n_cells)), np.zeros((m, n_cells))
    for cam, lm, mask in zip(cameras, lines, masks):
        s = contour_samples(sq, cam, *grid)  # every contour vertex, whatever cells are drawn
        if not s.pieces:
            continue
        owner = s.owner
        uv, z = cam.project(s.points)
        u, v = np.floor(uv[:, 0]).astype(int), np.floor(uv[:, 1]).astype(int)
        H, W = mask.shape
        idx = np.flatnonzero(s.on_union & (z > 1e-3 * frame.radius) & (u >= 0) & (v >= 0) & (u < W) & (v < H))
        if len(idx) == 0:
            continue
        hidden = silhouette_hidden(s.points[idx], s.normals[idx], owner[idx], np.zeros(len(idx), int), [cam], sq,
                                   0.03 * frame.radius, occluder)
        idx = idx[~hidden]
        reach = max(1, round(tau * max(W, H)))
        near = ndimage.binary_dilation(lm | silhouette_boundary(mask), iterations=reach)
        np.add.at(seen, (owner[idx], s.cells[idx]), 1)
        np.add.at(on, (owner[idx], s.cells[idx]), near[v[idx], u[idx]])
    return ((seen == 0) | (on >= min_share * seen)).reshape(m, *OUTLINE_CELLS)


def confirm_outlines(sq: SuperquadricSet, frame: SceneFrame, cameras: list[Camera], lines: list[np.ndarray],
                     masks: list[np.ndarray], occluder: Voxels | None = None) -> SuperquadricSet:
    """``sq`` with its drawn outlines drawn only where the views confirm them (:func:`confirmed_cells`)."""
    if not sq.drawn.any():
        return replace(sq, outline_cells=None)
    cells = confirmed_cells(sq, frame, cameras, lines, masks, occluder=occluder) | ~sq.drawn[:, None, None]
    return replace(sq, outline_cells=None if cells.all() else cells)


def inside_share(sq: SuperquadricSet, cameras: list[Camera], masks: list[np.ndarray], size: int = 96,
                 max_views: int = 12) -> np.ndarray:
    """Per superquadric, the share of its own silhouette that lies inside the (slightly grown) masks."""
    from PIL import Image

    from ...exporters.visibility import union_mask

    step = max(1, len(cameras) // max_views)
    inside, total = np.zeros(len(sq)), np.zeros(len(sq))
    for cam, mask in zip(cameras[::step], masks[::step]):
        c = cam.scaled(size / max(cam.width, cam.height))
        m = np.asarray(Image.fromarray(mask.astype(np.uint8) * 255).resize((c.width, c.height), Image.Resampling.BOX)) > 0
        m = ndimage.binary_dilation(m, iterations=1)
        for i in range(len(sq)):
            u = union_mask(sq.subset(np.array([i])), c, samples=24)
            inside[i] += (u & m).sum()
            total[i] += u.sum()
    return np.where(total > 0, inside / np.maximum(total, 1), 0.0)


def keep_outlines(sq: SuperquadricSet, curves: CurveSet, frame: SceneFrame, cameras: list[Camera],
                  lines: list[np.ndarray], masks: list[np.ndarray], min_inside: float = 0.9,
                  min_gain: float = MIN_OUTLINE_GAIN, min_precision: float = MIN_OUTLINE_PRECISION,
                  curves_beside: Callable[[SuperquadricSet], tuple[CurveSet, np.ndarray]] | None = None,
                  occluder: Voxels | None = None, hull: Voxels | None = None,
                  log: Callable[[str], None] = lambda m: None) -> SuperquadricSet:
    """Decide each superquadric's role (see the module doc): a drawn outline, an occluder only, or dropped.

    A superquadric whose silhouette spills out of the masks (less than ``min_inside`` of it inside) would
    hide lines that are in plain view, so it is dropped. The others are tried as drawn outlines one by one,
    the most promising first (each one's :func:`sketch_score` beside ``curves``); one is drawn when the
    sketch's F over ``cameras`` rises by at least ``min_gain`` with it (or keeps within ``min_gain`` of it with
    fewer curves beside it, or within :data:`HALVING_LOSS` with half of them: the one rule for an outline that
    alone, on top of the curves, lowers F) and at least ``min_precision`` of its
    own outline lies on the object's lines (:func:`outline_precision`). ``curves_beside(sq)`` gives the curves
    that would be chosen beside ``sq``'s drawn outlines (they avoid lines an outline already draws), so an
    outline that only displaces sharp curves gains nothing, with the view each contour curve was traced in
    (``traced`` of :func:`sketch_score`); without it, ``curves`` stay as they are. The ``hull``'s outline is
    drawn in every trial: an outline must add to it.
    """
    if len(sq) == 0:
        return sq
    inside = inside_share(sq, cameras, masks)
    keep = inside >= min_inside
    for i in np.flatnonzero(~keep):
        log(f"superquadrics: dropping one that spills out of the silhouettes ({inside[i]:.0%} inside)")
    sq = sq.subset(keep)
    if len(sq) == 0:
        return sq

    def score(drawn: np.ndarray, beside: tuple[CurveSet, np.ndarray | None]) -> float:
        strokes = StrokeSet(frame, beside[0], sq.subset(drawn), occluder=occluder, hull=hull)
        return sketch_score(strokes, cameras, lines, masks, traced=beside[1])[0]

    precision = outline_precision(sq, frame, cameras, lines, masks, occluder=occluder)
    none = np.zeros(len(sq), bool)
    base = curves_beside(replace(sq, outline=none)) if curves_beside is not None else (curves, None)
    best = without = score(none, base)
    alone = np.array([score(np.eye(len(sq), dtype=bool)[i], base) for i in range(len(sq))])
    drawn, current = none, base
    for i in np.argsort(-alone):
        if precision[i] < min_precision:
            log(f"superquadrics: one hides what is behind it but draws no outline (only {precision[i]:.0%} of its "
                f"outline lies on the object's lines)")
            continue
        # worse on top of the curves chosen without it: only halving the curves beside it can pay for it
        halving_only = alone[i] < without - min_gain
        if alone[i] < without - max(min_gain, HALVING_LOSS):
            log(f"superquadrics: one hides what is behind it but draws no outline (sketch F {alone[i]:.3f} with it, "
                f"{without:.3f} with the curves alone)")
            continue
        trial = drawn.copy()
        trial[i] = True
        beside = curves_beside(replace(sq, outline=trial)) if curves_beside is not None else base
        f = score(trial, beside)
        # As good, with fewer curves: one exact outline instead of the contour curves of many views beside each
        # other (a ball's rim drawn by a circle, not by a bundle of arcs); nearly as good with half of them
        halving = len(beside[0]) <= len(current[0]) / 2 and f >= best - HALVING_LOSS
        simpler = len(beside[0]) < len(current[0]) and f >= best - min_gain
        passes = halving if halving_only else f >= best + min_gain or simpler or halving
        if passes:
            log(f"superquadrics: one draws its outline (sketch F {best:.3f} → {f:.3f}, {len(beside[0])} curves beside "
                f"it instead of {len(current[0])})")
            drawn, best, current = trial, max(f, best), beside
        else:
            log(f"superquadrics: one hides what is behind it but draws no outline (sketch F {f:.3f} with it and "
                f"the curves beside it, {best:.3f} without)")
    return replace(sq, outline=drawn)


def useful_occluders(sq: SuperquadricSet, curves: CurveSet, frame: SceneFrame, cameras: list[Camera],
                     depth: list[np.ndarray], hull_margin: float, occlusion_margin: float = 0.03,
                     samples_per_curve: int = 12) -> SuperquadricSet:
    """Keep the superquadrics that draw an outline, and of the occluder-only ones those that help: on points
    of the curves, over the views, an occluder must agree with the visual hull on what is hidden (``depth``:
    the hull's depth maps of ``cameras``) more often than it disagrees — hiding a visible point counts
    double, hiding one the face normals already hide counts nothing.
    """
    from ...exporters.drawing import back_facing, occlusion_probes, off_contour
    from ...exporters.visibility import occluded
    from .carve import project_points

    if len(sq) == 0 or sq.drawn.all():
        return sq
    if len(curves) == 0:
        return sq.subset(sq.drawn)
    t = np.linspace(0.05, 0.95, samples_per_curve)
    pts = bezier_points(curves.control_points, t).reshape(-1, 3)
    tt = np.tile(t, len(curves))
    normals = np.repeat(curves.normals, samples_per_curve, axis=0) if curves.normals is not None else None
    gates = np.repeat(curves.gates, samples_per_curve)
    rows, views, truth, shown = [], [], [], []
    for v, (cam, zb) in enumerate(zip(cameras, depth)):
        u, w, z = project_points(cam, pts.astype(np.float32))
        ok = (z > 1e-6) & (u >= 0) & (w >= 0) & (u < cam.width) & (w < cam.height)
        idx = np.flatnonzero(ok)
        vis = z[idx] <= zb[w[idx], u[idx]] + hull_margin
        facing = np.ones(len(idx), bool)
        if normals is not None:
            n = len(idx)
            eyes, fwd = np.repeat(cam.center[None], n, 0), np.repeat(cam.forward[None], n, 0)
            ortho = np.full(n, cam.projection == "orthographic")
            facing = ~back_facing(pts[idx], tt[idx], normals[idx], eyes, fwd, ortho)
            facing &= ~off_contour(pts[idx], tt[idx], normals[idx], gates[idx], eyes, fwd, ortho)
        rows.append(idx), views.append(np.full(len(idx), v)), truth.append(vis), shown.append(facing)
    idx, view = np.concatenate(rows), np.concatenate(views)
    truth, shown = np.concatenate(truth), np.concatenate(shown)
    margin = occlusion_margin * frame.radius
    probe = occlusion_probes(pts[idx], tt[idx], None if normals is None else normals[idx], margin)
    keep = sq.drawn.copy()
    for i in np.flatnonzero(~sq.drawn):
        hides = occluded(probe, view, cameras, sq.subset(np.array([i])), margin) & shown
        gain = int((hides & ~truth).sum()) - 2 * int((hides & truth).sum())
        keep[i] = gain > 0
    return sq.subset(keep)


def outline_share(sq: SuperquadricSet, frame: SceneFrame, cameras, masks: list[np.ndarray], reach: int = 2,
                  occluder: Voxels | None = None) -> float:
    """Share of the masks' outline pixels within ``reach`` px of the superquadrics' drawn outlines: how much of
    the object's outline they draw, where no curves are chosen (``--curves 0``)."""
    drawn = silhouette_pixels(sq, frame, cameras, grow_px=reach, occluder=occluder) if sq.drawn.any() else \
        [np.zeros(m.shape, bool) for m in masks]
    rims = [silhouette_boundary(m) for m in masks]
    total = sum(int(r.sum()) for r in rims)
    return sum(int((r & d).sum()) for r, d in zip(rims, drawn)) / max(total, 1)
