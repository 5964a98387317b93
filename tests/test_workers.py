"""Worker processes: no deadlock after torch ran in the parent, no re-run of the caller's script, no orphans."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
import uuid
from functools import partial
from pathlib import Path

import pytest

from doodle.workers import map_chunks

REPO = Path(__file__).resolve().parents[1]


def _square_all(offset: int, chunk: list[int]) -> list[int]:
    return [x * x + offset for x in chunk]


def _fail_on_seven(chunk: list[int]) -> list[int]:
    if 7 in chunk:
        raise ValueError("seven")
    return chunk


class TestMapChunks:
    @pytest.mark.parametrize("workers", [1, 2, 3])
    @pytest.mark.parametrize("n", [0, 1, 5, 37])
    def test_results_in_item_order(self, workers, n):
        assert list(map_chunks(partial(_square_all, 1), list(range(n)), workers)) == [x * x + 1 for x in range(n)]

    def test_progress_reaches_the_total(self):
        seen = []
        list(map_chunks(partial(_square_all, 0), list(range(40)), 2, progress=seen.append))
        assert seen and seen[-1] == 40 and seen == sorted(seen)

    def test_a_job_error_reaches_the_caller(self):
        with pytest.raises(ValueError, match="seven"):
            list(map_chunks(_fail_on_seven, list(range(40)), 2))


def _run_script(code: str, tmp_path: Path, timeout: float, env: dict | None = None) -> subprocess.CompletedProcess:
    script = tmp_path / "script.py"
    script.write_text(textwrap.dedent(code))
    return subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True,
                          timeout=timeout, env={**os.environ, **(env or {})})


FIT_THEN_DRAW = """
    # A plain script, no `if __name__ == "__main__"` guard: fit (torch's thread pool runs), then export and
    # animate with worker processes, several times in one process.
    import sys
    import numpy as np
    import torch
    sys.path.insert(0, {tests!r})
    from helpers import random_strokes
    from doodle.animate import AnimateOptions, animate
    from doodle.exporters import ExportOptions, export_cameras, export_views

    strokes = random_strokes(0, 12, 3)
    for k in range(3):
        x = torch.randn(256, 256)
        for _ in range(10):
            x = torch.tanh(x @ x.T / 256)  # OpenMP threads in the parent, as a fit leaves them
        export_views(strokes, export_cameras(strokes, 12, size=(128, None)), f"out{{k}}", ExportOptions(png=True, workers=2))
        animate(strokes, f"turn{{k}}.gif", AnimateOptions(frames=8, size=96, workers=2))
        print("round", k, flush=True)
"""


def test_fit_then_export_and_animate_in_one_process_never_hangs(tmp_path):
    for attempt in range(2):
        (tmp_path / str(attempt)).mkdir()
        result = _run_script(FIT_THEN_DRAW.format(tests=str(REPO / "tests")), tmp_path / str(attempt), timeout=120)
        assert result.returncode == 0, result.stderr[-2000:]
        assert result.stdout.split() == ["round", "0", "round", "1", "round", "2"]  # the script ran once, not per worker
        assert len(list((tmp_path / str(attempt) / "out2").glob("*.svg"))) == 12


LONG_EXPORT = """
    import sys
    sys.path.insert(0, {tests!r})
    from helpers import random_strokes
    from doodle.exporters import ExportOptions, export_cameras, export_views

    strokes = random_strokes(1, 32, 8)
    print("start", flush=True)
    export_views(strokes, export_cameras(strokes, 2000, size=(512, None)), "out", ExportOptions(png=True, workers=3))
"""


def _processes_with(marker: str) -> list[int]:
    found = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit() and int(d.name) != os.getpid():
            try:
                if marker.encode() in (d / "environ").read_bytes():
                    found.append(int(d.name))
            except OSError:
                pass
    return found


@pytest.mark.skipif(not Path("/proc/self/environ").exists(), reason="needs /proc to find processes")
def test_workers_die_with_a_killed_parent(tmp_path):
    marker = f"DOODLE_TEST_{uuid.uuid4().hex}"
    script = tmp_path / "script.py"
    script.write_text(textwrap.dedent(LONG_EXPORT.format(tests=str(REPO / "tests"))))
    proc = subprocess.Popen([sys.executable, str(script)], cwd=tmp_path, stdout=subprocess.PIPE, text=True,
                            env={**os.environ, marker: "1"})
    try:
        assert proc.stdout.readline().strip() == "start"
        deadline = time.monotonic() + 60
        while len(_processes_with(marker)) < 3 and time.monotonic() < deadline:  # parent + fork server + worker
            time.sleep(0.1)
        assert len(_processes_with(marker)) >= 3, "the workers never started"
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    deadline = time.monotonic() + 10
    while _processes_with(marker) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert _processes_with(marker) == []
