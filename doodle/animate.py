"""``doodle animate``: a seamless turntable of the 3D sketch as GIF, APNG, MP4 or one animated SVG."""

from __future__ import annotations

import contextlib
import io
import os
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path
from typing import Callable

import numpy as np
from PIL import Image

from .atomic import atomic_path, check_writable
from .cameras import orbit_cameras
from .errors import DoodleError
from .exporters import DrawOptions, draw_many
from .workers import map_chunks
from .exporters.raster import svg_to_png
from .exporters.svg import to_svg
from .strokes.model import StrokeSet
from .styles import Style, load_style

FORMATS = ("gif", "apng", "mp4", "svg")


@dataclass
class AnimateOptions:
    frames: int = 36
    fps: float = 12.0
    size: int = 512
    style: Style | str = "ink"
    elevation_deg: float | None = None
    """Camera elevation (default: the stroke file's)."""
    bob_deg: float = 0.0
    """Amplitude of a gentle up-down motion (one period per loop, so the loop stays seamless)."""
    hidden: str = ""
    """``hide``/``dash``/``show``; ``""`` = the style's preference, else ``hide``."""
    filters: bool = True
    draw: DrawOptions = field(default_factory=lambda: DrawOptions(tolerance=0.25))
    workers: int = 0


def _resolve(opt: AnimateOptions) -> tuple[Style, DrawOptions]:
    style = load_style(opt.style) if isinstance(opt.style, (str, Path)) else opt.style
    hidden = opt.hidden or style.hidden_mode or "hide"
    return style, replace(opt.draw, hidden=hidden)


def _validate(strokes: StrokeSet, opt: AnimateOptions) -> None:
    if opt.frames < 1:
        raise DoodleError(f"--frames must be at least 1, got {opt.frames}")
    if not 0 < opt.fps <= 100:
        raise DoodleError(f"--fps must be in (0, 100], got {opt.fps}")
    if not 16 <= opt.size <= 4096:
        raise DoodleError(f"--size must be in [16, 4096], got {opt.size}")
    if strokes.is_empty:
        raise DoodleError("the stroke set is empty: nothing to animate")


def render_frames(strokes: StrokeSet, opt: AnimateOptions, progress: Callable[[int, int], None] | None = None
                  ) -> tuple[list[str], list[Image.Image]]:
    """SVG text and RGB image of every frame, in order."""
    _validate(strokes, opt)
    style, dopt = _resolve(opt)
    try:
        cams = orbit_cameras(strokes.frame, opt.frames, opt.size, opt.size, elevation_deg=opt.elevation_deg,
                             elevation_bob_deg=opt.bob_deg)
    except ValueError as exc:
        raise DoodleError(str(exc)) from None

    svgs, images = [], []
    job = partial(_render_frames, strokes, style, dopt, opt.filters)
    report = (lambda done: progress(done, len(cams))) if progress else None
    for svg, png in map_chunks(job, cams, opt.workers, progress=report):
        svgs.append(svg)
        with Image.open(io.BytesIO(png)) as im:
            rgba = im.convert("RGBA")
        bg = Image.new("RGBA", rgba.size, style.background if style.background != "none" else "#ffffff")
        images.append(Image.alpha_composite(bg, rgba).convert("RGB"))
    return svgs, images


def _render_frames(strokes: StrokeSet, style: Style, dopt: DrawOptions, filters: bool, cams) -> list[tuple[str, bytes]]:
    out = []
    for drawing in draw_many(strokes, cams, dopt):
        svg = to_svg(drawing, dopt.tolerance, style=style, filters=filters)
        out.append((svg, svg_to_png(svg, None)))
    return out


def format_for(path: Path) -> str:
    ext = path.suffix.lower().lstrip(".")
    return {"gif": "gif", "png": "apng", "apng": "apng", "mp4": "mp4", "svg": "svg"}.get(ext, "")


def animate(strokes: StrokeSet, out: str | os.PathLike, opt: AnimateOptions | None = None, fmt: str | None = None,
            progress: Callable[[int, int], None] | None = None) -> Path:
    """Write a turntable animation; the format comes from ``fmt`` or the file suffix."""
    return animate_many(strokes, {fmt or format_for(Path(out)): Path(out)}, opt, progress)[0]


def animate_many(strokes: StrokeSet, outputs: dict[str, Path], opt: AnimateOptions | None = None,
                 progress: Callable[[int, int], None] | None = None) -> list[Path]:
    """Render the frames once and write each requested format (``gif``, ``apng``, ``mp4``, ``svg``)."""
    opt = opt or AnimateOptions()
    for fmt, path in outputs.items():
        if fmt not in FORMATS:
            raise DoodleError(f"{path}: unknown animation format {fmt!r} (use .gif, .png/.apng, .mp4 or .svg)")
        check_writable(path)
    if "mp4" in outputs:
        try:
            import imageio_ffmpeg  # noqa: F401
        except ImportError:
            raise DoodleError("--mp4 needs imageio-ffmpeg, which is not installed "
                              "(pip install 'doodle3d[video]')") from None
    svgs, images = render_frames(strokes, opt, progress)
    duration_ms = 1000.0 / opt.fps
    with contextlib.ExitStack() as stack:
        # every output goes to its own temporary file; they are renamed into place only once all are written
        for fmt, path in outputs.items():
            tmp = stack.enter_context(atomic_path(path))
            if fmt == "gif":
                pal = [im.quantize(colors=64, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE) for im in images]
                pal[0].save(tmp, format="GIF", save_all=True, append_images=pal[1:], duration=duration_ms, loop=0,
                            optimize=True, disposal=1)
            elif fmt == "apng":
                images[0].save(tmp, format="PNG", save_all=True, append_images=images[1:], duration=duration_ms,
                               loop=0, optimize=False)
            elif fmt == "mp4":
                import imageio.v2 as iio

                even = [np.asarray(im)[: im.height // 2 * 2, : im.width // 2 * 2] for im in images]
                iio.mimwrite(tmp, even, format="FFMPEG", fps=opt.fps, codec="libx264", quality=8, macro_block_size=1)
            else:
                tmp.write_text(animated_svg(svgs, opt.fps), encoding="utf-8")
    written = list(outputs.values())
    return written


def animated_svg(frame_svgs: list[str], fps: float) -> str:
    """One SVG that plays the frames in a browser: each frame's content in a group whose ``display`` is
    switched by a discrete SMIL animation (no scripts)."""
    import re

    n = len(frame_svgs)
    dur = n / fps
    head = re.match(r"<svg[^>]*>", frame_svgs[0]).group(0)
    parts = [head]
    for k, svg in enumerate(frame_svgs):
        body = svg[svg.index(">", svg.index("<svg")) + 1: svg.rindex("</svg>")]
        body = re.sub(r'id="', f'id="f{k:03d}-', body)
        body = body.replace('url(#', f'url(#f{k:03d}-')
        if n == 1:
            parts.append(f'<g id="frame-{k:03d}">{body}</g>')
            continue
        times = sorted({0.0, k / n, (k + 1) / n, 1.0})
        values = ["inline" if t == k / n else "none" for t in times]
        key_times = ";".join(f"{t:.6g}" for t in times)
        parts.append(f'<g id="frame-{k:03d}" display="{"inline" if k == 0 else "none"}">'
                     f'<animate attributeName="display" values="{";".join(values)}" keyTimes="{key_times}" '
                     f'dur="{dur:.6g}s" calcMode="discrete" repeatCount="indefinite"/>{body}</g>')
    parts.append("</svg>\n")
    return "".join(parts)
