"""The README's promises: its length, its CI marker, and its quick start, run as written."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


def _block_after(heading: str, lang: str = "bash") -> str:
    text = README.read_text(encoding="utf-8")
    section = text.split(f"\n## {heading}\n", 1)[1].split("\n## ", 1)[0]
    return re.search(rf"```{lang}\n(.*?)```", section, re.S).group(1)


def test_readme_is_short_and_keeps_the_ci_marker():
    text = README.read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 300
    assert "<!-- test-command -->\n```bash\npip install -e '.[test]' && pytest\n```" in text


def test_readme_links_resolve():
    text = README.read_text(encoding="utf-8")
    for target in re.findall(r"\]\(((?:docs/)[^)#]+)", text):
        assert (README.parent / target).exists(), target


@pytest.mark.timeout(600)
def test_quick_start_runs_as_written(tmp_path, monkeypatch):
    """Every command of the quick start, in order, in an empty folder: each exits 0 and writes what it says.
    The sample scene is made smaller than the quick start's (12 views at 128 px) and the fits' grids with it
    (96 voxels, 40 silhouette and 40 abstraction steps, at most 2 plain superquadrics), so the three fits take
    seconds; every command runs as written. The first runs the installed ``doodle`` executable; the others run
    its command line in this process (the same arguments through the same ``click`` group: the interpreter's
    start and torch's import, 3 s a command, are paid once). What the fits draw is tested elsewhere."""
    from click.testing import CliRunner

    from doodle.cli import cli

    commands = [line.split("  #")[0].strip() for line in _block_after("Quick start").splitlines()]
    commands = [c for c in commands if c]
    assert commands[0].startswith("doodle sample") and any(c.startswith("doodle fit") for c in commands)
    commands[0] += " --train 12 --test 3 --size 128"
    small = " --evidence-voxels 96 --sq-iterations 40 --abstraction-steps 40 --max-superquadrics 2 --no-deform"
    commands = [c + small if c.startswith("doodle fit") else c for c in commands]
    doodle = str(Path(sys.executable).with_name("doodle"))
    first = commands[0].split()
    r = subprocess.run([doodle if Path(doodle).exists() else "doodle", *first[1:]], cwd=tmp_path,
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0 and "Traceback" not in r.stderr, (commands[0], r.stderr[-2000:])
    monkeypatch.chdir(tmp_path)
    for command in commands[1:]:
        assert command.startswith("doodle ")
        r = CliRunner().invoke(cli, command.split()[1:])
        assert r.exit_code == 0 and r.exception is None, (command, r.output[-2000:])
    for made in ("cow.doodleb", "cow-low.doodleb", "cow-hull.doodleb", "cow.gif", "sheet.png", "views"):
        assert (tmp_path / made).exists(), made
    assert (tmp_path / "cow.doodleb").stat().st_size <= 2048
