"""The fit as stages: a real Ctrl-C in each stage of a default fit leaves a readable stroke file and exit code
130; ``--resume`` then gives exactly the file an uninterrupted fit gives."""

from __future__ import annotations

import os
import signal

import numpy as np
import pytest
from click.testing import CliRunner

from doodle.cli import cli
from doodle.fit import FitConfig, fit
from doodle.scenes import load_scene
from doodle.strokes import read_strokes
from doodle.strokes.binary import encode

#: A default fit, small: the compact abstraction draws the snowman's balls, curves its nose and arms.
SMALL = ["--size", "64", "--evidence-size", "96", "--evidence-voxels", "64", "--abstraction-steps", "40"]
STAGES = ("prepare", "volume", "discover", "superquadrics", "curves", "assemble")


def _bytes(path) -> bytes:
    s = read_strokes(path)
    s.provenance.pop("seconds")
    return encode(s)


@pytest.fixture(scope="module")
def uninterrupted(snowman_dir, tmp_path_factory) -> bytes:
    out = tmp_path_factory.mktemp("fit") / "s.doodleb"
    r = CliRunner().invoke(cli, ["fit", str(snowman_dir), "-o", str(out), *SMALL])
    assert r.exit_code == 0, r.output
    s = read_strokes(out)
    assert s.superquadrics.drawn.any() and len(s.curves)  # the default path: both kinds of stroke
    return _bytes(out)


@pytest.fixture(autouse=True)
def _ctrl_c_reaches_python():
    """Python's own Ctrl-C handler for each test: a suite started with SIGINT ignored (``cmd &`` in a script,
    some CI runners) would ignore the tests' Ctrl-C, as it does a user's."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


def _ctrl_c_at(monkeypatch, stage: str) -> None:
    """Send this process a real SIGINT as ``stage`` begins (as a user's Ctrl-C would arrive)."""
    from doodle.fit import pipeline
    from doodle.fit.stages import assemble, curves, discover, superquadrics, volume

    owner, name = {"prepare": (pipeline, "prepare"), "assemble": (assemble, "assemble"), "volume": (volume, "run"),
                   "discover": (discover, "run"), "superquadrics": (superquadrics, "run"),
                   "curves": (curves, "run")}[stage]
    original = getattr(owner, name)

    def interrupted(*args, **kwargs):
        os.kill(os.getpid(), signal.SIGINT)
        return original(*args, **kwargs)

    monkeypatch.setattr(owner, name, interrupted)


@pytest.mark.parametrize("stage", STAGES)
def test_ctrl_c_in_each_stage_writes_what_the_finished_stages_give_and_resume_finishes(
        stage, snowman_dir, tmp_path, monkeypatch, uninterrupted):
    out = tmp_path / "s.doodleb"
    _ctrl_c_at(monkeypatch, stage)
    r = CliRunner().invoke(cli, ["fit", str(snowman_dir), "-o", str(out), *SMALL])
    monkeypatch.undo()
    assert r.exit_code == 130, r.output
    assert "interrupted" in r.output and (tmp_path / "s.doodleb.ckpt").exists()
    s = read_strokes(out)
    if stage in ("prepare", "volume", "discover"):  # held until the volume is carved: its outline
        assert s.hull is not None and s.hull.occupied.any() and not len(s.curves) and not len(s.superquadrics)
    elif stage == "superquadrics":  # discovery's strong curves, and the hull's outline where no superquadric is
        assert len(s.curves) and s.hull is not None and not len(s.superquadrics)
    else:  # the superquadrics are settled
        assert s.superquadrics.drawn.any() and len(s.curves) and s.hull is None
    if stage == "assemble":  # held until the strokes were complete
        assert _bytes(out) == uninterrupted
    _abstraction_stops()
    r = CliRunner().invoke(cli, ["fit", str(snowman_dir), "-o", str(out), *SMALL, "--resume"])
    assert r.exit_code == 0, r.output
    assert _bytes(out) == uninterrupted and not (tmp_path / "s.doodleb.ckpt").exists()


def test_a_fit_is_the_same_bytes_in_another_process(snowman_dir, tmp_path, uninterrupted):
    """``doodle fit`` run as its own process (a fresh interpreter, a random hash seed) writes the file the
    in-process fit wrote: nothing in a fit depends on the process."""
    import subprocess
    import sys

    out = tmp_path / "s.doodleb"
    r = subprocess.run([sys.executable, "-m", "doodle", "fit", str(snowman_dir), "-o", str(out), *SMALL],
                       capture_output=True, text=True, timeout=240, env={**os.environ, "PYTHONHASHSEED": "random"})
    assert r.returncode == 0, r.stderr[-2000:]
    assert _bytes(out) == uninterrupted


def test_a_second_ctrl_c_stops_at_once_and_writes_nothing(snowman_dir, tmp_path, monkeypatch):
    """While the volume is carved a first Ctrl-C is held; a second one stops the fit there, with nothing to
    write yet: the output file stays as it was."""
    from doodle.fit.stages import volume

    original = volume.run

    def twice(state):
        os.kill(os.getpid(), signal.SIGINT)
        os.kill(os.getpid(), signal.SIGINT)
        return original(state)

    monkeypatch.setattr(volume, "run", twice)
    out = tmp_path / "s.doodleb"
    out.write_bytes(b"earlier")
    r = CliRunner().invoke(cli, ["fit", str(snowman_dir), "-o", str(out), *SMALL])
    assert r.exit_code == 130 and out.read_bytes() == b"earlier"


def test_a_fit_in_another_thread_is_interrupted_as_before(snowman_dir):
    """Only the main thread can hold a Ctrl-C: elsewhere the library's behaviour is a plain
    ``KeyboardInterrupt`` turned into an interrupted fit at the stage it reaches."""
    import threading

    from doodle.fit.stages import discover

    results = []
    original = discover.run

    def interrupted(state):
        raise KeyboardInterrupt

    discover.run = interrupted
    try:
        worker = threading.Thread(target=lambda: results.append(
            fit(load_scene(snowman_dir), FitConfig(size=64, evidence_size=96, evidence_voxels=64), progress=False,
                log=lambda m: None)))
        worker.start()
        worker.join(120)
    finally:
        discover.run = original
    (res,) = results
    assert res.interrupted and res.strokes.hull is not None and not len(res.strokes.curves)
    _abstraction_stops()  # started beside discovery, cancelled with the fit


def _abstraction_stops(within: float = 30.0) -> None:
    """The thread of an abstraction started beside discovery ends once the fit that started it ended."""
    import threading
    import time

    deadline = time.monotonic() + within
    while any(t.name == "doodle-superquadrics" for t in threading.enumerate()):
        assert time.monotonic() < deadline, "the abstraction's thread still runs after its fit ended"
        time.sleep(0.05)


def test_the_abstraction_beside_discovery_is_the_one_after_it(snowman_dir, tmp_path, monkeypatch, uninterrupted):
    """The volume's abstraction starts in its own thread once the volume is carved and runs while discovery
    does; the file is the one a fit gives that starts it only when discovery is done."""
    import threading
    import time

    from doodle.fit.stages import discover, superquadrics
    from doodle.fit.volume import abstraction

    seen: dict[str, object] = {}
    abstract, discover_run, begin = abstraction.abstract_volume, discover.run, superquadrics.begin

    def abstract_noted(*args, **kwargs):
        seen["thread"], seen["started"] = threading.current_thread().name, time.perf_counter()
        return abstract(*args, **kwargs)

    def discover_noted(state):
        discover_run(state)
        seen["discovered"] = time.perf_counter()

    monkeypatch.setattr(abstraction, "abstract_volume", abstract_noted)
    monkeypatch.setattr(discover, "run", discover_noted)
    out = tmp_path / "beside.doodleb"
    r = CliRunner().invoke(cli, ["fit", str(snowman_dir), "-o", str(out), *SMALL])
    assert r.exit_code == 0, r.output
    assert seen["thread"] == "doodle-superquadrics" and seen["started"] < seen["discovered"]
    assert _bytes(out) == uninterrupted
    # started only when its stage comes
    monkeypatch.setattr(superquadrics, "begin", lambda state: begin(state) if "discover" in state.done else None)
    r = CliRunner().invoke(cli, ["fit", str(snowman_dir), "-o", str(out), *SMALL])
    assert r.exit_code == 0, r.output
    assert seen["started"] > seen["discovered"] and _bytes(out) == uninterrupted


def test_work_beside_the_stages_says_its_messages_when_taken_and_stops_when_cancelled():
    import threading

    from doodle.fit.beside import Beside, Cancelled, stopped

    def work(log):
        log("one")
        log("two")
        return 42

    said: list[str] = []
    assert Beside(work, "test").result(said.append) == 42 and said == ["one", "two"]
    stopped()  # outside a Beside: nothing to stop

    running, ended = threading.Event(), threading.Event()

    def forever(log):
        running.set()
        try:
            while True:
                stopped()
        finally:
            ended.set()

    beside = Beside(forever, "test")
    assert running.wait(10)
    beside.cancel()
    assert ended.wait(10)
    with pytest.raises(Cancelled):
        beside.result(said.append)

    def fails(log):
        raise ValueError("in the thread")

    with pytest.raises(ValueError, match="in the thread"):
        Beside(fails, "test").result(said.append)


def test_curves_0_draws_the_outline_or_says_why_not(chair_dir, tmp_path):
    """``--curves 0`` on the chair (thin legs, a slab seat and back): the superquadrics draw too little of it,
    so ``auto`` draws the hull's outline; with ``--outline superquadrics`` it says why nothing is drawn."""
    out = tmp_path / "c.doodleb"
    r = CliRunner().invoke(cli, ["fit", str(chair_dir), "-o", str(out), "--curves", "0", *SMALL])
    assert r.exit_code == 0, r.output
    s = read_strokes(out)
    assert not len(s.curves) and s.hull is not None and s.hull.occupied.any()
    r = CliRunner().invoke(cli, ["fit", str(chair_dir), "-o", str(tmp_path / "x.doodleb"), "--curves", "0",
                                 "--outline", "superquadrics", *SMALL])
    last = r.output.strip().splitlines()[-1]
    assert r.exit_code == 2 and last.startswith("Error: ") and "--curves 0" in last and "Traceback" not in r.output
    assert not (tmp_path / "x.doodleb").exists()


def test_the_stages_report_their_time(snowman_dir):
    res = fit(load_scene(snowman_dir), FitConfig(size=64, evidence_size=96, evidence_voxels=64), progress=False,
              log=lambda m: None)
    assert list(res.stage_seconds) == ["prepare", *STAGES[1:-1], "assemble"]
    assert np.isclose(sum(res.stage_seconds.values()), res.seconds, rtol=0.2, atol=0.5)


def test_max_bytes_leaves_out_curves_until_the_file_fits(snowman_dir, tmp_path, uninterrupted):
    """The same fit under a size a few curves over: a file within it, its curves some of the uninterrupted
    fit's, the superquadrics as they were; the log says how many were left out."""
    from doodle.strokes.binary import decode

    whole = decode(uninterrupted)
    whole.provenance["seconds"] = 99999.99
    cap = len(encode(whole)) - 12
    out = tmp_path / "small.doodleb"
    r = CliRunner().invoke(cli, ["fit", str(snowman_dir), "-o", str(out), *SMALL, "--max-bytes", str(cap)])
    assert r.exit_code == 0, r.output
    assert "left out, the least telling first" in r.output
    assert out.stat().st_size <= cap
    small = read_strokes(out)
    assert 0 < len(small.curves) < len(whole.curves)
    for c in small.curves.control_points:
        assert np.abs(whole.curves.control_points - c).max(axis=(1, 2)).min() < 2e-3  # the binary's quantum
    assert np.allclose(small.superquadrics.drawn, whole.superquadrics.drawn)


def test_a_fit_interrupted_before_the_curves_stage_is_cut_to_max_bytes(snowman_dir, tmp_path, monkeypatch):
    """Stopped in the superquadrics stage, the file holds discovery's curves beside the hull's outline: they
    are cut to ``--max-bytes`` as the curves stage cuts them (the hull's outline, standing in until
    ``--resume``, not counted), a subset of the uncut ones."""
    from dataclasses import replace

    def interrupted(cap: int):
        out = tmp_path / f"s{cap}.doodleb"
        _ctrl_c_at(monkeypatch, "superquadrics")
        r = CliRunner().invoke(cli, ["fit", str(snowman_dir), "-o", str(out), *SMALL, "--max-bytes", str(cap)])
        monkeypatch.undo()
        assert r.exit_code == 130, r.output
        return read_strokes(out)

    whole = interrupted(0)
    assert whole.hull is not None and len(whole.curves) > 2
    cap = len(encode(replace(whole, hull=None))) - 12
    cut = interrupted(cap)
    assert cut.hull is not None and 0 < len(cut.curves) < len(whole.curves)
    assert len(encode(replace(cut, hull=None))) <= cap
    for c in cut.curves.control_points:
        assert np.abs(whole.curves.control_points - c).max(axis=(1, 2)).min() < 2e-3
