"""SVG writer (svgwrite): one Inkscape layer per stroke kind, stable ids, metadata, deterministic output."""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np
import svgwrite

from .drawing import LAYERS, Drawing, PathOp

INKSCAPE_NS = "http://www.inkscape.org/namespaces/inkscape"

#: Default look of each layer (the styles package overrides it).
LAYER_STYLE = {
    "silhouettes": {"stroke": "#1a1a1a", "opacity": 1.0, "dash": None},
    "curves": {"stroke": "#1a1a1a", "opacity": 1.0, "dash": None},
    "hidden": {"stroke": "#8c8c8c", "opacity": 1.0, "dash": (4.0, 3.0)},
}


class _Metadata(svgwrite.base.BaseElement):
    """``<metadata>`` holding JSON text (svgwrite has no class for it)."""

    elementname = "metadata"

    def __init__(self, text: str, **extra: Any) -> None:
        super().__init__(**extra)
        self.text = text

    def get_xml(self):  # noqa: D102 - svgwrite API
        xml = super().get_xml()
        xml.text = self.text
        return xml


def digits_for(tolerance: float) -> int:
    """Decimals needed so rounding adds at most a quarter of ``tolerance`` (0.05 px → 2)."""
    return max(0, min(6, math.ceil(-math.log10(tolerance / 4))))


def path_data(op: PathOp, digits: int) -> str:
    """``d`` attribute: ``M x y C ... [Z]`` per subpath, numbers with ``digits`` decimals, trailing zeros cut."""
    def num(v: float) -> str:
        s = f"{v:.{digits}f}".rstrip("0").rstrip(".") if digits else f"{v:.0f}"
        return "0" if s in ("-0", "") else s

    parts = []
    for pieces, closed in zip(op.subpaths, op.closed):
        p0 = pieces[0, 0]
        cmds = [f"M{num(p0[0])} {num(p0[1])}C"]
        cmds.append(" ".join(" ".join(f"{num(x)} {num(y)}" for x, y in seg[1:]) for seg in pieces))
        if closed:
            cmds.append("Z")
        parts.append("".join(cmds))
    return "".join(parts)


def camera_metadata(drawing: Drawing, source: str = "") -> dict[str, Any]:
    cam = drawing.camera
    return {"generator": "doodle", "source": source, "camera": {
        "name": cam.name, "projection": cam.projection, "width": cam.width, "height": cam.height,
        "fx": round(cam.fx, 6), "fy": round(cam.fy, 6), "cx": round(cam.cx, 6), "cy": round(cam.cy, 6),
        "R": np.round(cam.R, 9).tolist(), "t": np.round(cam.t, 9).tolist()}}


def to_svg(drawing: Drawing, tolerance: float = 0.05, source: str = "", background: str | None = None,
           width_px: float | None = None) -> str:
    """The SVG document of a drawing as text (byte-identical for identical input)."""
    cam = drawing.camera
    dwg = svgwrite.Drawing(size=(f"{cam.width}px", f"{cam.height}px"), profile="full", debug=False)
    dwg.viewbox(0, 0, cam.width, cam.height)
    dwg.attribs["xmlns:inkscape"] = INKSCAPE_NS
    dwg.set_desc(title="doodle sketch", desc=f"{cam.name} of {source}" if source else cam.name)
    dwg.add(_Metadata(json.dumps(camera_metadata(drawing, source), sort_keys=True), id="doodle-metadata"))
    if background:
        dwg.add(dwg.rect((0, 0), (cam.width, cam.height), fill=background, id="background"))
    digits = digits_for(tolerance)
    width = width_px if width_px is not None else drawing.width_px
    for layer in LAYERS:
        ops = drawing.layer(layer)
        if not ops:
            continue
        st = LAYER_STYLE[layer]
        g = dwg.g(id=f"layer-{layer}", fill="none", stroke=st["stroke"], stroke_width=f"{width:g}",
                  stroke_linecap="round", stroke_linejoin="round")
        g.attribs["inkscape:groupmode"] = "layer"
        g.attribs["inkscape:label"] = layer
        if st["dash"]:
            g.attribs["stroke-dasharray"] = " ".join(f"{v * width:g}" for v in st["dash"])
        if st["opacity"] != 1.0:
            g.attribs["stroke-opacity"] = f"{st['opacity']:g}"
        for op in ops:
            g.add(dwg.path(d=path_data(op, digits), id=op.id))
        dwg.add(g)
    return dwg.tostring() + "\n"
