"""Stage 3, discover: the curves the fit starts from.

With masks, stroke discovery (:mod:`doodle.fit.discovery`) traces candidate cubics from the views' multi-view
edge evidence on the carving's grid and chooses the strong ones, whose share of the outline decides whether
superquadrics are wanted beside the hull's outline; the final choice comes after the superquadrics
(:func:`choose_beside`, in the curves stage), once their outlines are known. Where the views see curves
inside the hull, the occluder is cleared there. Without discovery (``--no-discover``, no masks), short
curves are placed at farthest points of the SfM points or of the hull, for the gradient stage.
"""

from __future__ import annotations

import numpy as np

from ...exporters.drawing import DrawOptions
from ...strokes.model import CurveSet, SuperquadricSet
from ..config import AUTO_OUTLINE_CURVES
from ..discovery.discover import Candidates, Discovery, choose_curves, find_candidates, outline_pixel_ids
from ..gradient.init import farthest_points, initial_points
from ..gradient.params import initial_curves
from ..state import FitState, Found
from ..volume.hull import clear_seen

NAME = "discover"

#: Gain (share of line pixels) of the strong curves, whose outline coverage decides whether superquadrics
#: are fitted beside the hull's outline.
STRONG_GAIN = 0.002


def candidates(state: FitState) -> Candidates:
    """Discovery's candidates: traced on the carving (once per scene: a second fit of it offers the first
    fit's traces again), or those already at hand."""
    if state.candidates is None:
        cfg = state.config
        carving = state.carving
        state.candidates = find_candidates(
            state.evidence, cfg.evidence_voxels, contours=cfg.contours, texture=cfg.texture,
            hull_outline=cfg.outline_hull, log=state.say, traces=state.shared.get("traces"),
            carving=None if carving is None else (carving.grid, carving.occupied), hollows=cfg.features > 0)
        state.shared["traces"] = state.candidates.traces
    return state.candidates


def run(state: FitState) -> None:
    cfg = state.config
    if not state.plan.discover:
        if cfg.curves != 0 or state.plan.superquadrics in ("fixed", "grow"):  # the abstraction needs no start
            _start_points(state)
        return
    cand = candidates(state)
    if state.occluder is not None and cand.evidence.free is not None:
        state.occluder = clear_seen(state.occluder, cand.evidence.grid, cand.evidence.free)
    strong = choose_curves(cand, cfg.max_curves, max(STRONG_GAIN, cfg.min_gain), polish=False)
    state.found = Found(strong.control_points, strong.normals, strong.contour, strong.outline)


def _start_points(state: FitState) -> None:
    """The gradient path's start: short curves at farthest points of the SfM points, the hull or the box."""
    cfg = state.config
    carving = None if state.carving is None else (state.carving.grid, state.carving.occupied)
    surface, interior, method = initial_points(state.work, cfg.init, state.rng, state.say, carving)
    state.say(f"initialisation: {dict(points='SfM points', hull='visual hull', bbox='random in the bounding box')[method]}"
              f" ({len(surface)} candidate points)")
    n = max(cfg.max_curves, 1)
    start = initial_curves(farthest_points(surface, n, state.rng), 0.15 * state.frame.radius, state.rng)[: cfg.max_curves]
    state.found = Found(start)
    state.interior, state.init_method = interior, method


def choose_beside(state: FitState, sq: SuperquadricSet, polish: bool, log=lambda m: None) -> Discovery:
    """Discovery's choice of curves with ``sq``'s drawn outlines counted as drawn."""
    cfg = state.config
    cand = candidates(state)
    # An outline counts as drawn within 1.5 working pixels (the evidence views are finer). The hull's does
    # not: it gives way to the curves where they draw it, and a crisp edge along the outline draws it better.
    ratio = max(cand.evidence.cameras[0].width / state.work.cameras[0].width, 1.0)
    taken = outline_pixel_ids(cand, sq, state.frame, max(1, round(1.5 * ratio)), state.occluder) \
        if sq.drawn.any() else None
    return choose_curves(cand, cfg.max_curves, cfg.min_gain, taken, polish=polish, outline_curves=cfg.outline_curves,
                         outline_always=cfg.level.outline_always, whole_outline=cfg.whole_outline,
                         most_outline=AUTO_OUTLINE_CURVES, features=cfg.features,
                         over=sq, occluder=state.occluder,
                         occlusion_margin=DrawOptions.occlusion_margin * state.frame.radius,
                         open_features=cfg.level.open_features,
                         min_salience=cfg.level.min_salience, log=log)


def curves_beside(state: FitState, sq: SuperquadricSet) -> tuple[CurveSet, np.ndarray]:
    """The curves chosen beside ``sq``'s outlines, and per curve the judge view it was traced in (or -1)."""
    views = state.judge_views
    judge_of = np.full(len(state.work) + 1, -1)  # a view's place among the judges, -1 if none (and for source -1)
    judge_of[views] = np.arange(len(views))
    found = choose_beside(state, sq, polish=False)
    return CurveSet(found.control_points, state.config.width_px, found.normals, found.contour), judge_of[found.source]
