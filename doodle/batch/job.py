"""One object of a batch, start to finish, in whatever process runs it: fit, export, animate, view, score.

:func:`run_object` never raises for the object's own failures: it returns a record, ``status`` ``"ok"`` or
``"error"`` with the one-line reason, and writes the object's folder atomically — the complete new result
replaces the folder whole, or (on an error) only ``record.json`` is written beside what was there. A kill
at any moment leaves the folder as it was.
"""

from __future__ import annotations

import hashlib
import json
import os
import time
import traceback
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from .. import __version__
from ..atomic import atomic_folder
from ..errors import DoodleError
from ..workers import THREADS_ENV

RECORD = "record.json"


@dataclass
class Task:
    """What a worker needs to make one object: plain data, so it pickles to any process or Ray node."""

    name: str
    scene: str
    options: dict[str, Any]
    out_dir: str
    """The batch's output folder; the object goes into ``out_dir/name``."""
    fingerprint: str
    threads: int = 1


def scene_signature(scene: Path) -> list[list[Any]]:
    """Names, sizes and modification times of the scene's files two levels deep (its own ``doodle-masks``
    left out, which ``masks = "auto"`` writes, unless they were fixed by hand), so an edited scene is made
    again on a rerun."""
    from ..scenes.automask import fixed_by_hand

    rows: list[list[Any]] = []
    if not scene.is_dir():
        return rows
    hand = fixed_by_hand(scene / "doodle-masks")
    for level in (scene.glob("*"), scene.glob("*/*")):
        for f in level:
            if f.is_file() and (hand or "doodle-masks" not in f.relative_to(scene).parts):
                st = f.stat()
                rows.append([f.relative_to(scene).as_posix(), st.st_size, st.st_mtime_ns])
    return sorted(rows)


def fingerprint(scene: Path, options: dict[str, Any]) -> str:
    """What decides an object's output: the doodle version, the scene (path and files) and its options."""
    key = {"doodle": __version__, "scene": str(scene), "files": scene_signature(scene), "options": options}
    return hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:16]


def read_record(folder: Path) -> dict[str, Any] | None:
    """An object's record, or ``None`` when there is none or it cannot be read (then the object is made)."""
    try:
        record = json.loads((folder / RECORD).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return record if isinstance(record, dict) and "status" in record and "fingerprint" in record else None


def _limit_threads(threads: int) -> None:
    """Keep this process to ``threads`` cores: doodle's own thread pools, OpenMP, BLAS and torch."""
    for var in (THREADS_ENV, "OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
        os.environ[var] = str(threads)
    import torch

    if torch.get_num_threads() != threads:
        torch.set_num_threads(threads)


def _has_test_split(scene: Path) -> bool:
    from ..scenes import detect_format

    return detect_format(scene) == "nerf-synthetic" and (scene / "transforms_test.json").is_file()


def _make(task: Task, folder: Path, log: list[str]) -> dict[str, Any]:
    """Fit, export, animate, view and score one object into ``folder``; returns the record's details."""
    from ..animate import AnimateOptions, animate
    from ..cameras import orbit_cameras
    from ..exporters import DrawOptions, ExportOptions, export_views
    from ..exporters.viewer import ViewerOptions, write_viewer
    from ..fit import FitConfig, fit
    from ..fit.config import config_fields, manifest_key
    from ..scenes import load_scene, load_scene_at_size
    from ..scenes.automask import with_masks
    from ..strokes import write_strokes
    from ..styles import load_style

    o = task.options
    scene_dir = Path(task.scene)
    if not scene_dir.is_dir():
        raise DoodleError(f"{scene_dir}: no such scene folder")
    style = load_style(o["style"])
    hidden = o["hidden"] or style.hidden_mode or "hide"
    cfg = FitConfig(**{f.name: o[manifest_key(f)] for f in config_fields() if manifest_key(f) in o})
    cfg.check()
    say = log.append
    scene = load_scene_at_size(scene_dir, o["split"], cfg.load_size)
    scene = with_masks(scene, o["masks"], scene_dir / "doodle-masks", log=say)
    result = fit(scene, cfg, log=say, progress=False, hold_interrupt=False)
    if result.interrupted:  # Ctrl-C reached the worker: the object is not made (a rerun makes it)
        raise KeyboardInterrupt
    # the stroke file is the same bytes whenever the object is made: the fit's timing goes in the record
    strokes = replace(result.strokes, provenance={k: v for k, v in result.strokes.provenance.items() if k != "seconds"})
    strokes_file = folder / ("strokes.doodleb" if o["binary"] else "strokes.doodle")
    size = write_strokes(strokes_file, strokes)
    files = [strokes_file.name]
    source = f"{task.name}/{strokes_file.name}"
    if o["views"] > 0:
        cams = orbit_cameras(strokes.frame, o["views"], o["size"], o["size"])
        written = export_views(strokes, cams, folder / "views", ExportOptions(
            png=o["png"], style=style, source=source, workers=1, draw=DrawOptions(hidden=hidden)))
        files += [f"views/{p.name}" for p in written]
    if o["gif"]:
        animate(strokes, folder / "turntable.gif", AnimateOptions(frames=o["frames"], size=o["gif_size"], style=style,
                                                                  hidden=hidden, workers=1))
        files.append("turntable.gif")
    if o["html"]:
        write_viewer(strokes, folder / "sketch.html", ViewerOptions(size=o["size"], style=style, hidden=hidden, workers=1),
                     source=source)
        files.append("sketch.html")
    if o["model3d"]:
        from ..exporters.scene3d import encode_3d

        (folder / f"strokes.{o['model3d']}").write_bytes(encode_3d(strokes, f".{o['model3d']}"))
        files.append(f"strokes.{o['model3d']}")
    metrics = None
    if o["eval"] == "yes" or (o["eval"] == "auto" and _has_test_split(scene_dir)):
        from ..evaluate import evaluate

        m = evaluate(strokes, load_scene(scene_dir, "test"))
        metrics = {k: v for k, v in m.items() if k != "per_view"}
        (folder / "metrics.json").write_text(json.dumps(m, indent=2, sort_keys=True) + "\n", encoding="utf-8")
        files.append("metrics.json")
    return {"curves": len(strokes.curves), "superquadrics": len(strokes.superquadrics), "bytes": size,
            "fit_seconds": round(result.seconds, 1), "files": files, "metrics": metrics}


def run_object(task: Task) -> dict[str, Any]:
    """Make one object (see the module doc); returns its record, also written to ``out_dir/name/record.json``."""
    _limit_threads(task.threads)
    start = time.perf_counter()
    record: dict[str, Any] = {"name": task.name, "scene": task.scene, "fingerprint": task.fingerprint,
                              "doodle": __version__, "options": task.options}
    log: list[str] = []
    folder = Path(task.out_dir) / task.name
    try:
        with atomic_folder(folder, keep_others=False) as tmp:
            record.update(status="ok", **_make(task, tmp, log))
            record["seconds"] = round(time.perf_counter() - start, 1)
            record["log"] = log
            (tmp / RECORD).write_text(json.dumps(record, indent=2) + "\n", encoding="utf-8")
        return record
    except (DoodleError, OSError, ValueError, MemoryError) as exc:  # the object's input or the machine
        reason = _one_line(exc)
        record["traceback"] = traceback.format_exc()
    except KeyboardInterrupt:
        raise
    except Exception as exc:  # a bug: still one line here, the traceback in the record
        reason = f"internal error ({type(exc).__name__}: {_one_line(exc)})"
        record["traceback"] = traceback.format_exc()
    record.update(status="error", error=reason, seconds=round(time.perf_counter() - start, 1), log=log)
    try:  # the reason beside what the folder held: a failed rerun loses no earlier result
        with atomic_folder(folder, keep_others=True) as tmp:
            (tmp / RECORD).write_text(json.dumps(record, indent=2) + "\n", encoding="utf-8")
    except (DoodleError, OSError) as exc:
        record["error"] += f" (and its record could not be written: {_one_line(exc)})"
    return record


def _one_line(exc: BaseException) -> str:
    if isinstance(exc, OSError) and exc.strerror:
        where = f"{exc.filename}: " if exc.filename else ""
        return f"{where}{exc.strerror}"
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


__all__ = ["Task", "fingerprint", "read_record", "run_object", "scene_signature"]
