"""SVG writer (svgwrite): one Inkscape layer per stroke kind, stable ids, metadata, deterministic output."""

from __future__ import annotations

import json
import math
import re
from typing import Any

import numpy as np
import svgwrite

from ..styles import Style, load_style, styled_path_data
from ..styles.render import format_number
from .drawing import LAYERS, Drawing, PathOp

INKSCAPE_NS = "http://www.inkscape.org/namespaces/inkscape"


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
        return format_number(v, digits)

    parts = []
    for pieces, closed in zip(op.subpaths, op.closed):
        p0 = pieces[0, 0]
        cmds = [f"M{num(p0[0])} {num(p0[1])}C"]
        cmds.append(" ".join(" ".join(f"{num(x)} {num(y)}" for x, y in seg[1:]) for seg in pieces))
        if closed:
            cmds.append("Z")
        parts.append("".join(cmds))
    return "".join(parts)


_NOT_XML = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\x7f\ud800-\udfff\ufffe\uffff]")


def xml_text(text: str) -> str:
    """``text`` without the characters XML 1.0 forbids (control characters, lone surrogates), which a source
    path or camera name may carry: the SVG must stay well-formed whatever the input was called."""
    return _NOT_XML.sub("\ufffd", text)


def camera_metadata(drawing: Drawing, source: str = "") -> dict[str, Any]:
    cam = drawing.camera
    return {"generator": "doodle", "source": source, "camera": {
        "name": cam.name, "projection": cam.projection, "width": cam.width, "height": cam.height,
        "fx": round(cam.fx, 6), "fy": round(cam.fy, 6), "cx": round(cam.cx, 6), "cy": round(cam.cy, 6),
        "R": np.round(cam.R, 9).tolist(), "t": np.round(cam.t, 9).tolist()}}


def to_svg(drawing: Drawing, tolerance: float = 0.05, source: str = "", background: str | None = "",
           width_px: float | None = None, style: Style | None = None, filters: bool = True) -> str:
    """The SVG document of a drawing as text (byte-identical for identical input).

    Args:
        background: ``""`` uses the style's background, ``None`` or ``"none"`` leaves it transparent, a hex
            colour overrides it.
        style: a :class:`~doodle.styles.Style` (default: built-in ``ink``). Plain styles write the exact
            cubic paths; others write the style's geometry (jitter, passes, tapered outlines).
        filters: allow SVG filter effects (grain); off for tools that ignore filters.
    """
    style = style or load_style("ink")
    cam = drawing.camera
    dwg = svgwrite.Drawing(size=(f"{cam.width}px", f"{cam.height}px"), profile="full", debug=False)
    dwg.viewbox(0, 0, cam.width, cam.height)
    dwg.attribs["xmlns:inkscape"] = INKSCAPE_NS
    dwg.set_desc(title="doodle sketch", desc=xml_text(f"{cam.name} of {source}" if source else cam.name))
    dwg.add(_Metadata(json.dumps({**camera_metadata(drawing, source), "style": style.name}, sort_keys=True),
                      id="doodle-metadata"))
    bg = style.background if background == "" else (background or "none")
    if bg != "none":
        g = _layer(dwg, "background")
        g.add(dwg.rect((0, 0), (cam.width, cam.height), fill=bg, id="background"))
        dwg.add(g)
    grain = filters and style.filter.grain > 0
    if grain:
        f = dwg.defs.add(dwg.filter(id="doodle-grain", x="-5%", y="-5%", width="110%", height="110%"))
        f.feTurbulence(type="fractalNoise", baseFrequency="0.8", numOctaves="2", seed=str(style.seed), result="noise")
        f.feDisplacementMap(in_="SourceGraphic", in2="noise", scale=f"{2.5 * style.filter.grain:g}",
                            xChannelSelector="R", yChannelSelector="G")
    digits = digits_for(tolerance)
    base_width = (width_px if width_px is not None else drawing.width_px) * style.line.width
    ln, hd = style.line, style.hidden
    for layer in LAYERS:
        ops = drawing.layer(layer)
        if not ops:
            continue
        hidden = layer == "hidden"
        width = base_width * (ln.silhouette_width if layer == "silhouettes" else 1.0)
        outline = not hidden and (ln.taper > 0 or ln.width_variation > 0)
        color = hd.color if hidden else ln.color
        g = _layer(dwg, layer)
        if outline:
            g.attribs.update({"fill": color, "stroke": "none"})
        else:
            g.attribs.update({"fill": "none", "stroke": color, "stroke-width": f"{width:g}",
                              "stroke-linecap": ln.linecap, "stroke-linejoin": "round"})
        dash = hd.dash if hidden else ln.dash
        if dash and not outline:
            g.attribs["stroke-dasharray"] = " ".join(f"{v * width:g}" for v in dash)
        opacity = hd.opacity if hidden else ln.opacity
        if opacity != 1.0:
            g.attribs["fill-opacity" if outline else "stroke-opacity"] = f"{opacity:g}"
        if ln.blend != "normal":
            g.attribs["style"] = f"mix-blend-mode:{ln.blend}"
        if grain and not hidden:
            g.attribs["filter"] = "url(#doodle-grain)"
        for op in ops:
            if style.is_plain:
                g.add(dwg.path(d=path_data(op, digits), id=op.id))
                continue
            for k, d in enumerate(styled_path_data(op.subpaths, op.closed, style, op.id, width, outline)):
                g.add(dwg.path(d=d, id=op.id if k == 0 else f"{op.id}-pass{k}"))
        dwg.add(g)
    return dwg.tostring() + "\n"


def _layer(dwg: svgwrite.Drawing, name: str):
    g = dwg.g(id=f"layer-{name}")
    g.attribs["inkscape:groupmode"] = "layer"
    g.attribs["inkscape:label"] = name
    return g
