import json
import re
from pathlib import Path

import click
import numpy as np
import pytest
from click.testing import CliRunner

from doodle import __version__
from doodle.cli import cli
from doodle.strokes import read_strokes, write_strokes

from helpers import random_strokes

README = Path(__file__).resolve().parents[1] / "README.md"


@pytest.fixture
def runner():
    return CliRunner()


def test_version(runner):
    r = runner.invoke(cli, ["--version"])
    assert r.exit_code == 0 and __version__ in r.output


def test_every_command_has_help_and_is_documented(runner):
    readme = README.read_text()
    for name, cmd in cli.commands.items():
        assert cmd.help, name
        assert runner.invoke(cli, [name, "--help"]).exit_code == 0
        assert re.search(rf"doodle {name}\b", readme), f"`doodle {name}` missing from README"


def test_fit_help_gives_each_detail_levels_budget(runner):
    from doodle.fit.config import DETAIL_LEVELS

    text = " ".join(runner.invoke(cli, ["fit", "--help"]).output.split())
    for name, level in DETAIL_LEVELS.items():
        assert f"{name} {level.curves} + {level.superquadrics}" in text


def test_info_and_json(runner, tmp_path):
    p = tmp_path / "s.doodle"
    write_strokes(p, random_strokes())
    r = runner.invoke(cli, ["info", str(p)])
    assert r.exit_code == 0 and "curves          32" in r.output and "binary" in r.output
    d = json.loads(runner.invoke(cli, ["info", "--json", str(p)]).output)
    assert d["curves"] == 32 and d["superquadrics"] == 8 and d["bytes"]["binary"] <= 1024
    assert d["outlines_drawn"] == 8 and d["outline_cells_left_out"] == 0


def test_info_counts_drawn_outlines_and_cells_left_out(runner, tmp_path):
    s = random_strokes(n_sq=3)
    s.superquadrics.outline = np.array([True, False, True])
    s.superquadrics.outline_cells = np.ones((3, 8, 16), bool)
    s.superquadrics.outline_cells[0, :2] = False  # 32 cells of a drawn one
    s.superquadrics.outline_cells[1, :] = False  # an occluder's cells draw nothing anyway
    p = tmp_path / "s.doodle"
    write_strokes(p, s)
    r = runner.invoke(cli, ["info", str(p)])
    assert "superquadrics   3 (2 outlines drawn, 32 of their surface cells left out)" in r.output, r.output


def test_info_describes_the_voxel_volumes(runner, tmp_path):
    from doodle.strokes.model import Voxels

    s = random_strokes()
    s.hull = Voxels(np.zeros(3), 0.05, np.eye(3), np.ones((4, 5, 6), bool))
    p = tmp_path / "s.doodle"
    write_strokes(p, s)
    r = runner.invoke(cli, ["info", str(p)])
    assert "hull            4×5×6 voxels of 0.05 (120 occupied): every view draws its outline" in r.output, r.output
    assert "occluder" not in r.output
    d = json.loads(runner.invoke(cli, ["info", "--json", str(p)]).output)
    assert d["hull"] == {"shape": [4, 5, 6], "voxel": 0.05, "occupied": 120} and d["occluder"] is None


def test_info_corrupt_file_one_line_exit_2(runner, tmp_path):
    p = tmp_path / "bad.doodle"
    p.write_text('{"format": "doodle-strokes", "version": 1, "scene": {"up": [0, 0, "x"]}}')
    r = runner.invoke(cli, ["info", str(p)])
    assert r.exit_code == 2
    assert r.output.strip().count("\n") == 0 and "bad.doodle" in r.output and "scene.up[2]" in r.output
    assert "Traceback" not in r.output


def test_convert_round_trip(runner, tmp_path):
    src = tmp_path / "a.doodle"
    write_strokes(src, random_strokes())
    assert runner.invoke(cli, ["convert", str(src), str(tmp_path / "b.doodleb")]).exit_code == 0
    assert runner.invoke(cli, ["convert", str(tmp_path / "b.doodleb"), str(tmp_path / "c.json"), "--to", "json"]).exit_code == 0
    assert len(read_strokes(tmp_path / "c.json").curves) == 32


def test_convert_bad_input_keeps_output(runner, tmp_path):
    dst = tmp_path / "out.doodleb"
    dst.write_bytes(b"precious")
    (tmp_path / "bad.doodle").write_text("{")
    r = runner.invoke(cli, ["convert", str(tmp_path / "bad.doodle"), str(dst)])
    assert r.exit_code == 2 and dst.read_bytes() == b"precious"


def test_sample_writes_scene(runner, tmp_path):
    r = runner.invoke(cli, ["sample", "lamp", str(tmp_path / "lamp"), "--train", "2", "--test", "1", "--size", "32"])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "lamp" / "train" / "r_1.png").exists() and (tmp_path / "lamp" / "ground_truth.json").exists()
    r = runner.invoke(cli, ["sample", "nope", str(tmp_path / "x")])
    assert r.exit_code == 2 and "unknown sample scene" in r.output


def test_demo_offers_every_sample_scene():
    """The CLI lists the scenes literally (importing the renderer would slow every command's start): it must
    keep up with ``SCENES``."""
    from doodle.samples import SCENES

    option = next(p for p in cli.commands["demo"].params if p.name == "scene")
    assert list(option.type.choices) == list(SCENES)
    assert ", ".join(SCENES) in cli.commands["sample"].help


def test_every_option_has_help_and_commands_come_in_the_order_a_user_meets_them(runner):
    from doodle.cli import COMMAND_ORDER

    for name, cmd in cli.commands.items():
        assert cmd.short_help and len(cmd.short_help) <= 60, name
        for p in cmd.params:
            if isinstance(p, click.Option):
                assert p.help, f"{name} {p.name}"
    text = runner.invoke(cli, ["--help"]).output
    listed = [ln.split()[0] for ln in text.split("Commands:")[1].splitlines() if ln.startswith("  ") and ln.split()
              and not ln.startswith("    ")]
    assert listed == list(COMMAND_ORDER)
    assert "..." not in text.split("Commands:")[1]  # no one-line help cut short


def test_info_says_how_the_file_is_stored_and_how_to_rewrite_an_earlier_version(runner, tmp_path):
    old = Path(__file__).parent / "data" / "binary-v2.doodleb"
    r = runner.invoke(cli, ["info", str(old)])
    assert r.exit_code == 0 and "on disk (binary version 2; `doodle convert` rewrites it as version 5)" in r.output
    new = tmp_path / "new.doodleb"
    assert runner.invoke(cli, ["convert", str(old), str(new)]).exit_code == 0
    assert json.loads(runner.invoke(cli, ["info", "--json", str(new)]).output)["encoding"] == "binary 5"
    text = tmp_path / "s.doodle"
    assert runner.invoke(cli, ["convert", str(new), str(text)]).exit_code == 0
    assert "on disk (JSON)" in runner.invoke(cli, ["info", str(text)]).output
