"""``--preview DIR``: contact sheets of the strokes while a gradient stage runs (every ``--preview-every`` steps)."""

from __future__ import annotations

import io
from pathlib import Path
from typing import Callable

from ..atomic import atomic_path
from ..strokes.model import CurveSet, SuperquadricSet
from .gradient.params import CurveParams, SuperquadricParams
from .state import FitState


def previewer(state: FitState, tag: str, superquadrics: SuperquadricParams | None = None,
              curves: CurveParams | None = None) -> Callable[[int], None] | None:
    """A callback drawing the current strokes (``superquadrics`` or the state's, ``curves`` or none) on six
    working views into ``preview_dir/TAG_STEP.png``; ``None`` without ``--preview``."""
    cfg = state.config
    if cfg.preview_dir is None:
        return None

    def draw(step: int) -> None:
        from PIL import Image

        from ..exporters import DrawOptions, contact_sheet, draw, svg_to_png, to_svg

        sq = superquadrics.to_set() if superquadrics is not None else (state.superquadrics or SuperquadricSet())
        cs = CurveSet(curves.to_set(cfg.width_px).control_points, cfg.width_px) if curves is not None else CurveSet()
        s = state.stroke_set(cs, sq, state.hull)
        if s.is_empty:
            return
        cams = state.work.cameras[:: max(1, len(state.work.cameras) // 6)][:6]
        ims = [Image.open(io.BytesIO(svg_to_png(to_svg(draw(s, c, DrawOptions(tolerance=0.5)), 0.5)))) for c in cams]
        out = Path(cfg.preview_dir)
        out.mkdir(parents=True, exist_ok=True)
        with atomic_path(out / f"{tag}_{step:05d}.png") as tmp:
            contact_sheet(ims, cell=192).save(tmp, format="PNG")

    return draw
