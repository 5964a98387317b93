"""Plotter-ready SVG: joined strokes, pen-up travel, paper units; read back by vpype when it is installed."""

from __future__ import annotations

import shutil
import subprocess

import numpy as np
import pytest
from click.testing import CliRunner

from doodle.cameras import Camera
from doodle.cli import cli
from doodle.exporters.drawing import Drawing, PathOp
from doodle.exporters.plotter import chains, plot_order, pen_up_travel, plotter_svg, PlotterOptions
from doodle.strokes import write_strokes

from helpers import random_strokes


def _line(a, b) -> np.ndarray:
    """One straight cubic piece ``(1, 4, 2)`` from ``a`` to ``b``."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    return np.array([[a, a + (b - a) / 3, a + 2 * (b - a) / 3, b]])


def _drawing(*subpaths, layer="curves") -> Drawing:
    cam = Camera(100.0, 100.0, 50.0, 50.0, 100, 100, np.eye(3), np.array([0, 0, 4.0]))
    return Drawing(cam, [PathOp(f"curve-{k:03d}", layer, [sp], [False]) for k, sp in enumerate(subpaths)], 1.5)


def test_pieces_that_continue_each_other_are_one_path_and_corners_are_not():
    d = _drawing(_line((10, 10), (40, 10)), _line((40.5, 10.2), (80, 11)),  # continues within a pixel
                 _line((80, 11), (80, 60)),  # a right-angle corner: a new stroke
                 _line((10, 90), (11, 90)))  # 1 px: a dot a pen would make
    out = chains(d)
    assert len(out) == 2
    lengths = sorted(len(c) for c in out)
    assert lengths == [1, 2]
    joined = next(c for c in out if len(c) == 2)
    assert np.allclose(joined[1, 0], joined[0, 3])  # the joint is snapped: no gap


def test_plotter_paths_turn_corners_and_prefer_the_smooth_continuation():
    """A plotter's pen stays down at a corner; where a straight continuation and a corner meet at one end,
    the straight one is taken."""
    d = _drawing(_line((10, 10), (40, 10)), _line((40, 10), (40, 60)),  # a corner
                 _line((40, 10), (80, 10)))  # and the straight way on
    svg = plotter_svg(d)
    assert svg.count("<path") == 2
    (straight,) = [c for c in chains(d, max_turn_deg=180.0) if len(c) == 2]
    assert sorted([tuple(straight[0, 0]), tuple(straight[-1, 3])]) == [(10, 10), (80, 10)]


def test_a_loop_in_pieces_is_one_closed_path():
    d = _drawing(_line((10, 10), (50, 10)), _line((50, 10), (30, 40)), _line((30, 40), (10, 10)))
    (c,) = chains(d, max_turn_deg=180.0)
    assert len(c) == 3 and np.allclose(c[0, 0], c[-1, 3])


def test_reversed_pieces_join_too():
    d = _drawing(_line((10, 10), (40, 10)), _line((70, 10), (40.3, 10)))  # the second drawn backwards
    (c,) = chains(d)
    ends = {tuple(np.round(c[0, 0])), tuple(np.round(c[-1, 3]))}
    assert ends == {(10.0, 10.0), (70.0, 10.0)}


def test_plot_order_shortens_pen_up_travel_and_keeps_every_stroke():
    rng = np.random.default_rng(0)
    paths = [_line(rng.uniform(0, 500, 2), rng.uniform(0, 500, 2)) for _ in range(40)]
    ordered = plot_order(paths)
    assert pen_up_travel(ordered) < 0.5 * pen_up_travel(paths)
    key = lambda p: tuple(sorted([tuple(p[0, 0].round(6)), tuple(p[-1, 3].round(6))]))  # noqa: E731
    assert sorted(map(key, ordered)) == sorted(map(key, paths))


def test_plotter_svg_is_on_paper_in_millimetres():
    d = _drawing(_line((10, 10), (40, 10)), _line((40, 10), (70, 10)))
    svg = plotter_svg(d, PlotterOptions(paper_mm=(210, 297)))
    assert 'width="210mm"' in svg and 'height="297mm"' in svg and 'viewBox="0,0,210,297"' in svg
    assert svg.count("<path") == 1 and 'fill="none"' in svg and 'stroke="black"' in svg


def test_plotter_pen_is_its_width_on_paper():
    """The pen's width is millimetres on the paper, not scaled with the drawing: a 3 mm pen on A4 inks a band
    3 mm wide (rasterised at 10 px/mm), and the path's coordinates are the paper's."""
    import io
    import re

    from PIL import Image

    from doodle.exporters.raster import svg_to_png

    d = _drawing(_line((10, 50), (90, 50)))
    svg = plotter_svg(d, PlotterOptions(paper_mm=(210, 297), pen_mm=3.0))
    assert "transform" not in svg
    xs = [float(v) for v in re.search(r' d="M([-\d.]+) ', svg).groups()]
    assert 10 <= xs[0] <= 200
    ink = np.asarray(Image.open(io.BytesIO(svg_to_png(svg, size=(2100, 2970)))).convert("L")) < 128
    column = ink[:, ink.any(axis=0).nonzero()[0].mean().astype(int)]
    assert abs(column.sum() - 30) <= 2


def test_export_plotter_and_vpype_reads_it(tmp_path):
    src = tmp_path / "s.doodle"
    write_strokes(src, random_strokes(5, n_curves=12, n_sq=3))
    r = CliRunner().invoke(cli, ["export", str(src), "--plotter", "--paper", "210x297", "--views", "3",
                                 "--size", "256", "-o", str(tmp_path / "v")])
    assert r.exit_code == 0, r.output
    files = sorted((tmp_path / "v").glob("*.svg"))
    assert len(files) == 3
    r = CliRunner().invoke(cli, ["export", str(src), "--paper", "210x297", "-o", str(tmp_path / "w")])
    assert r.exit_code == 2 and "--plotter" in r.output
    if shutil.which("vpype") is None:
        pytest.skip("vpype is not installed")
    for f in files:
        out = subprocess.run(["vpype", "read", str(f), "stat"], capture_output=True, text=True, timeout=120)
        assert out.returncode == 0, out.stderr[-1000:]
        count = int(next(ln for ln in out.stdout.splitlines() if "Path count" in ln).split(":")[1])
        ours = f.read_text().count("<path")
        # vpype may cut a path where it turns back on itself; it reads every one of ours
        assert ours <= count <= ours + max(2, ours // 10), (count, ours)
