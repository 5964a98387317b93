"""``doodle fit``: posed images → stroke set, as a sequence of stages (:mod:`doodle.fit.stages`):

    prepare → volume → discover → superquadrics → curves → assemble

(the superquadrics' abstraction of the volume starts beside discovery, in a thread: it needs only the volume)

:func:`fit` runs them, falls back to the hull's outline when ``outline="auto"`` finds the compact abstraction
does not draw the object, writes a checkpoint after every stage (and within the gradient stages), resumes
from any, and on Ctrl-C returns the best stroke set the finished stages give (``FitResult.interrupted``).
"""

from __future__ import annotations

import os
import signal
import threading
import time
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable, Iterator

from ..errors import DoodleError
from ..scenes import Scene
from ..strokes.model import StrokeSet
from . import config as config_module
from .config import FitConfig
from .stages import assemble, curves, discover, superquadrics, volume
from .stages.prepare import prepare
from .state import FitState, check_resumable, checkpoint_payload, load_checkpoint, restore, save_checkpoint

#: The stages after ``prepare``, in order (``assemble`` runs last, also after an interruption).
STAGES = (volume, discover, superquadrics, curves)


@dataclass
class FitResult:
    strokes: StrokeSet | None
    """The stroke set; ``None`` only when the fit was interrupted before any stage that draws finished."""
    interrupted: bool = False
    seconds: float = 0.0
    log: list[str] = field(default_factory=list)
    outline_drawn: float | None = None
    """Share of the training silhouettes' pixels that the superquadrics' outlines and the curves draw, the
    hull's outline not counted (``None`` when not measured: without masks, or with a fixed superquadric
    count). After ``outline="auto"`` fell back to the hull's outline: the compact abstraction's, which
    decided it."""
    stage_seconds: dict[str, float] = field(default_factory=dict)
    """Seconds each stage took (``prepare``, ``volume``, ``discover``, ``superquadrics``, ``curves``,
    ``assemble``; a stage skipped on resume is absent)."""


def fit(scene: Scene, config: FitConfig | None = None, checkpoint: str | os.PathLike | None = None,
        resume: bool = False, log: Callable[[str], None] = print, progress: bool = True,
        hold_interrupt: bool = True) -> FitResult:
    """Fit a stroke set to a scene. See :class:`FitConfig` for the options and the module doc for the stages.

    ``outline="auto"`` fits the compact abstraction first and, when its superquadrics and outline curves
    together draw less than :data:`~doodle.fit.config.HULL_FALLBACK` of the training silhouettes (an object
    they cannot abstract), fits again with the hull's outline and returns that.

    ``checkpoint``: a file written after every stage (deleted when the fit ends); ``resume`` goes on from it.
    Ctrl-C ends the fit with the best stroke set the finished stages give (``interrupted``). With
    ``hold_interrupt`` (and in the main thread), a Ctrl-C during the first seconds — resizing the images and
    carving the volume, before anything can be drawn — is held until the volume is carved; a second one stops
    at once (``KeyboardInterrupt``). Raises :class:`~doodle.errors.DoodleError` for options the scene cannot
    take, and when a finished fit draws nothing (``--curves 0`` where no superquadric draws the outline).
    """
    cfg = config or FitConfig()
    if cfg.outline != "auto":
        return _drawn(_fit(scene, cfg, checkpoint, resume, log, progress, {}, hold_interrupt), cfg, scene)
    from ..strokes.binary import encode

    # The fallback draws the hull's outline without superquadrics: the compact fit has just shown that they do
    # not abstract this object, and grown again against the silhouettes they drew none of Lego's outline (all
    # six dropped, 54 of its 99 s). With --curves 0 they are all there is to fit beside the hull's outline.
    compact = replace(cfg, outline="superquadrics")
    whole = replace(cfg, outline="hull", superquadrics=0 if cfg.curves != 0 else cfg.superquadrics)
    ck = load_checkpoint(Path(checkpoint)) if (resume and checkpoint) else None
    if ck is not None and ck["config"].get("outline") == "hull":  # interrupted in the fallback's fit
        return _drawn(_fit(scene, whole, checkpoint, resume, log, progress, {}, hold_interrupt), cfg, scene)
    shared: dict = {}  # the carving and discovery's traces, the same for both outlines: the fallback takes them
    first = _fit(scene, compact, checkpoint, resume, log, progress, shared, hold_interrupt)
    falls_back = (not first.interrupted and first.outline_drawn is not None and cfg.superquadrics == "auto"
                  and first.outline_drawn < config_module.HULL_FALLBACK)
    if not falls_back:
        return _drawn(first, cfg, scene)
    size = f"the {len(encode(first.strokes)):,} B abstraction" if first.strokes is not None else "the abstraction"
    msg = (f"outline: superquadrics and curves draw {first.outline_drawn:.0%} of the silhouettes (under "
           f"{config_module.HULL_FALLBACK:.0%}): fitting again with the hull's outline (--outline superquadrics "
           f"keeps {size})")
    log(msg)
    second = _fit(scene, whole, checkpoint, False, log, progress, shared, hold_interrupt)
    if second.strokes is not None:
        second.strokes.provenance["seconds"] = round(first.seconds + second.seconds, 2)  # the file's cost: both
    return _drawn(replace(second, seconds=first.seconds + second.seconds, log=first.log + [msg] + second.log,
                          outline_drawn=first.outline_drawn), cfg, scene)


def _drawn(result: FitResult, cfg: FitConfig, scene: Scene) -> FitResult:
    """``result``, unless a finished fit drew nothing: then say why, in one line."""
    if result.strokes is None and not result.interrupted:
        if cfg.curves == 0:
            raise DoodleError(f"{scene.source}: nothing draws this object's outline with --curves 0: no superquadric "
                              "explains its volume well enough (it is thin parts, or boxy); allow curves or use "
                              "--outline hull")
        raise DoodleError(f"{scene.source}: the fit found nothing to draw: no curve lies on the views' lines"
                          + (" (the scene has no masks: give --masks DIR)" if scene.masks is None else ""))
    return result


def _fit(scene: Scene, cfg: FitConfig, checkpoint: str | os.PathLike | None, resume: bool,
         log: Callable[[str], None], progress: bool, shared: dict, hold_interrupt: bool) -> FitResult:
    """One fit with a concrete outline (``"superquadrics"`` or ``"hull"``). ``shared`` carries the carving and
    discovery's traces from one fit of the scene with these evidence options to the next."""
    messages: list[str] = []

    def say(msg: str) -> None:
        messages.append(msg)
        log(msg)

    path = Path(checkpoint) if checkpoint else None
    seconds: dict[str, float] = {}
    with _held_interrupt(hold_interrupt, say) as hold:
        clock = time.perf_counter()
        state = prepare(scene, cfg, say, progress, shared)
        if resume and path is not None:
            ck = load_checkpoint(path)
            check_resumable(ck, cfg, path)
            restore(state, ck)
            say(f"resuming from {path} ({', '.join(state.done) or 'no stage'} done"
                + (f"; the curves' gradient stage at step {ck['step']}" if ck["stage"] == "curves" and ck["step"] else "")
                + ")")
        seconds["prepare"] = time.perf_counter() - clock

        def save(stage: str | None = None, step: int = 0) -> None:
            if path is not None:
                save_checkpoint(path, checkpoint_payload(state, stage, step))

        state.checkpointer = save
        try:
            _run_stages(state, hold, save, say, seconds)
        finally:
            superquadrics.cancel(state)  # started beside discovery and not taken: the fit ended before its stage
        hold.hold()  # the assembly takes a moment: a Ctrl-C now is held until the strokes are complete
        clock = time.perf_counter()
        strokes = assemble.assemble(state)
        seconds["assemble"] = time.perf_counter() - clock
        if hold.requested and not state.interrupted:
            state.interrupted = True  # the stroke set is whole; the checkpoint stays, --resume just assembles again
            say("interrupted while assembling: the strokes are complete")
            save()
    if not state.interrupted:
        say("stages: " + ", ".join(f"{k} {v:.1f} s" for k, v in seconds.items()))
        if path is not None:
            path.unlink(missing_ok=True)
    elapsed = strokes.provenance["seconds"] if strokes is not None else time.perf_counter() - state.started
    return FitResult(strokes, state.interrupted, elapsed, messages, state.outline_drawn, seconds)


def _run_stages(state: FitState, hold: "_Hold", save: Callable[..., None], say: Callable[[str], None],
                seconds: dict[str, float]) -> None:
    """The stages after ``prepare`` that are not done yet, in order, until one is interrupted (its checkpoint
    written); each stage's seconds go to ``seconds``."""
    for stage in STAGES:
        if stage.NAME in state.done:
            continue
        if stage is not volume:
            hold.release()  # there is something to draw now: Ctrl-C interrupts the stage
            if hold.requested:  # a Ctrl-C held through the first stages
                state.interrupted = True
                say("interrupted: the volume is carved; writing what it gives (--resume goes on)")
                save()
                return
        if stage is discover:  # the abstraction needs only the carved volume: it runs beside discovery
            superquadrics.begin(state)
        clock = time.perf_counter()
        try:
            stage.run(state)
        except KeyboardInterrupt:
            state.interrupted = True
        seconds[stage.NAME] = time.perf_counter() - clock
        if state.interrupted:
            say(f"interrupted in the {stage.NAME} stage: writing what the finished stages give "
                "(--resume goes on)")
            save(stage.NAME, state.curve_state.step if stage is curves and state.curve_state else 0)
            return
        state.done.append(stage.NAME)
        save()


class _Hold:
    """A Ctrl-C held until there is something to draw (see :func:`_held_interrupt`)."""

    def __init__(self, say: Callable[[str], None], usable: bool) -> None:
        self.say, self.usable, self.active, self.requested = say, usable, False, False
        self.hold()

    def _handler(self, signum, frame) -> None:
        if self.requested:
            raise KeyboardInterrupt
        self.requested = True
        self.say("Ctrl-C: stopping at the end of this stage (Ctrl-C again to stop at once)")

    def hold(self) -> None:
        """From now on a first Ctrl-C is noted, not raised."""
        if self.usable and not self.active:
            signal.signal(signal.SIGINT, self._handler)
            self.active = True

    def release(self) -> None:
        """From now on Ctrl-C raises as usual (and a stage turns it into an interrupted fit)."""
        if self.active:
            signal.signal(signal.SIGINT, signal.default_int_handler)
            self.active = False


@contextmanager
def _held_interrupt(hold: bool, say: Callable[[str], None]) -> Iterator[_Hold]:
    """While held (the first stages, until the volume is carved, and the assembly), a first Ctrl-C is noted
    (``requested``) instead of raising, and a second raises ``KeyboardInterrupt`` at once; while released
    (the long stages), Ctrl-C raises and the stage running turns it into an interrupted fit. Only in the main
    thread and only when Python's own handler is in place: elsewhere Ctrl-C behaves as it did."""
    usable = (hold and threading.current_thread() is threading.main_thread()
              and signal.getsignal(signal.SIGINT) is signal.default_int_handler)
    held = _Hold(say, usable)
    try:
        yield held
    finally:
        held.release()
