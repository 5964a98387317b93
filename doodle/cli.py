"""The ``doodle`` command: parses options and calls library functions, nothing more.

Exit codes: 0 success; 1 unexpected internal error; 2 user error (bad file, bad option), printed as one line
on stderr.
"""

from __future__ import annotations

import json
import sys
import warnings
from pathlib import Path
from typing import Any, Callable

import click

from . import __version__
from .errors import DoodleError


class UserError(click.ClickException):
    """A library error shown as ``Error: <one line>`` with exit code 2."""

    exit_code = 2


def _one_line_warning(message: Warning | str, category: type[Warning], filename: str, lineno: int,
                      file: Any = None, line: str | None = None) -> None:
    """Show a warning as ``Warning: <one line>`` (no source file and line: users did not write them)."""
    click.echo(f"Warning: {str(message).splitlines()[0] if str(message) else category.__name__}", err=True)


#: ``doodle --help`` lists the commands in the order a user meets them.
COMMAND_ORDER = ("demo", "sample", "masks", "fit", "info", "export", "animate", "view", "batch", "styles", "eval",
                 "convert", "export3d", "blender-addon")


class DoodleGroup(click.Group):
    """Turns :class:`DoodleError` and click's usage errors into one line on stderr with exit code 2."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        known = [c for c in COMMAND_ORDER if c in self.commands]
        return known + sorted(c for c in self.commands if c not in known)

    def invoke(self, ctx: click.Context) -> Any:
        try:
            return super().invoke(ctx)
        except DoodleError as exc:
            raise UserError(str(exc).splitlines()[0]) from None
        except OSError as exc:  # unwritable output, full disk, vanished file: the file and the reason
            where = exc.filename if exc.filename is not None else "I/O"
            raise UserError(f"{where}: {exc.strerror or exc}".splitlines()[0]) from None

    def main(self, *args: Any, **kwargs: Any) -> Any:
        kwargs["standalone_mode"] = False
        try:
            with warnings.catch_warnings():
                warnings.showwarning = _one_line_warning
                rv = super().main(*args, **kwargs)
        except click.exceptions.Exit as exc:
            sys.exit(exc.exit_code)
        except (click.Abort, KeyboardInterrupt):
            click.echo("Aborted.", err=True)
            sys.exit(130)
        except click.ClickException as exc:  # UsageError, BadParameter, UserError: no usage banner, one line
            click.echo(f"Error: {exc.format_message()}".splitlines()[0], err=True)
            sys.exit(exc.exit_code)
        sys.exit(rv if isinstance(rv, int) else 0)


@click.group(cls=DoodleGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="doodle")
def cli() -> None:
    """Turn multi-view images of an object into a few 3D strokes and clean vector sketches."""


@cli.command(short_help="Write a procedural scene with its ground truth.")
@click.argument("name", type=str)
@click.argument("out_dir", type=click.Path(file_okay=False, path_type=Path))
@click.option("--train", "n_train", default=40, show_default=True, type=click.IntRange(1, 1000), help="Training views.")
@click.option("--test", "n_test", default=10, show_default=True, type=click.IntRange(1, 1000), help="Held-out views.")
@click.option("--size", default=256, show_default=True, type=click.IntRange(16, 4096), help="Image size in pixels.")
@click.option("--force", is_flag=True, help="Replace OUT_DIR if it exists.")
@click.option("--capture", is_flag=True,
              help="Write a phone-capture-like COLMAP project instead: JPEGs over a textured floor and wall, "
                   "landscape and portrait (some EXIF-rotated), lens distortion, no masks (--train photos).")
@click.option("--floor", type=click.Choice(["planks", "carpet"]), default="planks", show_default=True,
              help="With --capture: the floor the object stands on (carpet: a busy red carpet with more features "
                   "than the object).")
def sample(name: str, out_dir: Path, n_train: int, n_test: int, size: int, force: bool, capture: bool,
           floor: str) -> None:
    """Write procedural sample scene NAME (chair, snowman, lamp, tripod, mug, parcel, teapot, cow, calf, mouse) as a NeRF-synthetic folder.

    The folder holds RGBA renders from the upper hemisphere, transforms_{train,test}.json and
    ground_truth.json (primitives and visible feature edges). With --capture, a COLMAP project
    (images/, sparse/0/, true_masks/ for measuring automatic masks).
    """
    from .samples import write_capture, write_sample

    if capture:
        out = write_capture(name, out_dir, n=n_train, size=size, force=force, floor=floor)
        click.echo(f"wrote {name} as a phone capture on a {floor} floor: {n_train} photos, long side {size} px, to {out}")
        return
    out = write_sample(name, out_dir, n_train=n_train, n_test=n_test, size=size, force=force)
    click.echo(f"wrote {name}: {n_train} train + {n_test} test views at {size} px to {out}")


@cli.command(short_help="Counts, sizes per part and provenance of a stroke file.")
@click.argument("strokes", type=click.Path(path_type=Path))
@click.option("--json", "as_json", is_flag=True, help="Print machine-readable JSON.")
def info(strokes: Path, as_json: bool) -> None:
    """Summarise a stroke file: counts, bounding box, sizes in both encodings, provenance."""
    from .info import describe, format_description

    desc = describe(strokes)
    click.echo(json.dumps(desc, indent=1) if as_json else format_description(desc))


@cli.command(short_help="Convert a stroke file between JSON and compact binary.")
@click.argument("src", type=click.Path(path_type=Path))
@click.argument("dst", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--to", "fmt", type=click.Choice(["json", "binary"]), default=None,
              help="Output encoding (default: from DST's suffix, .doodleb = binary).")
def convert(src: Path, dst: Path, fmt: str | None) -> None:
    """Convert a stroke file between JSON (.doodle) and compact binary (.doodleb)."""
    from .strokes import read_strokes, write_strokes

    n = write_strokes(dst, read_strokes(src), binary=None if fmt is None else fmt == "binary")
    click.echo(f"wrote {dst} ({n} bytes)")


@cli.command(short_help="Write the 3D strokes as OBJ, PLY or glTF for 3D tools.")
@click.argument("strokes", type=click.Path(path_type=Path))
@click.option("-o", "--out", "out_path", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="3D file to write: .obj (polylines, exact cubics as curv, meshes), .ply (edges and faces) "
                   "or .glb (binary glTF, +Y up: line meshes with their cubics in extras, meshes).")
@click.option("--samples", type=click.IntRange(2, 1024), default=32, show_default=True,
              help="Points per curve in the polylines.")
@click.option("--curves/--no-curves", default=True, show_default=True, help="Write the curves.")
@click.option("--superquadrics/--no-superquadrics", default=True, show_default=True,
              help="Write the superquadrics as closed meshes.")
@click.option("--hull/--no-hull", default=True, show_default=True,
              help="Write the hull (in files that draw their outline by one) as a closed mesh.")
def export3d(strokes: Path, out_path: Path, samples: int, curves: bool, superquadrics: bool, hull: bool) -> None:
    """Write the 3D strokes of STROKES for 3D tools: OBJ or PLY in the stroke file's units and axes, or glTF
    binary (.glb) in its units turned to glTF's +Y up."""
    from dataclasses import replace

    from .atomic import write_bytes
    from .exporters.scene3d import FORMATS_3D, encode_3d
    from .strokes import CurveSet, SuperquadricSet, read_strokes

    s = read_strokes(strokes)
    if not curves:
        s = replace(s, curves=CurveSet(width_px=s.curves.width_px))
    if not superquadrics:
        s = replace(s, superquadrics=SuperquadricSet())
    if not hull:
        s = replace(s, hull=None)
    suffix = out_path.suffix.lower()
    if not len(s.curves) and not len(s.superquadrics) and s.hull is None:
        raise DoodleError(f"{strokes}: nothing to write (no curves, superquadrics or hull selected)")
    if suffix not in FORMATS_3D:
        raise DoodleError(f"{out_path}: unknown 3D format {suffix or '(no suffix)'!r} (use .obj, .ply or .glb)")
    data = encode_3d(s, suffix, samples)
    try:
        write_bytes(out_path, data)
    except OSError as exc:
        raise DoodleError(f"{out_path}: cannot write ({exc.strerror or exc})") from None
    click.echo(f"wrote {out_path}: {len(s.curves)} curves, {len(s.superquadrics)} superquadrics"
               f"{', the hull' if s.hull is not None else ''}, {len(data)} bytes")


@cli.command(name="blender-addon", short_help="Write the Blender add-on that imports stroke files.")
@click.option("-o", "--out", "out_path", type=click.Path(dir_okay=False, path_type=Path), default="doodle_import.py",
              show_default=True, help="Where to write the add-on (one Python file).")
def blender_addon(out_path: Path) -> None:
    """Write the Blender add-on and script that imports .doodle files (curves as exact Bézier curves,
    superquadrics as meshes, orbit cameras). Install it in Blender's preferences, or run it headless:
    blender -b --python doodle_import.py -- strokes.doodle --save strokes.blend"""
    from .atomic import write_text
    from .exporters.scene3d import blender_addon_source

    try:
        write_text(out_path, blender_addon_source())
    except OSError as exc:
        raise DoodleError(f"{out_path}: cannot write ({exc.strerror or exc})") from None
    click.echo(f"wrote {out_path} (Blender: Edit > Preferences > Add-ons > Install; or blender -b --python "
               f"{out_path.name} -- strokes.doodle)")


def _parse_size(ctx: click.Context, param: click.Parameter, value: str | None) -> tuple[int, int | None] | None:
    """``W`` or ``WxH`` in pixels."""
    if value is None:
        return None
    try:
        parts = [int(v) for v in value.lower().split("x")]
    except ValueError:
        parts = []
    if len(parts) not in (1, 2) or not all(1 <= v <= 16384 for v in parts):
        raise click.BadParameter(f"expected W or WxH in pixels (1..16384), got {value!r}")
    return (parts[0], parts[1] if len(parts) == 2 else None)


def _parse_paper(ctx: click.Context, param: click.Parameter, value: str | None) -> tuple[float, float] | None:
    """``WxH`` in millimetres (``210x297``, ``210x297mm``)."""
    if value is None:
        return None
    text = value.lower().removesuffix("mm")
    try:
        w, h = (float(v) for v in text.split("x"))
    except ValueError:
        raise click.BadParameter(f"expected WxH in millimetres (e.g. 210x297), got {value!r}") from None
    if not (30 <= w <= 5000 and 30 <= h <= 5000):
        raise click.BadParameter(f"paper sides must be within 30..5000 mm, got {value!r}")
    return (w, h)


def _positive_float(ctx: click.Context, param: click.Parameter, value: float) -> float:
    if not value > 0:
        raise click.BadParameter(f"must be positive, got {value}")
    return value


def _share(ctx: click.Context, param: click.Parameter, value: float | None) -> float | None:
    if value is not None and not 0 <= value < 1:
        raise click.BadParameter(f"must be in [0, 1), got {value}")
    return value


min_piece_option = click.option(
    "--min-piece", type=float, default=None, callback=_share,
    help="Leave out visible pieces of curves shorter than this share of the object's size on screen (dots, "
         "stubs of curves seen end-on or peeking out from behind a part); 0 draws every piece "
         "[default: 0.01, DrawOptions.min_piece].")


min_mark_option = click.option(
    "--min-mark", type=float, default=None, callback=_share,
    help="Leave out marks (a visible piece with every piece it touches) smaller than this share of the "
         "object's size on screen: isolated ticks and dots; 0 keeps them [default: 0.02, DrawOptions.min_mark].")


def view_options(f):
    """Options shared by every command that draws a stroke set: which cameras and how to draw."""
    opts = [
        click.option("--views", type=int, default=36, show_default=True,
                     help="Number of orbit cameras around the recorded up axis."),
        click.option("--cameras", "scene_dir", type=click.Path(path_type=Path),
                     help="Draw the cameras of this dataset folder instead of an orbit."),
        click.option("--split", default="test", show_default=True, help="Dataset split for --cameras."),
        click.option("--size", callback=_parse_size, help="Image size W or WxH in pixels (default: recorded)."),
        click.option("--projection", type=click.Choice(["persp", "ortho"]), default="persp", show_default=True,
                     help="Perspective or orthographic orbit cameras."),
        click.option("--tolerance", type=float, default=0.05, show_default=True, callback=_positive_float,
                     help="Max distance in px between drawn cubics and the exact projection."),
        click.option("--hidden", type=click.Choice(["show", "dash", "hide"]), default=None,
                     help="Parts behind the superquadric volume [default: the style's, else hide]."),
        click.option("--no-silhouettes", is_flag=True, help="Leave out superquadric silhouettes."),
        click.option("--no-curves", is_flag=True, help="Leave out the Bézier curves."),
        min_piece_option,
        min_mark_option,
    ]
    for opt in reversed(opts):
        f = opt(f)
    return f


def style_options(f):
    """--style and --no-filters, shared by export and animate."""
    f = click.option("--no-filters", is_flag=True, help="No SVG filter effects (for tools that ignore them).")(f)
    return click.option("--style", default="ink", show_default=True,
                        help="Built-in style name (see `doodle styles`) or a .toml/.json style file.")(f)


def _background(value: str | None) -> str | None:
    if value is None:
        return ""
    if value == "transparent":
        return None
    import re

    from cairosvg.colors import COLORS  # the SVG/CSS colour names the rasteriser knows

    if not (re.fullmatch(r"#[0-9a-fA-F]{6}", value) or value.lower() in COLORS):
        raise click.BadParameter(f"expected #rrggbb, a colour name or 'transparent', got {value!r}", param_hint="--background")
    return value


def _draw_options(tolerance: float, hidden: str, no_silhouettes: bool = False, no_curves: bool = False,
                  min_piece: float | None = None, min_mark: float | None = None):
    from .exporters import DrawOptions

    extra = {k: v for k, v in (("min_piece", min_piece), ("min_mark", min_mark)) if v is not None}
    return DrawOptions(tolerance=tolerance, hidden=hidden, curves=not no_curves, silhouettes=not no_silhouettes,
                       **extra)


@cli.command(short_help="Draw a stroke file as exact SVG/PNG/PDF views and a sheet.")
@click.argument("strokes", type=click.Path(path_type=Path))
@click.option("-o", "--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), required=True,
              help="Output folder (view_000.svg, ...).")
@click.option("--svg/--no-svg", "want_svg", default=None, help="Write SVG files (default unless only --png/--pdf).")
@click.option("--png", is_flag=True, help="Also write PNG files (cairosvg).")
@click.option("--pdf", is_flag=True, help="Also write PDF files (cairosvg).")
@click.option("--sheet", type=click.Path(dir_okay=False, path_type=Path), help="Write all views in one grid PNG.")
@click.option("--background", default=None,
              help="Background colour (#rrggbb) or 'transparent' (default: the style's).")
@click.option("--plotter", is_flag=True,
              help="Plotter-ready SVG: strokes that continue each other joined into one path, no pieces under 3 px, "
                   "paths ordered to keep pen-up travel short, black unfilled lines, hidden lines left out.")
@click.option("--paper", callback=_parse_paper, metavar="WxH", help="With --plotter: paper size in mm (e.g. "
              "210x297); the drawing is fitted inside 10 mm margins [default: the image size at 96 dpi].")
@style_options
@view_options
def export(strokes: Path, out_dir: Path, want_svg: bool | None, png: bool, pdf: bool, sheet: Path | None,
           plotter: bool, paper: tuple[float, float] | None,
           background: str | None, style: str, no_filters: bool, views: int, scene_dir: Path | None, split: str, size,
           projection: str, tolerance: float, hidden: str | None, no_silhouettes: bool, no_curves: bool,
           min_piece: float | None, min_mark: float | None) -> None:
    """Draw STROKES for orbit (or dataset) cameras as exact SVG paths, PNG, PDF and a contact sheet."""
    from .exporters import ExportOptions, export_cameras, export_views
    from .strokes import read_strokes

    s = read_strokes(strokes)
    cams = export_cameras(s, views, scene_dir, split, size, "orthographic" if projection == "ortho" else "perspective")
    from .styles import load_style

    st = load_style(style)
    svg = want_svg if want_svg is not None else not (png or pdf)
    if paper is not None and not plotter:
        raise DoodleError("--paper applies to --plotter output only")
    from .exporters.plotter import PlotterOptions

    opts = ExportOptions(svg=svg, png=png, pdf=pdf, sheet=sheet, background=_background(background), style=st,
                         filters=not no_filters, source=str(strokes),
                         plotter=PlotterOptions(paper_mm=paper) if plotter else None,
                         draw=_draw_options(tolerance, hidden or st.hidden_mode or "hide", no_silhouettes, no_curves,
                                            min_piece, min_mark))
    with _progress(len(cams), "drawing") as bar:
        files = export_views(s, cams, out_dir, opts, progress=lambda k, n: bar.update(k - bar.n))
    views = [f for f in files if sheet is None or f != Path(sheet)]
    if views:
        click.echo(f"wrote {len(views)} files for {len(cams)} views to {out_dir}" + (f" and sheet {sheet}" if sheet else ""))
    else:
        click.echo(f"wrote sheet {sheet} of {len(cams)} views")


def _parse_elevations(ctx: click.Context, param: click.Parameter, value: str) -> tuple[float, ...]:
    try:
        values = tuple(float(v) for v in value.split(",") if v.strip())
    except ValueError:
        raise click.BadParameter(f"expected degrees separated by commas (e.g. -30,0,30,60), got {value!r}") from None
    if not values:
        raise click.BadParameter("give at least one elevation")
    return values


@cli.command(short_help="Write an offline HTML page to turn the sketch around.")
@click.argument("strokes", type=click.Path(path_type=Path))
@click.option("-o", "--out", "out_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="HTML file to write [default: STROKES with the suffix .html].")
@click.option("--style", default="ink", show_default=True,
              help="Style the page opens with: a built-in name or a .toml/.json style file (built-ins are offered too).")
@click.option("--hidden", type=click.Choice(["show", "dash", "hide"]), default=None,
              help="Hidden-line mode the page opens with [default: the style's, else hide].")
@click.option("--size", type=click.IntRange(16, 4096), default=512, show_default=True, help="View size in pixels (square).")
@click.option("--azimuths", type=click.IntRange(1, 720), default=72, show_default=True,
              help="Views around the up axis (72: one every 5 degrees).")
@click.option("--elevations", default="-45,-30,-15,0,15,30,45,60,75", show_default=True, callback=_parse_elevations,
              help="Rows of views, degrees above the horizon, separated by commas.")
@click.option("--tolerance", type=float, default=0.05, show_default=True, callback=_positive_float,
              help="Max distance in px between drawn cubics and the exact projection.")
def view(strokes: Path, out_path: Path | None, style: str, hidden: str | None, size: int, azimuths: int,
         elevations: tuple[float, ...], tolerance: float) -> None:
    """Write one self-contained HTML file (no network, opens from disk) holding the exporter's drawings of
    STROKES from every 5 degrees around and 15 degrees up: drag to turn, wheel to zoom, choose a style and
    the hidden lines, save the view as SVG."""
    from .exporters.viewer import ViewerOptions, write_viewer
    from .strokes import read_strokes
    from .styles import load_style

    s = read_strokes(strokes)
    st = load_style(style)
    out = out_path if out_path is not None else strokes.with_suffix(".html")
    opts = ViewerOptions(azimuths=azimuths, elevations=elevations, size=size, tolerance=tolerance, style=st,
                         hidden=hidden or st.hidden_mode or "hide")
    opts.check()
    n = azimuths * len(elevations)
    with _progress(n, "drawing") as bar:
        write_viewer(s, out, opts, source=str(strokes), progress=lambda k, total: bar.update(k - bar.n))
    click.echo(f"wrote {out}: {n} views, {out.stat().st_size / 1e6:.2f} MB (open it in a browser; no network needed)")


@cli.command(short_help="Fit, export and animate every object of a manifest.")
@click.argument("manifest", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), required=True,
              help="Output folder: one folder per object, summary.json, sheet.png, index.html.")
@click.option("--jobs", type=click.IntRange(0, 256), default=0, show_default=True,
              help="Objects made at once on this machine (0: one a core, as many as the memory holds).")
@click.option("--threads", type=click.IntRange(0, 256), default=0, show_default=True,
              help="Threads per object (0: the cores shared out between the jobs).")
@click.option("--ray", "ray_address", metavar="auto|ADDRESS", default=None,
              help="Run the objects as Ray tasks: 'auto' joins a running cluster or starts one here, or a "
                   "cluster's address (needs pip install -e '.[ray]'; OUT must be shared by the nodes).")
@click.option("--gpus", type=click.FloatRange(0, 64), default=0.0, show_default=True,
              help="GPUs each Ray task asks for.")
@click.option("--retry-failed", is_flag=True, help="Make again the objects whose last attempt failed.")
def batch(manifest: Path, out_dir: Path, jobs: int, threads: int, ray_address: str | None, gpus: float,
          retry_failed: bool) -> None:
    """Fit, export and animate every object listed in MANIFEST (TOML, JSON or CSV) into OUT/NAME/, resumably:
    objects done before are skipped, a failed object is recorded with its reason and the others go on.
    Exit code 0 when every object is made, 3 when some failed (see OUT/summary.json)."""
    import time

    from .batch import BatchOptions, run_batch

    start = time.perf_counter()
    bar = None

    def progress(done: int, total: int, name: str) -> None:
        nonlocal bar
        if bar is None:
            bar = _progress(total, "objects")
            bar.unit = "object"
        hours = (time.perf_counter() - start) / 3600
        bar.set_postfix_str(f"{done / hours:.0f} objects/h, last {name}", refresh=False)
        bar.update(done - bar.n)

    try:
        result = run_batch(manifest, out_dir, BatchOptions(jobs=jobs, threads=threads, ray=ray_address, gpus=gpus,
                                                           retry_failed=retry_failed), log=click.echo, progress=progress)
    finally:
        if bar is not None:
            bar.close()
    ok = len(result.records) - len(result.failed)
    per_hour = result.made / (result.seconds / 3600) if result.made and result.seconds > 0 else 0.0
    click.echo(f"{ok} of {len(result.records)} objects made ({result.made} this run"
               + (f", {per_hour:.0f} objects/h" if result.made else "") + f"); summary in {out_dir / 'summary.json'}")
    if result.failed:
        click.echo(f"failed: {', '.join(result.failed)}", err=True)
        sys.exit(3)


@cli.command(short_help="Render a seamless turntable: GIF, APNG, MP4 or SVG.")
@click.argument("strokes", type=click.Path(path_type=Path))
@click.option("--gif", type=click.Path(dir_okay=False, path_type=Path), help="Write an animated GIF.")
@click.option("--apng", type=click.Path(dir_okay=False, path_type=Path), help="Write an animated PNG.")
@click.option("--mp4", type=click.Path(dir_okay=False, path_type=Path), help="Write an MP4 (needs imageio-ffmpeg).")
@click.option("--svg", type=click.Path(dir_okay=False, path_type=Path), help="Write one animated SVG (plays in browsers).")
@click.option("--frames", type=int, default=36, show_default=True, help="Frames in one turn.")
@click.option("--fps", type=float, default=12.0, show_default=True, help="Frames per second.")
@click.option("--size", type=int, default=512, show_default=True, help="Frame size in pixels (square).")
@click.option("--elevation", type=float, default=None, help="Camera elevation in degrees (default: recorded).")
@click.option("--bob", type=float, default=0.0, show_default=True, help="Gentle up-down motion, degrees.")
@click.option("--hidden", type=click.Choice(["show", "dash", "hide"]), default=None,
              help="Parts behind the superquadric volume [default: the style's, else hide].")
@min_piece_option
@min_mark_option
@style_options
def animate(strokes: Path, gif: Path | None, apng: Path | None, mp4: Path | None, svg: Path | None, frames: int,
            fps: float, size: int, elevation: float | None, bob: float, hidden: str | None, style: str,
            no_filters: bool, min_piece: float | None, min_mark: float | None) -> None:
    """Render a seamless turntable of STROKES as GIF, APNG, MP4 and/or animated SVG."""
    from .animate import AnimateOptions, animate_many
    from .strokes import read_strokes

    outputs = {k: v for k, v in (("gif", gif), ("apng", apng), ("mp4", mp4), ("svg", svg)) if v is not None}
    if not outputs:
        raise click.UsageError("choose at least one of --gif, --apng, --mp4, --svg")
    from .styles import load_style

    s = read_strokes(strokes)
    opt = AnimateOptions(frames=frames, fps=fps, size=size, style=load_style(style), elevation_deg=elevation,
                         bob_deg=bob, hidden=hidden or "", filters=not no_filters,
                         draw=_draw_options(0.25, hidden or "", min_piece=min_piece, min_mark=min_mark))
    with _progress(frames, "frames") as bar:
        written = animate_many(s, outputs, opt, progress=lambda k, n: bar.update(k - bar.n))
    click.echo("wrote " + ", ".join(str(p) for p in written))


@cli.command(short_help="List the brush styles, or draw them all on one view.")
@click.option("--preview", type=click.Path(dir_okay=False, path_type=Path),
              help="Write a sheet with every style drawn on one view.")
@click.option("--strokes", "strokes_path", type=click.Path(path_type=Path),
              help="Stroke file for the preview (default: a built-in sample).")
@click.option("--style", "extra", multiple=True, help="Also preview these style files.")
def styles(preview: Path | None, strokes_path: Path | None, extra: tuple[str, ...]) -> None:
    """List the built-in styles; optionally write a preview sheet of all of them."""
    from .styles import builtin_names, load_style

    for name in builtin_names():
        click.echo(f"{name:10s} {load_style(name).description}")
    if preview:
        from .exporters.style_preview import preview_sheet
        from .strokes import read_strokes

        s = read_strokes(strokes_path) if strokes_path else None
        preview_sheet(preview, s, [*builtin_names(), *extra])
        click.echo(f"wrote {preview}")


def _count_or_auto(limit: int):
    """Click callback: ``auto`` or an integer in ``[0, limit]``."""
    def parse(ctx: click.Context, param: click.Parameter, value: str) -> Any:
        if value == "auto":
            return value
        try:
            n = int(value)
        except ValueError:
            n = -1
        if not 0 <= n <= limit:
            raise click.BadParameter(f"expected 'auto' or a number in [0, {limit}], got {value!r}")
        return n
    return parse


def _log(msg: str) -> None:
    click.echo(msg, err=True)


class GroupedOption(click.Option):
    """An option listed under a heading in its command's help (``group``: one of the fit config's groups)."""

    def __init__(self, *args: Any, group: str = "", **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.group = group


class GroupedCommand(click.Command):
    """A command whose help lists its options under headings: its own first, then each option group."""

    def format_options(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        sections: dict[str, list[tuple[str, str]]] = {}
        for param in self.get_params(ctx):
            record = param.get_help_record(ctx)
            if record is not None:
                sections.setdefault(getattr(param, "group", ""), []).append(record)
        for group, rows in sections.items():
            with formatter.section(f"{group.capitalize()} options" if group else "Options"):
                formatter.write_dl(rows)


def _config_option(f: Any) -> Callable[[Callable], Callable]:
    """The click option of one :class:`~doodle.fit.config.FitConfig` field, from its declaration."""
    from .fit.config import cli_flag

    m, flag, default = f.metadata, cli_flag(f), f.default
    common = dict(cls=GroupedOption, group=m["group"], help=m["help"])
    kind, limits = m["kind"], m["limits"]
    if kind is bool:
        return click.option(f"{flag}/--no-{flag[2:]}", f.name, default=default, show_default=default is not None,
                            **common)
    if kind == "count":
        return click.option(flag, f.name, default=str(default), show_default=True, metavar="auto|N",
                            callback=_count_or_auto(int(limits[1])), **common)
    if isinstance(kind, tuple):
        return click.option(flag, f.name, type=click.Choice(kind), default=default, show_default=True, **common)
    if kind == "path":
        return click.option(flag, f.name, type=click.Path(file_okay=False, path_type=Path), default=default, **common)
    types = {int: click.IntRange, float: click.FloatRange}
    ptype = types[kind](*limits) if kind in types and limits else kind
    return click.option(flag, f.name, type=ptype, default=default, show_default=default is not None, **common)


def fit_options(command: Callable) -> Callable:
    """Every option of :class:`~doodle.fit.config.FitConfig` that is not internal, as ``doodle fit`` flags."""
    from .fit.config import config_fields

    for f in reversed(config_fields()):
        if not f.metadata["internal"]:
            command = _config_option(f)(command)
    return command


@cli.command(cls=GroupedCommand, short_help="Fit strokes to posed images or plain photos of an object.")
@click.argument("scene_dir", metavar="SCENE", type=click.Path(path_type=Path))
@click.option("-o", "--out", "out_path", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="Stroke file to write (.doodle JSON, .doodleb binary).")
@click.option("--split", default="train", show_default=True, help="Dataset split to fit (NeRF-synthetic).")
@click.option("--masks", default="auto", show_default=True, metavar="auto|none|DIR",
              help="Object masks: the scene's own, else those in SCENE/doodle-masks (made for these photos, or "
                   "fixed by hand), else made from the photos and saved there (auto); none; or a folder with "
                   "NAME.png per view.")
@click.option("--resume", is_flag=True, help="Continue from OUT.ckpt, written after every stage.")
@fit_options
def fit(scene_dir: Path, out_path: Path, split: str, masks: str, resume: bool, **options: Any) -> None:
    """Fit strokes to the posed images in SCENE (NeRF-synthetic, nerfstudio, COLMAP, or plain photos).

    Ctrl-C stops early and still writes what the finished stages give (exit code 130); --resume goes on from
    the checkpoint written after every stage.
    """
    from .atomic import check_writable
    from .fit import FitConfig
    from .fit import fit as fit_scene
    from .scenes import load_scene_at_size
    from .scenes.automask import with_masks
    from .strokes import write_strokes

    cfg = FitConfig(**options)
    cfg.check()
    check_writable(out_path)  # before minutes of fitting
    scene = load_scene_at_size(scene_dir, split, cfg.load_size)
    _log(f"loaded {len(scene)} views from {scene_dir}")
    scene = with_masks(scene, masks, Path(scene_dir) / "doodle-masks", log=_log)
    ckpt = out_path.with_name(out_path.name + ".ckpt")
    result = fit_scene(scene, cfg, checkpoint=ckpt, resume=resume, log=_log, progress=True)
    s = result.strokes
    if s is None:  # interrupted before anything could be drawn
        click.echo(f"interrupted before anything was drawn: {out_path} not written (--resume goes on from {ckpt})",
                   err=True)
        sys.exit(130)
    n = write_strokes(out_path, s)
    msg = f"wrote {out_path}: {len(s.curves)} curves, {len(s.superquadrics)} superquadrics, {n} bytes, {result.seconds:.0f} s"
    if result.interrupted:
        click.echo(msg + f" (interrupted; --resume goes on from {ckpt})")
        sys.exit(130)
    click.echo(msg)


@cli.command(short_help="Make the automatic masks of photos, to check or fix.")
@click.argument("scene_dir", metavar="SCENE", type=click.Path(path_type=Path))
@click.option("-o", "--out", "out_dir", type=click.Path(file_okay=False, path_type=Path),
              help="Folder for the masks, NAME.png per view [default: SCENE/doodle-masks, where a fit reads them].")
@click.option("--split", default="train", show_default=True, help="Dataset split (NeRF-synthetic).")
@click.option("--size", type=click.IntRange(16, 4096), default=512, show_default=True,
              help="Image size (larger side, px) to make them at: a fit at the same size reads them instead of "
                   "making them again.")
@click.option("--sheet", type=click.Path(dir_okay=False, path_type=Path),
              help="Also write a contact sheet of the photos with each mask's outline (PNG).")
@click.option("--against", "truth_dir", type=click.Path(exists=True, file_okay=False, path_type=Path),
              help="Measure them against these masks (NAME.png per view) [default: the scene's own, if any].")
def masks(scene_dir: Path, out_dir: Path | None, split: str, size: int, sheet: Path | None,
          truth_dir: Path | None) -> None:
    """Make the object masks a fit makes for photos without them (whatever the scene holds), save them with the
    marker that says they are automatic, and measure them against true masks when there are some (the scene's
    alpha or masks folder, or --against). Fix any by hand and fit with --masks DIR."""
    from dataclasses import replace

    import numpy as np

    from .atomic import atomic_path, check_writable
    from .scenes import load_scene_at_size
    from .scenes.automask import agreement, auto_masks, fixed_by_hand, with_masks, write_masks

    out_dir = out_dir or Path(scene_dir) / "doodle-masks"
    if sheet is not None:
        check_writable(sheet)
    scene = load_scene_at_size(scene_dir, split, size)
    _log(f"loaded {len(scene)} views from {scene_dir}")
    truth = with_masks(scene, truth_dir, log=_log).masks if truth_dir is not None else scene.masks
    if fixed_by_hand(out_dir):
        raise UserError(f"{out_dir}: holds masks fixed by hand; give another folder with -o (or delete it)")
    bare = replace(scene, masks=None, masks_automatic=False)
    made = auto_masks(bare, _log)
    write_masks(bare, made, out_dir)
    click.echo(f"wrote {len(made)} masks to {out_dir}: the object covers "
               f"{100 * float(np.mean([m.mean() for m in made])):.0f}% of the image on average")
    if truth is not None:
        ious = agreement(made, truth)
        worst = int(np.argmin(ious))
        click.echo(f"IoU with the true masks: mean {np.mean(ious):.3f}, worst {ious[worst]:.3f} "
                   f"({scene.cameras[worst].name})")
    if sheet is not None:
        from .exporters.raster import masks_sheet

        with atomic_path(sheet) as tmp:
            masks_sheet(scene.images, made, [c.name for c in scene.cameras]).save(tmp, format="PNG")
        click.echo(f"wrote {sheet}")


@cli.command(name="eval", short_help="Score a sketch on held-out views (and 3D curves).")
@click.argument("strokes", type=click.Path(path_type=Path))
@click.argument("scene_dir", metavar="SCENE", type=click.Path(path_type=Path))
@click.option("--split", default="test", show_default=True, help="Held-out split to measure on.")
@click.option("--tau", type=float, default=2.0, show_default=True, callback=_positive_float, help="Distance threshold (px).")
@click.option("--size", type=int, default=256, show_default=True, help="Evaluation resolution (px).")
@click.option("--json", "json_out", type=click.Path(dir_okay=False, path_type=Path),
              help="Also write the metrics (with per-view rows) as JSON here ('-' for stdout only).")
@click.option("--gt-curves", "gt_dir", type=click.Path(path_type=Path),
              help="Ground-truth feature curves (ABC: mesh.obj, features.yml, normalisation.json): also report "
                   "3D Chamfer distance, precision, recall and F.")
@click.option("--gt-threshold", type=float, default=0.02, show_default=True, callback=_positive_float,
              help="Distance for 3D precision and recall (scene units).")
@click.option("--masks", "masks_dir", type=click.Path(file_okay=False, path_type=Path),
              help="Measure silhouettes against these masks (NAME.png per view) instead of the scene's.")
def eval_cmd(strokes: Path, scene_dir: Path, split: str, tau: float, size: int, json_out: Path | None,
             gt_dir: Path | None, gt_threshold: float, masks_dir: Path | None) -> None:
    """Measure STROKES on SCENE's held-out views: line precision, silhouette recall, F-score, IoU, size;
    with --gt-curves, also the 3D curve accuracy as NEF and EMAP report it.

    STROKES may also be a folder of line drawings, one SVG per held-out camera in name order (Blender
    Freestyle's, say): they get the same line metrics, to compare with."""
    from .atomic import write_text
    from .evaluate import evaluate, evaluate_svgs, format_metrics, natural_sorted
    from .scenes import load_scene_at_size
    from .strokes import read_strokes

    drawings = natural_sorted(strokes.glob("*.svg")) if strokes.is_dir() else None
    if drawings is not None and gt_dir is not None:
        raise click.UsageError("--gt-curves needs a stroke file, not a folder of drawings")
    if drawings is not None and not drawings:
        raise UserError(f"{strokes}: no .svg drawings in this folder")
    s = read_strokes(strokes) if drawings is None else None
    truth = None
    if gt_dir is not None:
        from .curvemetrics import read_abc_ground_truth

        truth = read_abc_ground_truth(gt_dir)
    scene = load_scene_at_size(scene_dir, split, size)
    if masks_dir is not None:
        from .scenes.automask import with_masks

        scene = with_masks(scene, masks_dir, log=_log)
    if drawings is not None:
        if len(drawings) != len(scene.cameras):
            raise UserError(f"{strokes}: {len(drawings)} SVG drawings for the {len(scene.cameras)} cameras of "
                            f"{scene_dir}'s {split} split")
        metrics = evaluate_svgs(drawings, scene, tau=tau, size=size)
    else:
        metrics = evaluate(s, scene, tau=tau, size=size, truth=truth, gt_threshold=gt_threshold)
    if json_out is not None and str(json_out) == "-":
        click.echo(json.dumps(metrics, indent=1))
        return
    click.echo(format_metrics(metrics))
    if json_out is not None:
        write_text(json_out, json.dumps(metrics, indent=1))


@cli.command(short_help="Run the whole pipeline on a built-in scene.")
@click.option("-o", "--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), default=Path("doodle-demo"),
              show_default=True, help="Folder for everything the demo makes.")
@click.option("--scene", type=click.Choice(["chair", "snowman", "lamp", "tripod", "mug", "parcel", "teapot", "cow", "calf", "mouse"]),
              default="snowman", show_default=True, help="The procedural scene to run on.")
def demo(out_dir: Path, scene: str) -> None:
    """Run the whole pipeline on a built-in procedural scene: render, fit, export, animate, evaluate."""
    from .demo import run_demo

    run_demo(out_dir, scene, log=click.echo)


def _progress(total: int, desc: str):
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit="view", leave=False, disable=not sys.stderr.isatty())


def main() -> None:
    """Console-script entry point."""
    cli(prog_name="doodle")


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
