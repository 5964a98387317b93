"""kill -9 during export: the output folder must be entirely old or entirely new, never a mix.

Each trial starts ``export_views`` in a child process over a folder that holds an earlier export (other
views, another style), sends SIGKILL after a random delay spread over the export's whole run (start-up,
drawing, the final swap), and compares the folder with the two complete versions. A later export must clean
up what the killed one left beside the folder.

Target (issue 11): every trial old or new, 0 mixed.
Run: ``python benchmarks/bench_kill.py [--trials 100]``
"""

from __future__ import annotations

import argparse
import hashlib
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

EXPORT = """
    import sys
    from doodle.exporters import ExportOptions, export_cameras, export_views
    from doodle.strokes import read_strokes

    strokes = read_strokes(sys.argv[1])
    views, background = int(sys.argv[3]), sys.argv[4]
    print("start", flush=True)
    export_views(strokes, export_cameras(strokes, views, size=(160, None)), sys.argv[2],
                 ExportOptions(png=True, workers=2, background=background))
    print("done", flush=True)
"""

NEW_BACKGROUND = "#f4efe4"  # the new export differs from the old in every file


def snapshot(folder: Path) -> dict[str, str]:
    """File name → content hash of everything in ``folder`` (empty when it does not exist)."""
    if not folder.is_dir():
        return {}
    return {p.name: hashlib.sha1(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir())}


class KillRig:
    """An old export in ``root/views``, the script for the new one, and both versions' snapshots."""

    def __init__(self, root: Path, strokes_path: Path) -> None:
        self.root, self.strokes = root, strokes_path
        self.script = root / "export.py"
        self.script.write_text(textwrap.dedent(EXPORT))
        self.views = root / "views"
        self._run(root / "old", 8, "#ffffff")
        # how long the new export runs after printing 'start': the window the kills are spread over
        self.window = self._run(root / "new", 12, NEW_BACKGROUND)
        self.old, self.new = snapshot(root / "old"), snapshot(root / "new")
        assert self.old and self.new and self.old != self.new

    def _run(self, out: Path, views: int, background: str) -> float:
        """Export into ``out``; the seconds it ran after printing 'start'."""
        proc = subprocess.Popen([sys.executable, str(self.script), str(self.strokes), str(out), str(views), background],
                                stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        assert proc.stdout.readline().strip() == "start"
        started = time.perf_counter()
        proc.stdout.read()
        proc.stdout.close()
        if proc.wait(timeout=300):
            raise subprocess.CalledProcessError(proc.returncode, proc.args)
        return time.perf_counter() - started

    def start_new_export(self) -> subprocess.Popen:
        """Reset the folder to the old export and start the new one; returns once it printed 'start'."""
        shutil.rmtree(self.views, ignore_errors=True)
        shutil.copytree(self.root / "old", self.views)
        proc = subprocess.Popen([sys.executable, str(self.script), str(self.strokes), str(self.views), "12", NEW_BACKGROUND],
                                stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        assert proc.stdout.readline().strip() == "start"
        return proc

    def trial(self, delay: float) -> str:
        """Kill a new export ``delay`` s after it started drawing; 'old', 'new' or 'mixed'."""
        proc = self.start_new_export()
        try:
            time.sleep(delay)
        finally:
            proc.send_signal(signal.SIGKILL)
            proc.wait()
            proc.stdout.close()
        now = snapshot(self.views)
        return "old" if now == self.old else "new" if now == self.new else "mixed"

    def leftovers(self) -> list[str]:
        """Temporary folders beside ``views`` (a killed export may leave one; the next export removes it)."""
        return sorted(p.name for p in self.root.glob(".views.doodle-*.tmp"))

    def export_cleans_up(self) -> bool:
        self._run(self.views, 12, NEW_BACKGROUND)
        return not self.leftovers() and snapshot(self.views) == self.new


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=100)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from helpers import random_strokes

    from doodle.strokes import write_strokes

    rng = random.Random(args.seed)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        write_strokes(root / "s.doodle", random_strokes(0, 24, 6))
        rig = KillRig(root, root / "s.doodle")
        window = rig.window
        counts = {"old": 0, "new": 0, "mixed": 0}
        for _ in range(args.trials):
            counts[rig.trial(rng.uniform(0.0, 1.1 * window))] += 1
        left = len(rig.leftovers())
        clean = rig.export_cleans_up()
    print(f"export window {window:.2f} s; {args.trials} kills: {counts['old']} old, {counts['new']} new, "
          f"{counts['mixed']} mixed; temp folders after the last kill {left}, removed by the next export: {clean}")
    sys.exit(1 if counts["mixed"] or not clean else 0)


if __name__ == "__main__":
    main()
