"""The ``doodle`` command: parses options and calls library functions, nothing more.

Exit codes: 0 success; 1 unexpected internal error; 2 user error (bad file, bad option), printed as one line
on stderr.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import click

from . import __version__
from .errors import DoodleError


class UserError(click.ClickException):
    """A library error shown as ``Error: <one line>`` with exit code 2."""

    exit_code = 2


class DoodleGroup(click.Group):
    """Turns :class:`DoodleError` and click's usage errors into one line on stderr with exit code 2."""

    def invoke(self, ctx: click.Context) -> Any:
        try:
            return super().invoke(ctx)
        except DoodleError as exc:
            raise UserError(str(exc).splitlines()[0]) from None

    def main(self, *args: Any, **kwargs: Any) -> Any:
        kwargs["standalone_mode"] = False
        try:
            rv = super().main(*args, **kwargs)
        except click.exceptions.Exit as exc:
            sys.exit(exc.exit_code)
        except click.Abort:
            click.echo("Aborted.", err=True)
            sys.exit(1)
        except click.ClickException as exc:  # UsageError, BadParameter, UserError: no usage banner, one line
            click.echo(f"Error: {exc.format_message()}".splitlines()[0], err=True)
            sys.exit(exc.exit_code)
        sys.exit(rv if isinstance(rv, int) else 0)


@click.group(cls=DoodleGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="doodle")
def cli() -> None:
    """Turn multi-view images of an object into a few 3D strokes and clean vector sketches."""


@cli.command()
@click.argument("name", type=str)
@click.argument("out_dir", type=click.Path(file_okay=False, path_type=Path))
@click.option("--train", "n_train", default=40, show_default=True, type=click.IntRange(1, 1000), help="Training views.")
@click.option("--test", "n_test", default=10, show_default=True, type=click.IntRange(1, 1000), help="Held-out views.")
@click.option("--size", default=256, show_default=True, type=click.IntRange(16, 4096), help="Image size in pixels.")
@click.option("--force", is_flag=True, help="Replace OUT_DIR if it exists.")
def sample(name: str, out_dir: Path, n_train: int, n_test: int, size: int, force: bool) -> None:
    """Write procedural sample scene NAME (chair, snowman, lamp) as a NeRF-synthetic folder.

    The folder holds RGBA renders from the upper hemisphere, transforms_{train,test}.json and
    ground_truth.json (primitives and visible feature edges).
    """
    from .samples import write_sample

    out = write_sample(name, out_dir, n_train=n_train, n_test=n_test, size=size, force=force)
    click.echo(f"wrote {name}: {n_train} train + {n_test} test views at {size} px to {out}")


@cli.command()
@click.argument("strokes", type=click.Path(path_type=Path))
@click.option("--json", "as_json", is_flag=True, help="Print machine-readable JSON.")
def info(strokes: Path, as_json: bool) -> None:
    """Summarise a stroke file: counts, bounding box, sizes in both encodings, provenance."""
    from .info import describe, format_description

    desc = describe(strokes)
    click.echo(json.dumps(desc, indent=1) if as_json else format_description(desc))


@cli.command()
@click.argument("src", type=click.Path(path_type=Path))
@click.argument("dst", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--to", "fmt", type=click.Choice(["json", "binary"]), default=None,
              help="Output encoding (default: from DST's suffix, .doodleb = binary).")
def convert(src: Path, dst: Path, fmt: str | None) -> None:
    """Convert a stroke file between JSON (.doodle) and compact binary (.doodleb)."""
    from .strokes import read_strokes, write_strokes

    n = write_strokes(dst, read_strokes(src), binary=None if fmt is None else fmt == "binary")
    click.echo(f"wrote {dst} ({n} bytes)")


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


def _positive_float(ctx: click.Context, param: click.Parameter, value: float) -> float:
    if not value > 0:
        raise click.BadParameter(f"must be positive, got {value}")
    return value


def view_options(f):
    """Options shared by every command that draws a stroke set: which cameras and how to draw."""
    opts = [
        click.option("--views", type=int, default=36, show_default=True,
                     help="Number of orbit cameras around the recorded up axis."),
        click.option("--cameras", "scene_dir", type=click.Path(path_type=Path),
                     help="Draw the cameras of this dataset folder instead of an orbit."),
        click.option("--split", default="test", show_default=True, help="Dataset split for --cameras."),
        click.option("--size", callback=_parse_size, help="Image size W or WxH in pixels (default: recorded)."),
        click.option("--projection", type=click.Choice(["persp", "ortho"]), default="persp", show_default=True),
        click.option("--tolerance", type=float, default=0.05, show_default=True, callback=_positive_float,
                     help="Max distance in px between drawn cubics and the exact projection."),
        click.option("--hidden", type=click.Choice(["show", "dash", "hide"]), default="hide", show_default=True,
                     help="Parts behind the superquadric volume."),
        click.option("--no-silhouettes", is_flag=True, help="Leave out superquadric silhouettes."),
        click.option("--no-curves", is_flag=True, help="Leave out the Bézier curves."),
    ]
    for opt in reversed(opts):
        f = opt(f)
    return f


def _draw_options(tolerance: float, hidden: str, no_silhouettes: bool, no_curves: bool):
    from .exporters import DrawOptions

    return DrawOptions(tolerance=tolerance, hidden=hidden, curves=not no_curves, silhouettes=not no_silhouettes)


@cli.command()
@click.argument("strokes", type=click.Path(path_type=Path))
@click.option("-o", "--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), required=True,
              help="Output folder (view_000.svg, ...).")
@click.option("--svg/--no-svg", "want_svg", default=None, help="Write SVG files (default unless only --png/--pdf).")
@click.option("--png", is_flag=True, help="Also write PNG files (cairosvg).")
@click.option("--pdf", is_flag=True, help="Also write PDF files (cairosvg).")
@click.option("--sheet", type=click.Path(dir_okay=False, path_type=Path), help="Write all views in one grid PNG.")
@click.option("--background", default="white", show_default=True,
              help="PNG/PDF background: a colour or 'transparent'.")
@view_options
def export(strokes: Path, out_dir: Path, want_svg: bool | None, png: bool, pdf: bool, sheet: Path | None,
           background: str, views: int, scene_dir: Path | None, split: str, size, projection: str, tolerance: float,
           hidden: str, no_silhouettes: bool, no_curves: bool) -> None:
    """Draw STROKES for orbit (or dataset) cameras as exact SVG paths, PNG, PDF and a contact sheet."""
    from .exporters import ExportOptions, export_cameras, export_views
    from .strokes import read_strokes

    if views < 1:
        raise click.BadParameter(f"must be at least 1, got {views}", param_hint="--views")
    s = read_strokes(strokes)
    cams = export_cameras(s, views, scene_dir, split, size, "orthographic" if projection == "ortho" else "perspective")
    svg = want_svg if want_svg is not None else not (png or pdf)
    opts = ExportOptions(svg=svg, png=png, pdf=pdf, sheet=sheet,
                         background=None if background == "transparent" else background,
                         draw=_draw_options(tolerance, hidden, no_silhouettes, no_curves), source=str(strokes))
    with _progress(len(cams), "drawing") as bar:
        files = export_views(s, cams, out_dir, opts, progress=lambda k, n: bar.update(1))
    click.echo(f"wrote {len(files)} files for {len(cams)} views to {out_dir}" + (f" and sheet {sheet}" if sheet else ""))


def _progress(total: int, desc: str):
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit="view", leave=False, disable=not sys.stderr.isatty())


def main() -> None:
    """Console-script entry point."""
    cli(prog_name="doodle")


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
