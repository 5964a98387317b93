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
    """Turns :class:`DoodleError` (and bad values the library rejects) into one-line user errors."""

    def invoke(self, ctx: click.Context) -> Any:
        try:
            return super().invoke(ctx)
        except DoodleError as exc:
            raise UserError(str(exc).splitlines()[0]) from None


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


def main() -> None:
    """Console-script entry point."""
    cli(prog_name="doodle")


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
