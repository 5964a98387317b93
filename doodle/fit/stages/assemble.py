"""Stage 6, assemble: the stroke set, with the scene's frame and the fit's provenance.

After an interruption it is the best stroke set the finished stages give: the chosen curves and the
superquadrics when the curves stage ran; discovery's strong curves beside the superquadrics (or, when none
draws, the carved hull's outline) when it did not, cut to ``--max-bytes`` as the curves stage cuts them; the
hull's outline alone after the volume stage.
``None`` when no stage finished that draws anything.
"""

from __future__ import annotations

import time

from ...strokes.model import CurveSet, StrokeSet, SuperquadricSet
from ..state import FitState

NAME = "assemble"


def assemble(state: FitState) -> StrokeSet | None:
    cfg = state.config
    sq = state.superquadrics if state.superquadrics is not None else SuperquadricSet()
    hull = state.hull
    curves = state.curves
    if curves is None:  # the curves stage did not finish: what the earlier stages found
        found = state.found if state.discovering else None  # the gradient path's start is not fitted yet
        curves = CurveSet(found.control_points, cfg.width_px, found.normals, found.contour) if found is not None \
            else CurveSet(width_px=cfg.width_px)
        if cfg.max_bytes and not cfg.outline_hull and len(curves):
            # cut as the curves stage would have cut them (discovery's curves over a small --max-bytes were
            # written whole); the hull's outline standing in below is not counted, as the fallback's is not:
            # `--resume` replaces it
            from .curves import within_bytes

            curves = within_bytes(state, curves)
        if not sq.drawn.any() and hull is None and state.carving is not None:
            from ..volume.hull import outline_hull

            hull = outline_hull(state.carving.grid, state.carving.occupied)
    if not len(curves) and not sq.drawn.any() and hull is None:
        return None
    return state.stroke_set(curves, sq, hull, time.perf_counter() - state.started)
