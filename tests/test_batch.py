"""``doodle batch``: the manifest's checks, the local engine on small procedural scenes (one broken), a rerun
that does no work, a killed run resumed to identical outputs, and the Ray engine (skips without Ray)."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from click.testing import CliRunner

from doodle.batch import BatchOptions, load_manifest, run_batch
from doodle.batch.job import fingerprint
from doodle.batch.runner import plan
from doodle.cli import cli
from doodle.errors import DoodleError

MANIFEST = """
[defaults]
detail = "low"
evidence_voxels = 64
abstraction_steps = 40
views = 3
size = 96
frames = 4
gif_size = 64

[[objects]]
scene = "snowman"

[[objects]]
scene = "broken"

[[objects]]
scene = "parcel"
name = "box"
views = 2
model3d = "glb"
"""


def _write_scenes(root: Path) -> Path:
    from doodle.samples import write_sample

    for name in ("snowman", "parcel"):
        write_sample(name, root / name, n_train=12, n_test=2, size=96)
    (root / "broken").mkdir()
    (root / "broken" / "transforms_train.json").write_text('{"frames": "not a list"}')
    manifest = root / "objects.toml"
    manifest.write_text(MANIFEST)
    return manifest


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """The manifest run once through the CLI, two objects at once with one thread each (what the default is
    on 2 cores): (manifest, output folder, exit code, output)."""
    root = tmp_path_factory.mktemp("batch")
    manifest = _write_scenes(root)
    r = CliRunner().invoke(cli, ["batch", str(manifest), "-o", str(root / "out"), "--jobs", "2", "--threads", "1"])
    return manifest, root / "out", r.exit_code, r.output


def _outputs(folder: Path) -> dict[str, bytes]:
    """Every file an object's folder holds, its record (timings) left out."""
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file() and p.name != "record.json"}


# ---- the manifest ----------------------------------------------------------------------------------------

def test_manifest_formats_agree(tmp_path):
    (tmp_path / "m.toml").write_text('[defaults]\nviews = 4\n[[objects]]\nscene = "a"\n[[objects]]\nscene = "b"\nname = "bee"\ngif = false\n')
    (tmp_path / "m.json").write_text(json.dumps({"defaults": {"views": 4}, "objects": [
        {"scene": "a"}, {"scene": "b", "name": "bee", "gif": False}]}))
    (tmp_path / "m.csv").write_text("scene,name,views,gif\na,,4,\nb,bee,4,false\n")
    got = [[(o.name, o.scene, o.options) for o in load_manifest(tmp_path / f"m.{s}").objects] for s in ("toml", "json", "csv")]
    assert got[0] == got[1] == got[2]
    (a, _, opt_a), (bee, scene_b, opt_b) = got[0]
    assert (a, bee, scene_b) == ("a", "bee", (tmp_path / "b").resolve())
    assert opt_a["views"] == opt_b["views"] == 4 and opt_a["gif"] is True and opt_b["gif"] is False
    assert opt_a["detail"] == "medium"  # a default of doodle fit's


@pytest.mark.parametrize("text, needle", [
    ('[[objects]]\nscene = "a"\ncolour = 3\n', "unknown option 'colour'"),
    ('[[objects]]\nscene = "a"\nviews = "many"\n', "views must be a whole number"),
    ('[[objects]]\nscene = "a"\ndetail = "ultra"\n', "detail must be"),
    ('[[objects]]\nscene = "a"\n[[objects]]\nscene = "x/a"\n', "name 'a' is also object 1's"),
    ('[[objects]]\nname = "a"\n', "needs a scene"),
    ('[[objects]]\nscene = "a"\nname = "../up"\n', "name '../up' must be"),
    ('[defaults]\nviews = -1\n[[objects]]\nscene = "a"\n', "views must be between"),
    ("[[objects]\n", "not valid TOML"),
    ("[defaults]\n", "no objects listed"),
])
def test_bad_manifest_is_one_line_naming_file_and_object(tmp_path, text, needle):
    (tmp_path / "m.toml").write_text(text)
    with pytest.raises(DoodleError, match="m.toml") as err:
        load_manifest(tmp_path / "m.toml")
    assert needle in str(err.value) and "\n" not in str(err.value)
    r = CliRunner().invoke(cli, ["batch", str(tmp_path / "m.toml"), "-o", str(tmp_path / "out")])
    assert r.exit_code == 2 and needle in r.output and len(r.output.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists()


def test_plan_shares_the_cores():
    assert plan(2) == (2, 1) and plan(16) == (16, 1) and plan(1) == (1, 1)
    assert plan(16, memory=24 * 2 ** 30) == (8, 2)  # 3 GB an object
    assert plan(8, jobs=4) == (4, 2) and plan(8, jobs=3, threads=1) == (3, 1) and plan(8, threads=2) == (4, 2)


def test_fingerprint_follows_options_and_scene_files(tmp_path):
    (tmp_path / "s").mkdir()
    (tmp_path / "s" / "a.png").write_bytes(b"x")
    opts = load_manifest_options()
    fp = fingerprint(tmp_path / "s", opts)
    assert fp == fingerprint(tmp_path / "s", dict(opts))
    assert fp != fingerprint(tmp_path / "s", {**opts, "views": 7})
    (tmp_path / "s" / "doodle-masks").mkdir()
    (tmp_path / "s" / "doodle-masks" / "a.png").write_bytes(b"m")
    (tmp_path / "s" / "doodle-masks" / "doodle-masks.json").write_text("{}")  # masks doodle made: not an edit
    assert fp == fingerprint(tmp_path / "s", opts)
    # a mask fixed by hand (saved after the marker) is an edit, as is a folder without the marker
    os.utime(tmp_path / "s" / "doodle-masks" / "a.png", (time.time() + 5, time.time() + 5))
    hand = fingerprint(tmp_path / "s", opts)
    assert hand != fp
    (tmp_path / "s" / "doodle-masks" / "doodle-masks.json").unlink()
    assert fingerprint(tmp_path / "s", opts) not in (fp, hand)
    shutil.rmtree(tmp_path / "s" / "doodle-masks")
    assert fp == fingerprint(tmp_path / "s", opts)
    (tmp_path / "s" / "a.png").write_bytes(b"xy")
    assert fp != fingerprint(tmp_path / "s", opts)


def load_manifest_options() -> dict:
    from doodle.batch import OPTIONS

    return {k: o.default for k, o in OPTIONS.items()}


# ---- the local engine ------------------------------------------------------------------------------------

def test_batch_makes_the_good_objects_and_records_the_broken_one(made):
    manifest, out, code, output = made
    assert code == 3, output
    summary = json.loads((out / "summary.json").read_text())
    assert (summary["ok"], summary["error"], summary["pending"]) == (2, 1, 0)
    by_name = {r["name"]: r for r in summary["results"]}
    assert by_name["broken"]["status"] == "error" and "frames" in by_name["broken"]["error"]
    assert "\n" not in by_name["broken"]["error"]
    for name, views in (("snowman", 3), ("box", 2)):
        folder = out / name
        assert (folder / "strokes.doodleb").stat().st_size < 2000
        assert len(list((folder / "views").glob("view_*.svg"))) == views
        assert (folder / "turntable.gif").read_bytes()[:6] == b"GIF89a"
        assert json.loads((folder / "metrics.json").read_text())["f_score"] > 0.5
        assert json.loads((folder / "record.json").read_text())["status"] == "ok"
    assert json.loads((out / "broken" / "record.json").read_text())["status"] == "error"
    assert (out / "box" / "strokes.glb").read_bytes()[:4] == b"glTF" and not (out / "snowman" / "strokes.glb").exists()
    from PIL import Image

    assert Image.open(out / "sheet.png").size[0] >= 256 * 2
    index = (out / "index.html").read_text()
    assert 'src="snowman/views/view_000.svg"' in index and 'href="box/turntable.gif"' in index
    assert "2 made, 1 failed" in index and "frames" in index  # the broken object's reason


def test_rerun_does_no_work(made):
    manifest, out, _, _ = made
    before = {p: p.stat().st_mtime_ns for p in out.rglob("*") if p.is_file() and p.parent != out}
    result = run_batch(manifest, out, log=lambda m: None)
    assert result.made == 0 and sorted(result.failed) == ["broken"]
    assert {p: p.stat().st_mtime_ns for p in out.rglob("*") if p.is_file() and p.parent != out} == before


def test_killed_run_resumes_to_identical_outputs(made, tmp_path):
    manifest, reference, _, _ = made
    out = tmp_path / "out"
    # one object at a time, so one is in flight when the first is done; one thread each, as the reference
    # run had (a fit's floats depend on its thread count)
    proc = subprocess.Popen([sys.executable, "-m", "doodle", "batch", str(manifest), "-o", str(out), "--jobs", "1",
                             "--threads", "1"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    deadline = time.time() + 240
    while not (out / "snowman" / "record.json").exists() and time.time() < deadline and proc.poll() is None:
        time.sleep(0.2)
    assert proc.poll() is None, "the batch finished before it could be killed"
    os.kill(proc.pid, signal.SIGKILL)  # mid-run: the broken object or the box is in flight
    proc.wait()
    # the workers look for their parent every 0.25 s, between the fit's calls into C that hold the GIL
    for _ in range(100):
        orphans = subprocess.run(["pgrep", "-s", str(proc.pid)], capture_output=True, text=True).stdout.split()
        if not orphans:
            break
        time.sleep(0.2)
    assert orphans == [], "workers outlived the killed batch"
    result = run_batch(manifest, out, BatchOptions(jobs=1, threads=1), log=lambda m: None)
    assert 1 <= result.made <= 2 and sorted(result.failed) == ["broken"]
    for name in ("snowman", "box"):
        assert _outputs(out / name) == _outputs(reference / name), name
    assert not [p for p in out.iterdir() if p.name.endswith(".tmp")]  # no half-made folder left


# ---- the Ray engine --------------------------------------------------------------------------------------

@pytest.mark.timeout(400)
def test_ray_engine_gives_the_local_engines_outputs(made, tmp_path):
    pytest.importorskip("ray", reason="needs Ray (pip install -e '.[ray]')")
    manifest, reference, _, _ = made
    one = tmp_path / "one.toml"
    one.write_text(MANIFEST.split("[[objects]]")[0] + '[[objects]]\nscene = "%s"\n' % (manifest.parent / "snowman"))
    out = tmp_path / "out"
    r = CliRunner().invoke(cli, ["batch", str(one), "-o", str(out), "--ray", "auto", "--threads", "1"])
    assert r.exit_code == 0, r.output
    assert _outputs(out / "snowman") == _outputs(reference / "snowman")
