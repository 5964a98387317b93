"""``doodle view``: one self-contained HTML file to turn a sketch around in a browser, offline.

The page holds a dense grid of the exporter's own drawings (every 5° of azimuth, every 15° of elevation by
default), not a second renderer in JavaScript: each view is exactly what ``doodle export`` draws for that
camera — the same hidden lines, outline cells, hull outline and mark filter — and the grid, packed as
integers and gzip'd into the page, is small: a Lego fit's 648 views are 1.6 MB (2.7 MB with the hull outline). Dragging steps through the grid, the wheel zooms
(the paths are vectors), and the style and hidden-line choices are applied in the page: views are drawn
with hidden parts in their own layer (``hidden="dash"``), which a style shows dashed, solid or not at all.
Plain styles write the exact cubics; the sketchy styles' wobble is redrawn in the page with the same
recipe as :mod:`doodle.styles.render` (seeded differently, so the wobble is not the exporter's to the pixel).
"""

from __future__ import annotations

import base64
import dataclasses
import gzip
import json
import math
import os
import re
import struct
from dataclasses import dataclass
from functools import partial
from html import escape
from importlib import resources
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from ..atomic import check_writable, write_text
from ..cameras import Camera, orbit_cameras
from ..errors import DoodleError
from ..strokes.model import StrokeSet
from ..styles import Style, builtin_names, load_style
from .drawing import LAYERS, DrawOptions, HiddenMode, check_camera, draw_many
from .svg import camera_metadata, digits_for, path_data
from ..workers import map_chunks

#: The page's template: markup, style sheet and script; the data goes where ``DATA_MARK`` is.
TEMPLATE = "web/viewer.html"
DATA_MARK = "/*DOODLE-DATA*/"
TITLE_MARK = "<!--DOODLE-TITLE-->"


@dataclass
class ViewerOptions:
    """The views a viewer page holds and how it opens."""

    azimuths: int = 72
    """Views around the up axis (72: every 5°)."""
    elevations: tuple[float, ...] = (-45.0, -30.0, -15.0, 0.0, 15.0, 30.0, 45.0, 60.0, 75.0)
    """Rows of views, degrees above the horizon (strictly between -90 and 90)."""
    size: int = 512
    """Width and height of every view in pixels."""
    tolerance: float = 0.05
    """Maximum distance in pixels between a drawn cubic and the exact projection."""
    style: Style | None = None
    """The style the page opens with (default ``ink``); the built-in styles are always offered too."""
    hidden: HiddenMode = "hide"
    """The hidden-line mode the page opens with."""
    workers: int = 0
    """Processes drawing views; 0 = one per CPU core (at most 8)."""

    def check(self) -> None:
        if self.azimuths < 1 or self.azimuths > 720:
            raise DoodleError(f"--azimuths must be between 1 and 720, got {self.azimuths}")
        if not self.elevations or len(self.elevations) > 60:
            raise DoodleError(f"give between 1 and 60 elevations, got {len(self.elevations)}")
        bad = [e for e in self.elevations if not (math.isfinite(e) and -90 < e < 90)]
        if bad:
            raise DoodleError(f"elevations must lie strictly between -90 and 90 degrees, got {bad[0]:g}")
        if self.size < 16 or self.size > 4096:
            raise DoodleError(f"--size must be between 16 and 4096 px, got {self.size}")
        if self.hidden not in ("show", "dash", "hide"):
            raise DoodleError(f"hidden mode must be show, dash or hide, got {self.hidden!r}")


def viewer_cameras(strokes: StrokeSet, options: ViewerOptions | None = None) -> list[Camera]:
    """The page's cameras, row by row: ``elevations[e]`` × ``azimuths`` orbit views (index ``e * A + a``)."""
    opt = options or ViewerOptions()
    opt.check()
    cams = []
    for e, el in enumerate(sorted(opt.elevations)):
        for a, cam in enumerate(orbit_cameras(strokes.frame, opt.azimuths, opt.size, opt.size, elevation_deg=el)):
            cams.append(dataclasses.replace(cam, name=f"view_e{e}_a{a:03d}"))
    return cams


def _draw_views(strokes: StrokeSet, draw: DrawOptions, cams: Sequence[Camera]) -> list[list[tuple[int, str, str]]]:
    """Each camera's paths as ``(layer index, id, SVG path data)`` (runs in worker processes)."""
    digits = digits_for(draw.tolerance)
    return [[(LAYERS.index(op.layer), op.id, path_data(op, digits)) for op in drawing.paths]
            for drawing in draw_many(strokes, list(cams), draw)]


_NUMBER = re.compile(r"-?[0-9.]+")


def pack_views(views: list[list[tuple[int, str, str]]], digits: int) -> tuple[list[str], bytes]:
    """The views' paths as an id table and one stream of LEB128 integers: a third smaller than their SVG
    path text once both are gzip'd (Lego: 1.6 MB against 2.3 MB).

    Per view: its number of paths; per path: layer index, id index, number of subpaths; per subpath:
    closed (0/1), number of cubic pieces ``K``, then its ``2 + 6K`` numbers of ``M x y C ...`` as integers
    in units of ``10^-digits`` px, each x (and each y) the zigzag-coded difference from the previous one.
    The integers are read off the path data text itself, so the page writes back the very same text.
    """
    ids: dict[str, int] = {}
    head: list[int] = []
    numbers: list[np.ndarray] = []
    for paths in views:
        head.append(len(paths))
        for layer, pid, d in paths:
            subpaths = d.split("M")[1:]
            head.extend((layer, ids.setdefault(pid, len(ids)), len(subpaths)))
            for sub in subpaths:
                values = np.rint(np.array(_NUMBER.findall(sub), float) * 10.0 ** digits).astype(np.int64)
                head.extend((int(sub.endswith("Z")), (len(values) - 2) // 6))
                xy = values.reshape(-1, 2)
                numbers.append(np.diff(xy, axis=0, prepend=0).ravel())
                head.append(-1 - len(numbers))  # where this subpath's numbers go in the stream
    # interleave the counts with the coordinates in reading order
    stream: list[np.ndarray] = []
    run: list[int] = []
    for value in head:
        if value < 0:
            stream.append(np.array(run, np.int64))
            stream.append(_zigzag(numbers[-value - 2]))
            run = []
        else:
            run.append(value)
    stream.append(np.array(run, np.int64))
    return list(ids), leb128(np.concatenate(stream))


def _zigzag(values: np.ndarray) -> np.ndarray:
    """Signed → unsigned integers, small magnitudes staying small: 0, -1, 1, -2 … → 0, 1, 2, 3 …"""
    return np.where(values < 0, -2 * values - 1, 2 * values)


def leb128(values: np.ndarray) -> bytes:
    """Unsigned integers ``(N,)`` (< 2^35) as LEB128 bytes: 7 bits a byte, high bit set on all but the last."""
    v = np.asarray(values, np.uint64)
    if len(v) and int(v.max()) >= 1 << 35:
        raise ValueError("value too large for the viewer's stream")
    groups = np.stack([(v >> np.uint64(7 * k)) & np.uint64(0x7F) for k in range(5)], axis=1).astype(np.uint8)
    count = np.ones(len(v), np.intp)
    for k in range(1, 5):
        count += v >= np.uint64(1 << (7 * k))
    keep = np.arange(5)[None, :] < count[:, None]
    groups[np.arange(5)[None, :] < (count - 1)[:, None]] |= 0x80
    return groups[keep].tobytes()


def style_dict(style: Style) -> dict[str, Any]:
    """A style as plain JSON data for the page (the same fields as a style file)."""
    return json.loads(json.dumps(dataclasses.asdict(style)))


def viewer_data(strokes: StrokeSet, options: ViewerOptions | None = None, source: str = "",
                progress: Callable[[int, int], None] | None = None) -> tuple[dict[str, Any], bytes]:
    """Everything the page shows: JSON-ready data (cameras, styles, start view, path ids) and the views'
    paths packed by :func:`pack_views`."""
    opt = options or ViewerOptions()
    if strokes.is_empty:
        raise DoodleError("the stroke set is empty: nothing to draw")
    cams = viewer_cameras(strokes, opt)
    for cam in cams:
        check_camera(strokes, cam)
    draw = DrawOptions(tolerance=opt.tolerance, hidden="dash")
    report = (lambda done: progress(done, len(cams))) if progress else None
    views = list(map_chunks(partial(_draw_views, strokes, draw), cams, opt.workers, progress=report))
    ids, stream = pack_views(views, digits_for(draw.tolerance))
    start = opt.style or load_style("ink")
    styles = {name: style_dict(load_style(name)) for name in builtin_names()}
    styles[start.name] = style_dict(start)
    dc = strokes.frame.camera
    elevations = sorted(float(e) for e in opt.elevations)
    return {
        "generator": "doodle", "version": 1, "source": source, "layers": list(LAYERS),
        "width": opt.size, "height": opt.size, "width_px": strokes.curves.width_px,
        "azimuths": [dc.azimuth_deg + 360.0 * a / opt.azimuths for a in range(opt.azimuths)],
        "elevations": elevations,
        "start": [0, min(range(len(elevations)), key=lambda e: abs(elevations[e] - dc.elevation_deg))],
        "style": start.name, "hidden": opt.hidden, "styles": styles,
        "cameras": [camera_metadata_of(cam) for cam in cams],
        "digits": digits_for(draw.tolerance), "ids": ids, "views": len(views),
    }, stream


def camera_metadata_of(camera: Camera) -> dict[str, Any]:
    """The ``camera`` record an exported SVG carries in its metadata (:func:`.svg.camera_metadata`)."""
    from .drawing import Drawing

    return camera_metadata(Drawing(camera, [], 0.0))["camera"]


def viewer_html(strokes: StrokeSet, options: ViewerOptions | None = None, source: str = "",
                progress: Callable[[int, int], None] | None = None) -> str:
    """The viewer page as text: the template with the data gzip'd and base64-encoded in a script element."""
    data, stream = viewer_data(strokes, options, source, progress)
    header = json.dumps(data, separators=(",", ":")).encode()
    # one gzip member: the JSON's length (uint32, little-endian), the JSON, the views' integer stream
    packed = gzip.compress(struct.pack("<I", len(header)) + header + stream, 9, mtime=0)
    template = resources.files("doodle.exporters").joinpath(TEMPLATE).read_text(encoding="utf-8")
    title = escape(f"doodle — {Path(source).name}" if source else "doodle sketch")
    return template.replace(TITLE_MARK, title).replace(DATA_MARK, base64.b64encode(packed).decode("ascii"))


def write_viewer(strokes: StrokeSet, out: str | os.PathLike, options: ViewerOptions | None = None, source: str = "",
                 progress: Callable[[int, int], None] | None = None) -> Path:
    """Write the viewer page to ``out`` atomically (an existing file is replaced only by a complete page)."""
    out = Path(out)
    check_writable(out)
    write_text(out, viewer_html(strokes, options, source, progress))
    return out
