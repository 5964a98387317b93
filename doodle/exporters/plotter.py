"""Plotter- and editor-ready SVG: a view's strokes joined into as few paths as a pen draws, ordered to keep the
pen's travel in the air short, on paper of a physical size.

A drawing holds one path per stroke, cut where the stroke is hidden or ends; strokes that continue each other
on the page (a superquadric's outline and the curve that carries it on, the pieces of one outline either side
of a seam) are separate paths that a plotter lifts its pen between and a designer must select one by one.
:func:`chains` joins pieces whose ends meet within ``join_px`` with tangents turning by at most
``max_turn_deg``, smoothest joints first (the joint is snapped: the next piece starts where the last one
ended; a plotter joins at any turn, its pen need not lift at a corner), drops what is left
shorter than ``min_length_px`` (a pen would dot it), and :func:`plot_order` orders the chains greedily, each
from the end nearest to where the pen is, flipping it when its far end is nearer. Pure numpy and scipy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..strokes.bezier import bezier_points
from .drawing import Drawing, PathOp


@dataclass
class PlotterOptions:
    """``doodle export --plotter``: paper, pen and the joining rule."""

    paper_mm: tuple[float, float] | None = None
    """Paper width and height in millimetres (``None``: the image's size at 96 dpi)."""
    margin_mm: float = 10.0
    pen_mm: float = 0.3
    join_px: float = 1.0
    max_turn_deg: float = 180.0
    """Largest turn at a joint. The pen need not lift at a corner, so a plotter's paths join there too; where
    several pieces meet, the smoothest continuation is taken (:func:`chains` alone keeps 30°: strokes that
    continue each other)."""
    min_length_px: float = 3.0


def _length(pieces: np.ndarray) -> float:
    """Length of a chain of cubic pieces ``(K, 4, 2)``, along 8 chords a piece."""
    pts = bezier_points(pieces, np.linspace(0.0, 1.0, 9))
    return float(np.linalg.norm(np.diff(pts, axis=1), axis=-1).sum())


def _direction(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Unit direction from ``a`` towards ``b`` (or ``c`` where ``b`` coincides with ``a``)."""
    d = b - a
    if np.linalg.norm(d) < 1e-9:
        d = c - a
    n = np.linalg.norm(d)
    return d / n if n > 1e-12 else d


def _reverse(pieces: np.ndarray) -> np.ndarray:
    return pieces[::-1, ::-1].copy()


def chains(drawing: Drawing, layers: tuple[str, ...] = ("silhouettes", "curves"), join_px: float = 1.0,
           max_turn_deg: float = 30.0, min_length_px: float = 3.0) -> list[np.ndarray]:
    """The drawing's subpaths in ``layers`` joined into chains ``(K, 4, 2)`` (see the module doc).

    Joints are taken smoothest first over the whole view, each end at most once: where a straight
    continuation and a corner meet at one end, the continuation wins whichever piece is longer. Pieces that
    close a loop are joined round it.
    """
    from scipy.spatial import cKDTree

    pieces = [sp for layer in layers for op in drawing.layer(layer) for sp in op.subpaths if len(sp)]
    n = len(pieces)
    if n == 0:
        return []
    # end 2i is piece i's start, 2i + 1 its end; ``away`` the unit tangent leaving the piece there
    ends = np.array([e for p in pieces for e in (p[0, 0], p[-1, 3])])
    away = np.array([d for p in pieces for d in (_direction(p[0, 0], p[0, 0] - (p[0, 1] - p[0, 0]), p[0, 0] - (p[0, 2] - p[0, 0])),
                                                   _direction(p[-1, 3], p[-1, 3] + (p[-1, 3] - p[-1, 2]),
                                                              p[-1, 3] + (p[-1, 3] - p[-1, 1])))])
    pairs = cKDTree(ends).query_pairs(join_px, output_type="ndarray")
    pairs = pairs[pairs[:, 0] // 2 != pairs[:, 1] // 2]
    # leaving one piece and entering the other: the turn's cosine (1: straight on)
    cos = -np.einsum("pk,pk->p", away[pairs[:, 0]], away[pairs[:, 1]])
    ok = cos >= math.cos(math.radians(max_turn_deg)) - 1e-9
    pairs, cos = pairs[ok], cos[ok]
    gap = np.linalg.norm(ends[pairs[:, 0]] - ends[pairs[:, 1]], axis=1)
    partner = np.full(2 * n, -1)
    for a, b in pairs[np.lexsort((gap, -cos))]:
        if partner[a] < 0 and partner[b] < 0:  # two free ends of one chain close its loop
            partner[a], partner[b] = b, a

    used = np.zeros(n, bool)

    def walk(enter: int) -> np.ndarray:
        """The chain entered at end ``enter``, followed until a free end or back round its loop."""
        out: list[np.ndarray] = []
        while enter >= 0 and not used[enter // 2]:
            i = enter // 2
            used[i] = True
            piece = pieces[i] if enter % 2 == 0 else _reverse(pieces[i])
            if out:
                piece = piece.copy()
                piece[0, 0] = out[-1][-1, 3]  # snap the joint
            out.append(piece)
            enter = partner[enter ^ 1]
        return np.concatenate(out)

    starts = [e for e in range(2 * n) if partner[e] < 0] + list(range(0, 2 * n, 2))  # open chains, then loops
    out = []
    for e in starts:
        if not used[e // 2]:
            joined = walk(e)
            if _length(joined) >= min_length_px:
                out.append(joined)
    return out


def plot_order(paths: list[np.ndarray], start: tuple[float, float] = (0.0, 0.0)) -> list[np.ndarray]:
    """``paths`` ordered greedily by the pen's travel in the air, each flipped when its far end is nearer."""
    left = list(range(len(paths)))
    at = np.asarray(start, float)
    out = []
    while left:
        d0 = [np.linalg.norm(paths[i][0, 0] - at) for i in left]
        d1 = [np.linalg.norm(paths[i][-1, 3] - at) for i in left]
        k = int(np.argmin(np.minimum(d0, d1)))
        i = left.pop(k)
        p = paths[i] if d0[k] <= d1[k] else _reverse(paths[i])
        out.append(p)
        at = p[-1, 3]
    return out


def pen_up_travel(paths: list[np.ndarray], start: tuple[float, float] = (0.0, 0.0)) -> float:
    """Distance the pen travels in the air, from ``start`` through ``paths`` in their order (pixels)."""
    at, total = np.asarray(start, float), 0.0
    for p in paths:
        total += float(np.linalg.norm(p[0, 0] - at))
        at = p[-1, 3]
    return total


def plotter_svg(drawing: Drawing, options: PlotterOptions | None = None, source: str = "",
                tolerance: float = 0.05) -> str:
    """One black, unfilled path per chain, in plotting order, on paper of ``options.paper_mm`` (the drawing
    fitted inside the margins, centred), in one Inkscape layer ``plot``; hidden lines are left out."""
    import json

    import svgwrite

    from .svg import INKSCAPE_NS, _Metadata, camera_metadata, digits_for, path_data

    opt = options or PlotterOptions()
    cam = drawing.camera
    paths = plot_order(chains(drawing, join_px=opt.join_px, max_turn_deg=opt.max_turn_deg,
                              min_length_px=opt.min_length_px))
    px_mm = 25.4 / 96.0
    W, H = opt.paper_mm or (cam.width * px_mm, cam.height * px_mm)
    m = opt.margin_mm if opt.paper_mm else 0.0
    scale = min((W - 2 * m) / cam.width, (H - 2 * m) / cam.height)  # mm per pixel
    ox, oy = (W - scale * cam.width) / 2, (H - scale * cam.height) / 2
    dwg = svgwrite.Drawing(size=(f"{W:g}mm", f"{H:g}mm"), profile="full", debug=False)
    dwg.viewbox(0, 0, W, H)
    dwg.attribs["xmlns:inkscape"] = INKSCAPE_NS
    meta = {**camera_metadata(drawing, source), "plotter": {"paths": len(paths), "pen_up_px": round(pen_up_travel(paths), 1),
                                                             "mm_per_px": round(scale, 6)}}
    dwg.add(_Metadata(json.dumps(meta, sort_keys=True), id="doodle-metadata"))
    g = dwg.g(id="layer-plot", fill="none", stroke="black", **{"stroke-width": f"{opt.pen_mm:g}",
                                                               "stroke-linecap": "round", "stroke-linejoin": "round"})
    g.attribs["inkscape:groupmode"] = "layer"
    g.attribs["inkscape:label"] = "plot"
    # coordinates in millimetres on the paper (no transform: a transform would scale the pen's width too)
    digits = digits_for(tolerance * scale)
    offset = np.array([ox, oy])
    for k, p in enumerate(paths):
        g.add(dwg.path(d=path_data(PathOp(f"stroke-{k:03d}", "plot", [p * scale + offset], [False]), digits),
                       id=f"stroke-{k:03d}"))
    dwg.add(g)
    return dwg.tostring() + "\n"
