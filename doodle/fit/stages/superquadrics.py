"""Stage 4, superquadrics: the view-dependent outline's primitives, and which of them draw it.

Three ways to fit them, chosen in ``prepare`` (:class:`~doodle.fit.state.Plan`):

- ``abstract`` (the compact default): fitted to the carved volume in 3D (:mod:`doodle.fit.volume.abstraction`).
  It needs only the volume, so the pipeline starts it (:func:`begin`) in a thread beside discovery
  (:mod:`doodle.fit.beside`) and this stage takes its result: on two cores the skull's fit 67–77 → 57–62 s,
  bit for bit the same strokes.
- ``grow``: grown against the silhouettes one move at a time (:mod:`doodle.fit.gradient.grow`) — beside the
  hull's outline when the discovered curves leave too much of the outline undrawn, or without discovery
  unless the images' lines are mostly long straight edges.
- ``fixed``: a given number, started at farthest points inside the object and fitted to the silhouettes.

Then each one's outline is judged on the working views: drawn, or only hiding what lies behind it
(:func:`~doodle.fit.volume.outlines.abstraction_outlines` for the abstraction,
:func:`~doodle.fit.volume.outlines.keep_outlines` for the others, which weighs each outline against the
curves discovery would choose beside it). A gradient stage interrupted here leaves no superquadrics: the
pipeline writes what the finished stages give.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ...strokes.model import CurveSet, SuperquadricSet
from ..gradient.grow import grow_superquadrics
from ..gradient.init import farthest_points
from ..gradient.objectives import make_objective
from ..gradient.optimize import run_stage
from ..gradient.params import SuperquadricParams, initial_superquadrics
from ..gradient.targets import build_targets, straightness
from ..state import FitState
from ..gradient.silhouettes import silhouette_iou
from .discover import curves_beside

NAME = "superquadrics"


def run(state: FitState) -> None:
    cfg, plan, say = state.config, state.plan, state.say
    mode = plan.superquadrics
    if not _wanted(state):
        state.superquadrics = SuperquadricSet()
        return
    sq_scene, interior = state.work, state.interior
    if plan.discover and mode in ("grow", "fixed"):
        from ..volume.hull import thick_volume

        volume = thick_volume(state.work, state.carving.grid, state.carving.occupied, cfg.thin)
        interior, sq_scene = volume.interior, replace(state.work, masks=volume.masks)
        say(f"superquadrics: {volume.thin_share:.0%} of the mask pixels are thin parts, left to curves")
        if len(interior) < 10:
            say("superquadrics: no thick part; curves only")
            state.superquadrics = SuperquadricSet()
            return
    if mode == "abstract":
        if state.abstraction is None:  # not started beside discovery (a fit resumed after it)
            begin(state)
        found = state.abstraction.result(say)
        state.abstraction = None
        sq = SuperquadricParams.from_set(found.superquadrics).to_set()  # as the gradient paths store them (float32)
        plain = None if found.plain is None else SuperquadricParams.from_set(found.plain).to_set()
    else:
        sq, plain = _fit_to_silhouettes(state, sq_scene, interior), None
    if cfg.superquadrics == "auto" and (plan.discover or mode == "abstract"):
        sq = _judge_outlines(state, sq, plain)
        state.judged = True
        room = cfg.sq_limit - len(sq)
        if mode == "abstract" and len(found.plates) and room > 0:  # judged with the curves (useful_occluders)
            plates = found.plates.subset(np.arange(min(len(found.plates), room)))
            sq = sq.and_occluders(SuperquadricParams.from_set(plates).to_set())
            say(f"superquadrics: {len(plates)} thin plate{'s' * (len(plates) > 1)} (a chair's back, an ear) "
                "offered as occluders")
    elif plain is not None:  # not judged: kept plain (a deformation is kept only where it draws better)
        sq = plain
    state.superquadrics = sq
    say(f"superquadrics: {len(sq)}, {int(sq.drawn.sum())} drawn (training silhouette IoU "
        f"{silhouette_iou(sq, sq_scene.cameras, sq_scene.masks):.3f})")


def begin(state: FitState) -> None:
    """Start the volume's abstraction in a thread (:class:`~doodle.fit.beside.Beside`) when this stage will
    want it: it needs only the carved volume, so it runs beside discovery; :func:`run` takes its result."""
    if state.plan.superquadrics != "abstract" or state.carving is None or state.abstraction is not None:
        return
    from ..beside import Beside
    from ..volume.abstraction import abstract_volume

    cfg, grid, occupied = state.config, state.carving.grid, state.carving.occupied
    state.abstraction = Beside(lambda log: abstract_volume(
        grid.origin, grid.voxel, grid.axes, occupied, cfg.thin, cfg.sq_limit, cfg.level.superquadric_gain,
        steps=cfg.abstraction_steps, seed=cfg.seed, deform=cfg.deform, log=log), NAME)


def cancel(state: FitState) -> None:
    """Stop an abstraction started beside discovery whose result no stage will take (the fit ends before)."""
    if state.abstraction is not None:
        state.abstraction.cancel()
        state.abstraction = None


def _wanted(state: FitState) -> bool:
    """Whether superquadrics are fitted at all (saying why not)."""
    cfg, plan, say = state.config, state.plan, state.say
    if plan.superquadrics == "none":
        return False
    if plan.superquadrics == "grow" and plan.discover:  # beside the hull's outline
        outline = state.found.outline
        if outline >= cfg.outline_coverage:
            say(f"superquadrics: none (the curves draw {outline:.0%} of the outlines)")
            return False
        say(f"superquadrics: fitting up to {cfg.sq_limit} (the curves draw {outline:.0%} of the outlines)")
    elif plan.superquadrics == "grow":
        score = straightness(state.work)
        if score >= cfg.straight_threshold:
            say(f"superquadrics: none ({score:.0%} of the image lines are long straight edges: curves draw them)")
            return False
        say(f"superquadrics: fitting up to {cfg.sq_limit} ({score:.0%} of the image lines are straight)")
    return True


def _fit_to_silhouettes(state: FitState, sq_scene, interior: np.ndarray) -> SuperquadricSet:
    """``grow`` or ``fixed``: Adam on the silhouette objective (:mod:`doodle.fit.gradient`)."""
    from ..preview import previewer

    cfg = state.config
    fixed = state.plan.superquadrics == "fixed"
    params = SuperquadricParams.from_set(initial_superquadrics(
        farthest_points(interior, int(cfg.superquadrics), state.rng), state.frame.radius)) if fixed else None
    targets = build_targets(sq_scene, str(state.device))
    objective = make_objective(cfg.objective)

    def sq_stage(p: SuperquadricParams, steps: int, label: str = "superquadrics") -> bool:
        objective.begin(targets, state.frame, state.gen)
        _, stopped = run_stage(label, p, lambda v: objective.superquadric_terms(p, v), steps, cfg.lr_superquadrics,
                               targets.views, min(4, targets.views), state.gen, None, None, cfg.checkpoint_every,
                               previewer(state, "superquadrics", superquadrics=p), cfg.preview_every, state.progress)
        return stopped

    if fixed:
        params.to(state.device)
        interrupted = sq_stage(params, cfg.sq_iterations)
    else:
        params, interrupted = grow_superquadrics(interior, sq_scene, state.frame, cfg.sq_limit, cfg.sq_iterations,
                                                 sq_stage, state.device, state.say, gen=state.gen)
    if interrupted:  # half-fitted superquadrics are not kept: the finished stages' strokes are written
        raise KeyboardInterrupt
    return params.to_set()


def _judge_outlines(state: FitState, sq: SuperquadricSet, plain: SuperquadricSet | None = None) -> SuperquadricSet:
    """Which superquadrics draw their outline, and (``plain``: the abstraction's plain fits of its tapered and
    bent ones) which stay deformed (see the module doc)."""
    from ..volume.outlines import abstraction_outlines, keep_outlines

    cfg, found = state.config, state.found
    start = found.control_points if found is not None else np.zeros((0, 4, 3))
    contour = found.contour if found is not None else None
    if state.plan.superquadrics == "abstract":
        # The abstraction draws the outline, measured against the crisp feature curves discovery found first
        # (creases, not traces across smooth faces)
        crisp = (contour == 0) if contour is not None else np.ones(len(start), bool)
        if state.plan.discover and crisp.any():
            from ..discovery.texture import on_smooth_faces

            crisp[crisp] = ~on_smooth_faces(start[crisp], state.carving.grid, state.carving.occupied)
        return abstraction_outlines(sq, CurveSet(start[crisp], cfg.width_px), state.frame, *state.judge,
                                    occluder=state.occluder, log=state.say, plain=plain)
    return keep_outlines(sq, CurveSet(start, cfg.width_px, found.normals, contour), state.frame, *state.judge,
                         curves_beside=lambda s: curves_beside(state, s), occluder=state.occluder, hull=state.hull,
                         log=state.say)
