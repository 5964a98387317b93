"""A sheet with every style drawn on one view (``doodle styles --preview``)."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
from PIL import Image

from ..atomic import atomic_path
from ..cameras import orbit_cameras
from ..strokes import CurveSet, SceneFrame, StrokeSet, SuperquadricSet
from ..styles import builtin_names, load_style
from .drawing import DrawOptions, draw
from .raster import contact_sheet, svg_to_png
from .svg import to_svg


def sample_strokes() -> StrokeSet:
    """A small built-in sketch: a snowman of three superquadrics with a hat brim, arms and a scarf."""
    I = [1.0, 0.0, 0.0, 0.0]
    sq = SuperquadricSet(np.array([[0.5, 0.5, 0.48], [0.36, 0.36, 0.34], [0.25, 0.25, 0.25], [0.2, 0.2, 0.16]]),
                         np.array([[1.0, 1.0], [1.0, 1.0], [1.0, 1.0], [0.15, 1.0]]), np.array([I, I, I, I]),
                         np.array([[0, 0, -0.45], [0, 0, 0.22], [0, 0, 0.72], [0, 0, 1.05]]))
    arm = lambda s: [[0, s * 0.3, 0.3], [0, s * 0.6, 0.38], [0, s * 0.8, 0.52], [0, s * 0.95, 0.62]]
    ring = []
    for k in range(4):  # the scarf: a circle of 4 cubics around the neck
        a0, a1 = k * np.pi / 2, (k + 1) * np.pi / 2
        h = 4 / 3 * np.tan(np.pi / 8) * 0.3
        p0, p3 = np.array([np.cos(a0), np.sin(a0)]) * 0.3, np.array([np.cos(a1), np.sin(a1)]) * 0.3
        t0, t3 = np.array([-np.sin(a0), np.cos(a0)]), np.array([-np.sin(a1), np.cos(a1)])
        ring.append([[*p0, 0.5], [*(p0 + h * t0), 0.5], [*(p3 - h * t3), 0.5], [*p3, 0.5]])
    curves = np.array([arm(1), arm(-1), *ring], dtype=float)
    frame = SceneFrame(radius=1.3)
    frame.camera.distance, frame.camera.elevation_deg = 4.2, 15.0
    return StrokeSet(frame, CurveSet(curves, 1.5), sq)


def preview_sheet(out: str | Path, strokes: StrokeSet | None = None, names: list[str] | None = None,
                  size: int = 320) -> Path:
    """Draw ``strokes`` (default :func:`sample_strokes`) in every style into one labelled sheet."""
    strokes = strokes or sample_strokes()
    names = names or builtin_names()
    cam = orbit_cameras(strokes.frame, 8, size, size)[1]
    styles = [load_style(n) for n in names]
    images = []
    for st in styles:
        d = draw(strokes, cam, DrawOptions(tolerance=0.25, hidden=st.hidden_mode or "hide"))
        images.append(Image.open(io.BytesIO(svg_to_png(to_svg(d, 0.25, style=st)))))
    sheet = contact_sheet(images, columns=min(4, len(images)), cell=size, labels=[st.name for st in styles])
    out = Path(out)
    with atomic_path(out) as tmp:
        sheet.save(tmp, format="PNG")
    return out
