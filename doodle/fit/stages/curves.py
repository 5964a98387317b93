"""Stage 5, curves: the final choice of curves beside the superquadrics' outlines, their polish, and from
where each is drawn.

1. **Choice.** With discovery, the curves are chosen again with the drawn outlines counted as drawn (curves
   go where no outline is); superquadrics that only hide are dropped unless they hide more than they wrongly
   hide; an outline that strays once the others are settled is no longer drawn (and the curves chosen
   again); then each drawn outline is kept only where the views confirm it, cell by cell. Without
   discovery, the curves placed by the discover stage.
2. **Polish** (the gradient room's distance-field stage, ``--iterations`` steps: 0 after discovery, whose
   curves are polished on the 3D evidence already; 1500 without it), with the outlines' pixels left out of
   the targets; without discovery, curves off the views' lines are pruned after it.
3. **Hiding.** A discovered curve keeps its face normals (drawn only from where its faces are seen) unless
   the training views show it from where its faces would hide it.
4. **Size.** Past ``--max-bytes`` (2,500 by default), the curves that tell least are left out until the file
   fits (:mod:`..budget`); the hull's outline is never cut.

Ctrl-C in the polish keeps the best curves so far, finishes steps 3 and 4 and the file, and ``--resume`` goes on
with the polish.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Callable

import numpy as np

from ...strokes.model import CurveSet, SuperquadricSet
from ..gradient.objectives import make_objective
from ..gradient.optimize import StageState, run_stage
from ..gradient.params import CurveParams
from ..gradient.targets import build_targets
from ..state import FitState, Found
from ..volume.outlines import ABSTRACT_MIN_PRECISION, MIN_OUTLINE_PRECISION, confirm_outlines, outline_precision
from .discover import candidates, choose_beside

NAME = "curves"


def run(state: FitState) -> None:
    if state.chosen is None:
        choose(state)
        if state.checkpointer is not None:
            state.checkpointer(NAME, 0)
    polish(state)
    # the control points as the gradient stage holds them (float32), polished or not
    control = state.curve_control if state.curve_control is not None else state.chosen.control_points
    curves = CurveSet(np.asarray(control, np.float32).astype(np.float64), state.config.width_px,
                      state.chosen.normals, state.chosen.contour)
    if state.discovering and len(curves) and state.work.masks is not None:
        curves = confirm_hiding(state, curves)
    if state.config.max_bytes and not state.config.outline_hull and len(curves):
        curves = within_bytes(state, curves)
    state.curves = curves


def choose(state: FitState) -> None:
    """Step 1: ``state.chosen`` and the superquadrics as they stay beside them."""
    sq = state.superquadrics if state.superquadrics is not None else SuperquadricSet()
    if state.discovering:
        sq = _finish_discovery(state, sq)
        if state.judged and sq.drawn.any():
            minimum = ABSTRACT_MIN_PRECISION if state.plan.superquadrics == "abstract" else MIN_OUTLINE_PRECISION
            sq = recheck_outlines(sq, state, lambda s: _finish_discovery(state, s), minimum)
    else:
        state.chosen = state.found if state.found is not None else Found(np.zeros((0, 4, 3)))
    if state.judged and sq.drawn.any():
        from ..discovery.evidence import object_lines

        # Last, with the curves chosen: curves picked to fill an outline's gaps came out as ticks (the
        # snowman's nose: 3 curves → 7, held-out F no better). Every view votes (1.4 s for 100 at 256 px).
        w = state.work
        lines = [object_lines(image, mask) for image, mask in zip(w.images, w.masks)]
        sq = confirm_outlines(sq, state.frame, w.cameras, lines, w.masks, state.occluder)
        cells = sq.outline_cells
        if cells is not None:
            state.say(f"superquadrics: outlines drawn where the views confirm them ({int((~cells).sum())} of "
                      f"{cells[sq.drawn].size} surface cells left out)")
    if not state.discovering and state.plan.superquadrics == "abstract":  # --curves 0: the outline is theirs alone
        from ..volume.outlines import outline_share

        cams, _, masks = state.judge
        state.outline_drawn = outline_share(sq, state.frame, cams, masks, occluder=state.occluder)
    state.superquadrics = sq


def _finish_discovery(state: FitState, sq: SuperquadricSet) -> SuperquadricSet:
    """The final choice of curves beside ``sq``'s drawn outlines (into ``state.chosen``), and ``sq`` without the
    superquadrics that only hide and are not worth it."""
    cfg = state.config
    found = choose_beside(state, sq, polish=True, log=state.say)
    state.chosen = Found(found.control_points, found.normals, found.contour)
    state.outline_drawn = found.outline_drawn
    if len(sq) and not sq.drawn.all() and state.occluder is not None:
        state.say(f"superquadrics: {int((~sq.drawn).sum())} that only hide what is behind them dropped (the hull "
                  "occluder does that)")
        return sq.subset(sq.drawn)
    if len(sq) and not sq.drawn.all():
        from ..volume.outlines import useful_occluders

        cand = candidates(state)
        ev = cand.evidence
        kept = useful_occluders(sq, CurveSet(found.control_points, cfg.width_px, found.normals, found.contour),
                                state.frame, [ev.cameras[v] for v in cand.views], [ev.depth[v] for v in cand.views],
                                ev.margin)
        if len(kept) < len(sq):
            state.say(f"superquadrics: {len(sq) - len(kept)} occluder(s) would hide more visible lines than hidden "
                      "ones; dropped")
        return kept
    return sq


def recheck_outlines(sq: SuperquadricSet, state: FitState, finish: Callable[[SuperquadricSet], SuperquadricSet],
                     min_precision: float = MIN_OUTLINE_PRECISION) -> SuperquadricSet:
    """Judge the drawn outlines again among the superquadrics that stay: once occluders that hid parts of an
    outline are dropped, more of it shows (on the Lego photos the cab's ellipsoid went from 75 % of its
    outline on the object's lines to 64 %). One that now strays draws no outline, and ``finish`` chooses the
    curves again."""
    precision = outline_precision(sq, state.frame, *state.judge, occluder=state.occluder)
    stray = sq.drawn & (precision < min_precision)
    if not stray.any():
        return sq
    for i in np.flatnonzero(stray):
        state.say(f"superquadrics: one draws no outline after all (only {precision[i]:.0%} of it lies on the "
                  "object's lines once the other superquadrics are settled)")
    return finish(replace(sq, outline=sq.drawn & ~stray))


def polish(state: FitState) -> None:
    """Step 2: the distance-field stage on the chosen curves (``state.curve_control``), resumable."""
    from ..preview import previewer
    from ..gradient.silhouettes import silhouette_pixels

    cfg = state.config
    steps = cfg.curve_iterations
    start = state.chosen.control_points
    if not len(start) or steps <= 0:
        return
    params = CurveParams(start)
    if state.curve_control is not None and state.curve_control.shape == start.shape:
        params = CurveParams(state.curve_control)
    params.to(state.device)
    sq = state.superquadrics if state.superquadrics is not None else SuperquadricSet()
    exclude = silhouette_pixels(sq, state.frame, state.work.cameras, occluder=state.occluder, hull=state.hull) \
        if len(sq) or state.hull is not None else None
    targets = build_targets(state.work, str(state.device), exclude)
    objective = make_objective(cfg.objective)
    objective.begin(targets, state.frame, state.gen)
    lr = cfg.lr_curves * state.frame.radius * (0.25 if state.discovering else 1.0)  # discovered: polish only

    def save(stage_state: StageState) -> None:
        state.curve_state = stage_state
        state.curve_control = params.to_set(cfg.width_px).control_points
        if state.checkpointer is not None:
            state.checkpointer(NAME, stage_state.step)

    stage_state, interrupted = run_stage(
        "curves", params, lambda v: objective.curve_terms(params, v), steps, lr, targets.views,
        min(cfg.views_per_step, targets.views), state.gen, state.curve_state, save, cfg.checkpoint_every,
        previewer(state, "curves", curves=params), cfg.preview_every, state.progress)
    state.curve_state = stage_state
    state.curve_control = params.to_set(cfg.width_px).control_points
    if interrupted:
        state.interrupted = True
        state.say("interrupted: keeping the best curves so far")
    if cfg.prune_curves and not state.discovering:
        from ..gradient.prune import prune_curves

        n_before = len(start)
        kept, keep = prune_curves(CurveSet(state.curve_control, cfg.width_px), targets, cfg.curve_max_distance_px)
        state.say(f"curves: kept {len(kept)} of {n_before} (the others do not lie on lines across the views)")
        state.curve_control = kept.control_points
        state.chosen = _subset(state.chosen, keep)


def _subset(found: Found, keep: np.ndarray) -> Found:
    return Found(found.control_points[keep], None if found.normals is None else found.normals[keep],
                 None if found.contour is None else found.contour[keep], found.outline)


def within_bytes(state: FitState, curves: CurveSet) -> CurveSet:
    """Step 4: the curves thinned, the least telling first, until the file fits ``--max-bytes`` (:mod:`..budget`)."""
    from ...strokes.binary import encode
    from ..budget import within_bytes as thinned

    cfg = state.config
    sq = state.superquadrics if state.superquadrics is not None else SuperquadricSet()

    def size_of(c: CurveSet) -> int:
        # the provenance's seconds at their widest (a fit under 28 hours): the file written is no larger
        return len(encode(state.stroke_set(c, sq, state.hull, 99999.99)))

    before = size_of(curves)
    if before <= cfg.max_bytes:
        return curves
    if state.work.masks is not None:
        cameras, lines, _ = state.judge
    else:  # no masks: the images' strongest lines over the whole frame
        from ..discovery.evidence import object_lines

        cameras = [state.work.cameras[v] for v in state.judge_views]
        lines = [object_lines(state.work.images[v], None) for v in state.judge_views]
    kept = thinned(curves, size_of, cfg.max_bytes, sq, state.frame, cameras, lines, state.occluder)
    state.say(f"curves: {len(curves) - len(kept)} of {len(curves)} left out, the least telling first, for "
              f"--max-bytes {cfg.max_bytes:,} ({before:,} → {size_of(kept):,} B)")
    return kept


def confirm_hiding(state: FitState, curves: CurveSet) -> CurveSet:
    """Step 3: the curves with facing kept only where the training views do not contradict it (:mod:`..hiding`)."""
    from ..discovery.evidence import object_lines
    from ..hiding import wrongly_hidden

    w = state.work
    views = state.judge_views
    sq = state.superquadrics if state.superquadrics is not None else SuperquadricSet()
    # without thin parts' axes: a thin part's hidden edge lies beside its axis, as near as its visible one
    wrong = wrongly_hidden(curves, sq, state.frame, [w.cameras[v] for v in views],
                           [object_lines(w.images[v], w.masks[v], thin=0) for v in views], occluder=state.occluder,
                           hull=state.hull)
    if not wrong.any():
        return curves
    state.say(f"curves: {int(wrong.sum())} drawn from every side (the views see what their faces would hide)")
    normals = curves.normals.copy()
    normals[wrong] = 0.0
    return replace(curves, normals=normals)
