"""``doodle export``: draw a stroke set for many cameras into SVG / PNG / PDF files and a contact sheet."""

from __future__ import annotations

import contextlib
import io
import os
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

from PIL import Image

from ..atomic import atomic_folder, atomic_path, check_writable
from ..cameras import Camera, Projection, orbit_cameras, output_size
from ..errors import DoodleError
from ..strokes.model import StrokeSet
from ..styles import Style
from .drawing import DrawOptions, check_camera, draw_many
from .raster import contact_sheet, svg_to_pdf, svg_to_png
from .plotter import PlotterOptions, plotter_svg
from .svg import to_svg
from ..workers import map_chunks


@dataclass
class ExportOptions:
    """What to write for each view."""

    svg: bool = True
    png: bool = False
    pdf: bool = False
    sheet: Path | None = None
    """Also write all views in one grid image here."""
    background: str | None = ""
    """Background: ``""`` = the style's, ``None`` = transparent, or a hex colour."""
    style: Style | None = None
    """Brush style (default: built-in ``ink``)."""
    filters: bool = True
    """Allow SVG filter effects of the style."""
    draw: DrawOptions = field(default_factory=DrawOptions)
    source: str = ""
    workers: int = 0
    """Processes drawing views in parallel; 0 = one per CPU core (at most 8); 1 = draw in this process."""
    plotter: PlotterOptions | None = None
    """Write plotter-ready SVGs instead (:mod:`.plotter`: joined, ordered, on paper; no style, no hidden lines)."""


def _render_views(strokes: StrokeSet, opt: ExportOptions, cams: list[Camera]) -> list[tuple[str, bytes | None, bytes | None]]:
    """SVG text and, as asked, PNG and PDF bytes of some views (runs in worker processes)."""
    out = []
    for drawing in draw_many(strokes, cams, opt.draw):
        if opt.plotter is not None:
            svg = plotter_svg(drawing, opt.plotter, opt.source, opt.draw.tolerance)
        else:
            svg = to_svg(drawing, opt.draw.tolerance, opt.source, opt.background, style=opt.style, filters=opt.filters)
        png = svg_to_png(svg, None) if (opt.png or opt.sheet) else None
        pdf = svg_to_pdf(svg) if opt.pdf else None
        out.append((svg, png, pdf))
    return out


def export_cameras(strokes: StrokeSet, views: int | None = None, scene_dir: str | os.PathLike | None = None,
                   split: str = "test", size: tuple[int, int | None] | None = None,
                   projection: Projection = "perspective") -> list[Camera]:
    """The cameras to draw: an orbit of ``views`` cameras, or the cameras of a dataset's ``split``.

    ``size = (width, height)`` resizes them (height ``None`` keeps the aspect ratio); by default dataset
    cameras keep their photo's size with the long side capped at 1024 px, and orbits take the size recorded
    in the stroke file (the dataset's, capped the same way).
    """
    if scene_dir is not None:
        from ..scenes import load_cameras

        cams = load_cameras(scene_dir, split)
        if projection == "orthographic":
            raise DoodleError("--projection ortho applies to orbits only; dataset cameras are perspective")
        if size:
            return [c.resized(size[0], size[1]) for c in cams]
        return [c.resized(*output_size(c.width, c.height)) for c in cams]
    if views is None or views < 1:
        raise DoodleError(f"--views must be at least 1, got {views}")
    w, h = size if size else (None, None)
    return orbit_cameras(strokes.frame, views, w, h, projection)


def export_views(strokes: StrokeSet, cameras: list[Camera], out_dir: str | os.PathLike,
                 options: ExportOptions | None = None, progress=None) -> list[Path]:
    """Write ``view_000.svg`` … (and PNG/PDF, sheet) for each camera into ``out_dir``.

    Everything is validated and rendered into a sibling temporary folder first, which then replaces
    ``out_dir``'s files in one atomic exchange (see :func:`doodle.atomic.atomic_folder`): on any error or
    kill ``out_dir`` is left as it was. With only a sheet asked for, no folder is touched.

    Returns:
        The written paths.
    """
    opt = options or ExportOptions()
    if strokes.is_empty:
        raise DoodleError("the stroke set is empty: nothing to draw")
    if not cameras:
        raise DoodleError("no cameras to draw")
    if not (opt.svg or opt.png or opt.pdf or opt.sheet):
        raise DoodleError("nothing to write: choose --svg, --png, --pdf or --sheet")
    for cam in cameras:
        check_camera(strokes, cam)
    out = Path(out_dir)
    views = opt.svg or opt.png or opt.pdf
    if opt.sheet is not None:
        check_writable(opt.sheet)
    written: list[Path] = []
    sheet_images: list[Image.Image] = []
    job = partial(_render_views, strokes, opt)
    report = (lambda done: progress(done, len(cameras))) if progress else None
    with contextlib.ExitStack() as stack:
        # views go to a sibling folder that replaces OUT_DIR's files in one step at the end; a sheet alone
        # touches no folder
        tmp = stack.enter_context(atomic_folder(out)) if views else None
        for k, (svg, png, pdf) in enumerate(map_chunks(job, cameras, opt.workers, progress=report)):
            stem = f"view_{k:03d}"
            if opt.svg:
                (tmp / f"{stem}.svg").write_text(svg, encoding="utf-8")
            if png is not None and opt.png:
                (tmp / f"{stem}.png").write_bytes(png)
            if png is not None and opt.sheet:
                sheet_images.append(Image.open(io.BytesIO(png)))
            if pdf is not None:
                (tmp / f"{stem}.pdf").write_bytes(pdf)
        if tmp is not None:
            written = [out / f.name for f in sorted(tmp.iterdir())]
        if opt.sheet:
            # written to its temporary file before the views are swapped in: both land, or neither
            sheet = contact_sheet(sheet_images, labels=[f"{k}" for k in range(len(cameras))])
            sheet_file = stack.enter_context(atomic_path(opt.sheet))
            sheet.save(sheet_file, format="PNG")
            written.append(Path(opt.sheet))
    return written
