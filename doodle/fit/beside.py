"""A stage's work started early, in a thread beside the stages before it (:class:`Beside`).

The superquadric abstraction needs only the carved volume, and discovery does not need it: on DTU's skull
they are 17 and 22 s, the abstraction's small torch problems mostly on one core and discovery's ridge
walks and per-view passes mostly on one too. Started as soon as the volume is carved, the abstraction runs
beside discovery and the superquadrics stage takes its result. It is the same computation with the same
inputs, so the fit is the same bit for bit: its random draws are its own generator's, and the torch thread
count it sets while it runs (global to the process) reaches no discovery computation (discovery runs no torch).

A thread, not a process: nothing to fork after torch, nothing to pickle (the carving is read in place), and
numpy, scipy and torch release the GIL in their loops. A daemon thread, so that a process that ends (a
Ctrl-C'd ``doodle fit``) does not wait for it; :meth:`Beside.cancel` stops it at its next check
(:func:`stopped`) when a fit ends without it.
"""

from __future__ import annotations

import threading
from concurrent.futures import Future
from contextvars import ContextVar
from typing import Callable, Generic, TypeVar

T = TypeVar("T")

#: The event that stops the work running in this thread (set by :class:`Beside`; ``None`` elsewhere).
_STOP: ContextVar[threading.Event | None] = ContextVar("doodle_stop", default=None)


class Cancelled(Exception):
    """Raised in the work's thread at its next check after :meth:`Beside.cancel`."""


def stopped() -> None:
    """A long computation's check, between its steps: raises :class:`Cancelled` where the work beside the
    pipeline was cancelled; nothing elsewhere (the main thread, a plain call)."""
    stop = _STOP.get()
    if stop is not None and stop.is_set():
        raise Cancelled


class Beside(Generic[T]):
    """``work(log)`` run in a daemon thread; its messages are kept and given to the ``say`` of :meth:`result`,
    in order, when the stage that needs it takes the result."""

    def __init__(self, work: Callable[[Callable[[str], None]], T], name: str) -> None:
        self._stop = threading.Event()
        self._messages: list[str] = []
        self._future: Future[T] = Future()
        threading.Thread(target=self._run, args=(work,), name=f"doodle-{name}", daemon=True).start()

    def _run(self, work: Callable[[Callable[[str], None]], T]) -> None:
        _STOP.set(self._stop)  # this thread's context only
        try:
            self._future.set_result(work(self._messages.append))
        except BaseException as e:  # noqa: BLE001 (handed to the thread that takes the result)
            self._future.set_exception(e)

    def result(self, say: Callable[[str], None]) -> T:
        """The work's result (waiting for it; its exception raised here), after its messages went to ``say``."""
        try:
            return self._future.result()
        finally:
            for message in self._messages:
                say(message)
            self._messages.clear()

    def cancel(self) -> None:
        """Stop the work at its next check; its result is not wanted."""
        self._stop.set()
