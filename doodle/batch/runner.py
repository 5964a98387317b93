"""``doodle batch``: every object of a manifest made once, resumably, and one summary of them all.

An object is done when its folder holds a ``record.json`` whose fingerprint (doodle's version, the scene's
path and files, the object's options) matches: a rerun skips it, whether it succeeded or failed with a
reason of its own (``retry_failed`` tries failures again). A killed run loses only the objects in flight;
their folders are as they were. ``summary.json`` is rewritten atomically as each object finishes;
``sheet.png`` (one view of each object) and ``index.html`` at the end of the run, or when it is stopped.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..atomic import check_out_folder, write_text
from ..errors import DoodleError
from ..workers import cpu_count
from .job import Task, fingerprint, read_record
from .manifest import Manifest, load_manifest
from .summary import write_index, write_sheet


@dataclass
class BatchOptions:
    jobs: int = 0
    """Objects made at once; 0: one a core (as many as the memory holds, :func:`plan`)."""
    threads: int = 0
    """Threads per object; 0: the cores shared out between the jobs."""
    ray: str | None = None
    """Run on Ray instead of local processes: ``auto`` or a cluster address."""
    gpus: float = 0.0
    """GPUs each Ray task asks for."""
    retry_failed: bool = False
    """Make again the objects whose last attempt failed."""


@dataclass
class BatchResult:
    records: dict[str, dict[str, Any]] = field(default_factory=dict)
    made: int = 0
    """Objects made in this run (the others were done before)."""
    seconds: float = 0.0

    @property
    def failed(self) -> list[str]:
        return [n for n, r in self.records.items() if r.get("status") != "ok"]


#: Memory an object's fit may take at its peak (Lego from 100 photos: about 2 GB), for the default jobs.
MEMORY_PER_JOB = 3 * 2 ** 30


def memory_bytes() -> int | None:
    """This machine's memory, or ``None`` where the system does not say."""
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def plan(cores: int, jobs: int = 0, threads: int = 0, memory: int | None = None) -> tuple[int, int]:
    """``(jobs, threads)`` that fit ``cores``: by default one object a core with one thread each (a fit's
    threads scale poorly: on 2 cores two objects at once make 364 objects an hour, one with two threads
    213), but no more objects at once than ``memory`` holds at :data:`MEMORY_PER_JOB` each."""
    if jobs < 0 or threads < 0:
        raise DoodleError("--jobs and --threads must be 0 (automatic) or more")
    if not jobs:
        jobs = max(1, cores // threads) if threads else cores
        if memory:
            jobs = min(jobs, max(1, memory // MEMORY_PER_JOB))
    threads = threads or max(1, cores // jobs)
    return jobs, threads


@contextlib.contextmanager
def _locked(out: Path) -> Iterator[None]:
    """One batch at a time in an output folder (a second run would make the same objects twice)."""
    fd = os.open(out / ".doodle-batch.lock", os.O_CREAT | os.O_RDWR, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise DoodleError(f"{out}: another doodle batch is running in this folder") from None
        yield
    finally:
        os.close(fd)


def _summary(manifest: Manifest, records: dict[str, dict[str, Any]], started: float) -> dict[str, Any]:
    rows = []
    for obj in manifest.objects:
        r = records.get(obj.name)
        row = {"name": obj.name, "scene": str(obj.scene), "status": "pending" if r is None else r["status"]}
        if r is not None:
            for key in ("error", "curves", "superquadrics", "bytes", "seconds", "files", "metrics"):
                if r.get(key) is not None:
                    row[key] = r[key]
        rows.append(row)
    counts = {s: sum(row["status"] == s for row in rows) for s in ("ok", "error", "pending")}
    return {"manifest": str(manifest.path), "objects": len(rows), **counts,
            "seconds": round(time.perf_counter() - started, 1), "results": rows}


def run_batch(manifest_path: str | os.PathLike, out_dir: str | os.PathLike, options: BatchOptions | None = None,
              log: Callable[[str], None] = print, progress: Callable[[int, int, str], None] | None = None) -> BatchResult:
    """Make every object of the manifest into ``out_dir/NAME/`` (see the module doc).

    ``progress(done, total, name)`` is called as each object to make finishes; ``log`` gets one line per
    object. Returns every object's record (the ones done before included).
    """
    opt = options or BatchOptions()
    manifest = load_manifest(manifest_path)
    jobs, threads = plan(cpu_count(), opt.jobs, opt.threads, memory_bytes())
    out = Path(out_dir)
    check_out_folder(out)
    if not out.parent.is_dir():
        raise DoodleError(f"{out}: folder {out.parent} does not exist")
    out.mkdir(exist_ok=True)
    started = time.perf_counter()
    result = BatchResult()
    with _locked(out):
        tasks = []
        for obj in manifest.objects:
            fp = fingerprint(obj.scene, obj.options)
            record = read_record(out / obj.name)
            if record is not None and record["fingerprint"] == fp and (record["status"] == "ok" or not opt.retry_failed):
                result.records[obj.name] = record
                continue
            tasks.append(Task(obj.name, str(obj.scene), obj.options, str(out.resolve()), fp, threads))
        done_before = len(result.records)
        if done_before:
            log(f"{done_before} of {len(manifest.objects)} objects done before (skipped)")
        if tasks:
            how = f"Ray ({opt.ray})" if opt.ray else f"{min(jobs, len(tasks))} process(es)"
            log(f"making {len(tasks)} object(s) in {how}, {threads} thread(s) each")
        engine = None
        if tasks:
            from .engines import run_local, run_ray

            engine = run_ray(tasks, opt.ray, opt.gpus) if opt.ray else run_local(tasks, jobs)
        try:
            for record in engine or ():
                result.records[record["name"]] = record
                result.made += 1
                if record["status"] == "ok":
                    log(f"{record['name']}: {record['curves']} curves + {record['superquadrics']} superquadrics, "
                        f"{record['bytes']} B, {record['seconds']:.0f} s")
                else:
                    log(f"{record['name']}: failed: {record['error']}")
                write_text(out / "summary.json", json.dumps(_summary(manifest, result.records, started), indent=2) + "\n")
                if progress:
                    progress(result.made, len(tasks), record["name"])
        finally:
            if engine is not None:
                engine.close()  # stops the workers still making objects (Ctrl-C, an error here)
            summary = _summary(manifest, result.records, started)
            write_text(out / "summary.json", json.dumps(summary, indent=2) + "\n")
            write_sheet(out, summary)
            write_index(out, summary)
    result.seconds = time.perf_counter() - started
    return result
