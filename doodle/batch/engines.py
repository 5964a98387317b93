"""Where a batch's objects are made: a local process pool (the default) or a Ray cluster (optional extra).

Both take the same :class:`~.job.Task` list and yield each object's record as it finishes, in finishing
order. Neither schedules beyond what its library does: the local engine is a ``ProcessPoolExecutor`` (fork
server workers that die with their parent, each object's threads capped so ``jobs × threads`` fits the
cores), the Ray engine is Ray tasks with a resource request and Ray's own retries.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any

from ..errors import DoodleError
from ..workers import init_worker, stop_pool, without_main_script, worker_context
from .job import Task, run_object

#: Attempts an object gets when the process making it dies (killed from outside, out of memory).
ATTEMPTS = 2


def _died(task: Task, attempts: int) -> dict[str, Any]:
    return {"name": task.name, "scene": task.scene, "fingerprint": task.fingerprint, "status": "error",
            "error": f"its worker process died {attempts} times (out of memory?)", "seconds": 0.0, "transient": True}


def run_local(tasks: list[Task], jobs: int) -> Iterator[dict[str, Any]]:
    """Make ``tasks`` in ``jobs`` worker processes; yields records as objects finish.

    A worker killed from outside breaks the pool: a new one is started and the objects that were not
    finished are given to it; an object whose worker dies :data:`ATTEMPTS` times is recorded as failed (but
    not written: a rerun tries it again). Stopping the iteration (Ctrl-C) stops the workers.
    """
    attempts = {t.name: 0 for t in tasks}
    left = list(tasks)
    while left:
        pool = ProcessPoolExecutor(max(1, min(jobs, len(left))), mp_context=worker_context(), initializer=init_worker,
                                   initargs=(os.getpid(),))
        futures: dict[Future, Task] = {}
        try:
            with without_main_script():  # the workers start as the first tasks are submitted
                for task in left:
                    futures[pool.submit(run_object, task)] = task
            broken = False
            pending = set(futures)
            while pending and not broken:
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                for f in done:
                    task = futures[f]
                    try:
                        record = f.result()
                    except BrokenProcessPool:
                        broken = True
                        continue
                    left.remove(task)
                    yield record
            if broken:
                for task in list(left):
                    attempts[task.name] += 1
                    if attempts[task.name] >= ATTEMPTS:
                        left.remove(task)
                        yield _died(task, attempts[task.name])
        finally:
            stop_pool(pool)


def run_ray(tasks: list[Task], address: str, gpus: float = 0.0) -> Iterator[dict[str, Any]]:
    """Make ``tasks`` as Ray tasks (``address``: ``auto`` joins a running cluster or starts one on this
    machine; else a cluster's address), each asking for its threads as CPUs and ``gpus`` GPUs; Ray retries
    an object whose worker dies. Records are streamed back as objects finish.

    The output folder must be one every node can write (a shared file system).
    """
    try:
        import ray
    except ImportError:
        raise DoodleError("--ray needs Ray: pip install -e '.[ray]'") from None
    if not ray.is_initialized():
        try:
            ray.init(address=None if address == "auto" else address, include_dashboard=False,
                     log_to_driver=False, configure_logging=False)
        except (ConnectionError, ValueError, RuntimeError) as exc:
            raise DoodleError(f"--ray {address}: cannot reach a Ray cluster ({str(exc).splitlines()[0]})") from None
    remote = ray.remote(run_object)
    refs = {}
    for task in tasks:
        ref = remote.options(num_cpus=task.threads, num_gpus=gpus, max_retries=ATTEMPTS,
                             name=f"doodle:{task.name}").remote(task)
        refs[ref] = task
    pending = list(refs)
    try:
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            for ref in done:
                task = refs[ref]
                try:
                    yield ray.get(ref)
                except ray.exceptions.RayError as exc:  # the worker or node died more often than Ray retries
                    record = _died(task, ATTEMPTS + 1)
                    record["error"] = f"Ray could not run it: {str(exc).strip().splitlines()[0]}"
                    yield record
    finally:
        for ref in pending:
            ray.cancel(ref, force=True)
