"""``doodle eval`` on line drawings: any SVGs (Blender Freestyle's, a hand drawing) get the stroke metrics."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from click.testing import CliRunner

from doodle.cli import cli
from doodle.evaluate import evaluate_svgs
from doodle.scenes import load_scene


def _outline_svg(mask: np.ndarray, shift: float = 0.0) -> str:
    """An SVG of the mask's outline (optionally shifted right by ``shift`` px) at the mask's size."""
    from skimage.measure import find_contours

    h, w = mask.shape
    paths = []
    for c in find_contours(mask.astype(float), 0.5):
        pts = " ".join(f"{x + 0.5 + shift:.2f},{y + 0.5:.2f}" for y, x in c)
        paths.append(f'<polyline fill="none" stroke="black" stroke-width="1.5" points="{pts}"/>')
    return f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}">{"".join(paths)}</svg>'


def test_outline_drawings_score_as_outlines_at_any_size(snowman_dir: Path):
    test = load_scene(snowman_dir, split="test")
    exact = [_outline_svg(m) for m in test.masks]
    m = evaluate_svgs(exact, test, size=64)  # drawn at 128 px, measured at 64: scaled as rasterised
    assert m["silhouette_recall"] > 0.95 and m["line_precision"] > 0.9, m
    off = evaluate_svgs([_outline_svg(mk, shift=20) for mk in test.masks], test, size=64)
    assert off["silhouette_recall"] < 0.6 and off["line_precision"] < m["line_precision"] - 0.2, off
    assert len(m["per_view"]) == len(test.cameras)


def test_cli_scores_a_folder_of_drawings(snowman_dir: Path, tmp_path: Path):
    test = load_scene(snowman_dir, split="test")
    folder = tmp_path / "drawings"
    folder.mkdir()
    for k, mk in enumerate(test.masks):  # numbers compared as numbers: view_2 before view_10
        (folder / f"view_{[2, 10, 11, 12][k]}.svg").write_text(_outline_svg(mk, shift=0 if k else 20))
    r = CliRunner().invoke(cli, ["eval", str(folder), str(snowman_dir), "--size", "64", "--json", "-"])
    assert r.exit_code == 0, r.output
    m = json.loads(r.stdout)
    assert m["views"] == len(test.cameras) and m["per_view"][0]["line_precision"] < m["per_view"][1]["line_precision"]

    (folder / "view_2.svg").write_text("<svg")  # not a drawable SVG
    r = CliRunner().invoke(cli, ["eval", str(folder), str(snowman_dir), "--size", "64"])
    assert r.exit_code == 2 and "view_2.svg" in r.output and len(r.output.strip().splitlines()) == 1, r.output
    (folder / "view_2.svg").unlink()  # one drawing short
    r = CliRunner().invoke(cli, ["eval", str(folder), str(snowman_dir)])
    assert r.exit_code == 2 and "3 SVG drawings for the 4 cameras" in r.output, r.output
    r = CliRunner().invoke(cli, ["eval", str(tmp_path), str(snowman_dir)])  # no drawings at all
    assert r.exit_code == 2 and "no .svg drawings" in r.output, r.output


def test_the_frame_that_cuts_the_object_is_not_its_outline():
    """Silhouette recall counts the outline's pixels, not the frame's edge where the object runs out of the
    photo: a drawing of the object's outline alone has recall 1 (it was 0.82 with the edge counted); and a line
    drawn along that edge is not precise (the reference line map left the edge in until this release)."""
    from doodle.arrays import silhouette_boundary
    from doodle.evaluate import _view_row

    mask = np.zeros((64, 64), bool)
    mask[20:, 16:48] = True  # a box standing out of the bottom of the frame
    outline = np.zeros_like(mask)
    outline[20, 16:48] = outline[20:, 16] = outline[20:, 47] = True
    assert (silhouette_boundary(mask) == outline).all()
    image = np.full((64, 64, 3), 255, np.uint8)
    image[mask] = 60
    row = _view_row("v", outline, image, mask, 2.0)
    assert row["silhouette_recall"] == 1.0
    # nor is it a reference line for precision: ink along the frame's edge is on nothing
    frame_ink = np.zeros_like(mask)
    frame_ink[63, 20:44] = True
    assert _view_row("v", frame_ink, image, mask, 2.0)["line_precision"] == 0.0
