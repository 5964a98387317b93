"""Drawing many views in worker processes that cannot deadlock or outlive their parent.

Workers are started with ``forkserver`` (``spawn`` where there is none), never with a plain ``fork``: a
process that has run torch or any OpenMP code cannot safely fork (the child hangs in libgomp's barrier the
first time it runs a parallel region). The fork server is a fresh interpreter that imports only the
drawing modules, which do not import torch, and forks the workers from that clean state, so a worker
starts in milliseconds once the server is up.

Workers ignore Ctrl-C (the parent handles it and stops them), and each one exits by itself when the
process that asked for it dies (``kill -9`` included), so no orphaned worker stays behind.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import TypeVar

T = TypeVar("T")
R = TypeVar("R")

#: Modules the fork server imports once, so workers forked from it start with them loaded.
PRELOAD = ["doodle.exporters.export", "doodle.animate"]


#: Environment variable that caps :func:`cpu_count` (``doodle batch`` sets it in each worker, so that
#: objects fitted side by side share the cores instead of each taking them all).
THREADS_ENV = "DOODLE_THREADS"


def cpu_count() -> int:
    """CPU cores this process may run on (the affinity mask, not the machine's count), at most
    ``$DOODLE_THREADS`` when that is set."""
    cap = os.environ.get(THREADS_ENV, "")
    if cap.isdigit() and int(cap) > 0:
        return min(int(cap), _cores())
    return _cores()


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # macOS, Windows
        return os.cpu_count() or 1


def worker_context() -> multiprocessing.context.BaseContext:
    """A ``forkserver`` context preloading the drawing modules, or ``spawn`` where forkserver is missing."""
    if "forkserver" in multiprocessing.get_all_start_methods():
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(PRELOAD)
        return ctx
    return multiprocessing.get_context("spawn")


def _watch_parent(parent_pid: int, interval: float = 0.25) -> None:
    while True:
        time.sleep(interval)
        try:
            os.kill(parent_pid, 0)
        except ProcessLookupError:
            os._exit(1)
        except PermissionError:  # the pid was reused by another user's process: ours is gone
            os._exit(1)


def init_worker(parent_pid: int) -> None:
    """Runs first in every worker: leave Ctrl-C to the parent, and die with it."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    threading.Thread(target=_watch_parent, args=(parent_pid,), daemon=True).start()


@contextlib.contextmanager
def without_main_script() -> Iterator[None]:
    """Start workers without re-running the caller's script in them.

    ``spawn`` and ``forkserver`` children import ``__main__`` by default, so a plain script that fits and
    exports (no ``if __name__ == "__main__"`` guard) would run again in every worker. The jobs here are
    functions of doodle's own modules and need nothing from ``__main__``, so its path is hidden while the
    workers start.
    """
    main = sys.modules.get("__main__")
    saved = {k: main.__dict__[k] for k in ("__file__", "__spec__") if main is not None and k in main.__dict__}
    try:
        if main is not None:
            main.__dict__.pop("__file__", None)
            main.__dict__["__spec__"] = None
        yield
    finally:
        if main is not None:
            main.__dict__.update(saved)


def stop_pool(pool: ProcessPoolExecutor) -> None:
    """Stop a pool now: cancel what has not started and terminate the workers (do not wait for them)."""
    processes = list(getattr(pool, "_processes", {}).values())  # no public handle on the workers
    pool.shutdown(wait=False, cancel_futures=True)
    for p in processes:
        if p.is_alive():
            p.terminate()
    for p in processes:
        p.join(timeout=2)
        if p.is_alive():
            p.kill()


class _TwoEnds:
    """Chunk indices claimed from the front (by workers) and from the back (by this process)."""

    def __init__(self, n: int) -> None:
        self.front, self.back = 0, n
        self.lock = threading.Lock()

    def take_front(self) -> int | None:
        with self.lock:
            if self.front >= self.back:
                return None
            self.front += 1
            return self.front - 1

    def take_back(self) -> int | None:
        with self.lock:
            if self.front >= self.back:
                return None
            self.back -= 1
            return self.back

    def close(self) -> None:
        with self.lock:
            self.back = self.front


def map_chunks(job: Callable[[Sequence[T]], list[R]], items: Sequence[T], workers: int = 0, batch: int = 12,
               min_parallel: int = 4, progress: Callable[[int], None] | None = None) -> Iterator[R]:
    """Yield ``job(chunk)``'s results one item at a time, in item order.

    Items go to ``job`` in chunks of at most ``batch`` (drawing many views at once is cheaper per view).
    With ``workers`` > 1 (0 = one per core, at most 8) and at least ``min_parallel`` items, ``workers − 1``
    processes take chunks from the front, one at a time each, while this process draws chunks from the
    back: the workers' start-up (the fork server's first start imports the drawing modules, ~0.5 s) costs
    no idle time, and a slow worker never holds more than one chunk. ``job`` must be a picklable
    module-level function (or a ``functools.partial`` of one). A worker killed from outside only costs
    time: its chunk is drawn here. ``progress(done)`` is called in this process as items finish.
    """
    workers = workers or min(cpu_count(), 8)
    parallel = workers > 1 and len(items) >= min_parallel
    # small chunks balance the two ends; batching pays little beyond a few views
    n = max(1, min(batch, -(-len(items) // (4 * workers)) if parallel else batch))
    chunks = [items[k:k + n] for k in range(0, len(items), n)]
    report = progress or (lambda done: None)
    if not parallel or len(chunks) < 2:
        done = 0
        for chunk in chunks:
            results = job(chunk)
            done += len(chunk)
            report(done)
            yield from results
        return
    n_pool = min(workers - 1, len(chunks) - 1)
    pool = ProcessPoolExecutor(n_pool, mp_context=worker_context(), initializer=init_worker,
                               initargs=(os.getpid(),))
    ends = _TwoEnds(len(chunks))
    futures: dict[int, Future[list[R]]] = {}
    slots = threading.Semaphore(n_pool)

    def feed() -> None:  # keeps each worker busy with exactly one chunk from the front
        try:
            while True:
                while not slots.acquire(timeout=0.1):
                    if ends.front >= ends.back:
                        return
                i = ends.take_front()
                if i is None:
                    slots.release()
                    return
                with without_main_script():  # a worker may start here
                    futures[i] = pool.submit(job, chunks[i])
                futures[i].add_done_callback(lambda _: slots.release())
        except Exception:  # the pool broke (a worker was killed): this process draws what is left, below
            return

    feeder = threading.Thread(target=feed, daemon=True)
    mine: dict[int, list[R]] = {}
    try:
        feeder.start()
        while (i := ends.take_back()) is not None:
            mine[i] = job(chunks[i])
            report(sum(len(chunks[k]) for k in mine) + sum(len(chunks[k]) for k, f in list(futures.items()) if f.done()))
        feeder.join()
        for i in range(len(chunks)):
            if i not in mine:
                try:
                    mine[i] = futures[i].result() if i in futures else job(chunks[i])
                except BrokenProcessPool:  # killed from outside (out of memory?): draw it here instead
                    mine[i] = job(chunks[i])
                report(sum(len(chunks[k]) for k in mine))
            yield from mine.pop(i)
    except BaseException:
        ends.close()
        feeder.join()
        stop_pool(pool)
        raise
    pool.shutdown(wait=True)
