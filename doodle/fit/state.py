"""What a fit knows between its stages (:class:`FitState`), and its checkpoint form.

Each stage (:mod:`doodle.fit.stages`) reads some fields of the state and fills others; the pipeline writes a
checkpoint after every stage (and the gradient stages within theirs), so ``--resume`` goes on from the last
stage finished. A checkpoint holds the stages' results, never what they can compute again from the scene:
discovery's candidates (the evidence grid, the per-view line maps: hundreds of MB on Lego) are traced again
when a resumed fit still needs them, which gives the same curves as a fit that was never interrupted.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

import numpy as np
import torch

from ..arrays import spread_indices
from ..atomic import atomic_path
from ..errors import DoodleError
from ..scenes import Scene, working_scene
from .. import __version__
from ..strokes.model import OUTLINE_CELLS, CurveSet, DefaultCamera, SceneFrame, StrokeSet, SuperquadricSet, Voxels
from .config import FitConfig
from .gradient.optimize import StageState
from .volume.carve import VoxelGrid

if TYPE_CHECKING:
    from .beside import Beside
    from .discovery.discover import Candidates
    from .volume.abstraction import Abstraction

CHECKPOINT_VERSION = 4
MAX_CHECKPOINT_BYTES = 1 << 30
#: Options that must match to resume a checkpoint.
RESUME_KEYS = ("curves", "superquadrics", "max_superquadrics", "size", "seed", "objective", "discover",
               "evidence_size", "evidence_voxels", "discovery_min_gain", "contours", "texture", "outline", "detail",
               "occluder", "thin", "init", "abstraction_steps")

STAGE_NAMES = ("volume", "discover", "superquadrics", "curves")
OUTLINE_VIEWS = 24
"""Working views on which the superquadrics' outlines are judged and the curves' hiding checked."""
"""The stages after ``prepare``, in order; a checkpoint lists those finished."""


@dataclass
class Carving:
    """The visual hull carved once per fit (:mod:`.volume.carve`): ``occupied`` ``bool`` on ``grid``."""

    grid: VoxelGrid
    occupied: np.ndarray


@dataclass
class Found:
    """The curves a stage offers the next: discovery's strong curves (before superquadrics), or the curves
    the gradient path starts from. ``normals`` and ``contour`` as :class:`~doodle.strokes.model.CurveSet`'s."""

    control_points: np.ndarray
    normals: np.ndarray | None = None
    contour: np.ndarray | None = None
    outline: float = 0.0
    """Share of the silhouettes' outline pixels these curves draw (discovery only)."""


@dataclass
class Plan:
    """Which path the fit takes (decided in ``prepare``, from the options and whether the scene has masks).

    ``superquadrics``: ``"abstract"`` (fitted to the carved volume in 3D: the compact default), ``"grow"``
    (grown against the silhouettes: beside the hull's outline, or without discovery), ``"fixed"`` (a given
    number, fitted to the silhouettes) or ``"none"``.
    """

    discover: bool
    superquadrics: str
    masks: bool


@dataclass
class FitState:
    """One fit's inputs, its plan, and each stage's results (``None`` until the stage that fills them ran)."""

    config: FitConfig
    scene: Scene
    """As given: its frame is the stroke file's."""
    work: Scene
    """At the working size (``config.size``): the superquadric judging and the gradient stages."""
    plan: Plan
    device: torch.device
    rng: np.random.Generator
    gen: torch.Generator
    say: Callable[[str], None]
    progress: bool = True
    shared: dict = field(default_factory=dict)
    """What a second fit of the same scene may take from this one (``outline="auto"``'s fallback): the carving
    and discovery's traces, which do not depend on the outline drawn."""
    # volume
    carving: Carving | None = None
    occluder: Voxels | None = None
    hull: Voxels | None = None
    # discover
    candidates: "Candidates | None" = None
    found: Found | None = None
    interior: np.ndarray | None = None
    """Gradient path: points inside the object ``(P, 3)`` (fixed superquadrics start at farthest ones)."""
    init_method: str = "evidence"
    # superquadrics
    abstraction: "Beside[Abstraction] | None" = None
    """The volume's abstraction, started beside discovery once the volume is carved (never checkpointed)."""
    superquadrics: SuperquadricSet | None = None
    judged: bool = False
    """Whether the superquadrics' outlines were judged against the views (then confirmed after the curves)."""
    # curves
    chosen: Found | None = None
    """The final curves before the gradient polish (discovery's choice beside the outlines, or the start)."""
    curve_state: StageState | None = None
    curve_control: np.ndarray | None = None
    """The gradient polish's best control points so far."""
    curves: CurveSet | None = None
    outline_drawn: float | None = None
    # bookkeeping
    interrupted: bool = False
    """A gradient stage was interrupted and kept its best state (its stage is not done)."""
    checkpointer: Callable[[str, int], None] | None = None
    """Writes a checkpoint from within a stage (its name, the step of its gradient stage)."""
    done: list[str] = field(default_factory=list)
    started: float = field(default_factory=time.perf_counter)

    @cached_property
    def evidence(self) -> Scene:
        """The scene at the evidence size (``config.evidence_size``): the carving and discovery."""
        return working_scene(self.scene, self.config.evidence_size)

    @cached_property
    def judge_views(self) -> np.ndarray:
        """Indices of the working views on which outlines are judged (:data:`OUTLINE_VIEWS`, evenly spread)."""
        return spread_indices(len(self.work), OUTLINE_VIEWS)

    @cached_property
    def judge(self) -> tuple[list, list[np.ndarray], list[np.ndarray]]:
        """The judge views' cameras, line maps (:func:`~doodle.fit.discovery.evidence.object_lines`) and masks."""
        from .discovery.evidence import object_lines

        w = self.work
        return ([w.cameras[v] for v in self.judge_views],
                [object_lines(w.images[v], w.masks[v]) for v in self.judge_views],
                [w.masks[v] for v in self.judge_views])

    @property
    def frame(self):
        return self.scene.frame

    @property
    def discovering(self) -> bool:
        return self.plan.discover

    def stroke_set(self, curves: CurveSet, sq: SuperquadricSet, hull: Voxels | None = None,
                   seconds: float = 0.0) -> StrokeSet:
        """A stroke set in the fit's scene frame (copied), with the occluder and the fit's provenance."""
        cfg, frame = self.config, self.frame
        return StrokeSet(
            frame=SceneFrame(frame.up.copy(), frame.center.copy(), frame.radius, DefaultCamera(**vars(frame.camera))),
            curves=curves, superquadrics=sq, occluder=self.occluder, hull=hull,
            provenance={"tool": f"doodle {__version__}", "source": self.scene.source, "objective": cfg.objective,
                        "iterations": cfg.curve_iterations, "superquadric_iterations": cfg.sq_iterations,
                        "init": self.init_method, "seed": cfg.seed, "seconds": round(seconds, 2)},
        )


# -- the checkpoint form --------------------------------------------------------------------------------------

def _f64(a: Any) -> torch.Tensor:
    return torch.tensor(np.asarray(a), dtype=torch.float64)


def _bits(a: np.ndarray) -> dict:
    return {"shape": list(a.shape), "bits": torch.from_numpy(np.packbits(a.ravel()))}


def _unbits(d: dict) -> np.ndarray:
    shape = tuple(int(s) for s in d["shape"])
    return np.unpackbits(d["bits"].numpy(), count=int(np.prod(shape))).astype(bool).reshape(shape)


def _voxels(v: Voxels | None) -> dict | None:
    return None if v is None else {"origin": _f64(v.origin), "voxel": float(v.voxel), "axes": _f64(v.axes),
                                   "occupied": _bits(v.occupied)}


def _unvoxels(d: dict | None) -> Voxels | None:
    return None if d is None else Voxels(d["origin"].numpy(), float(d["voxel"]), d["axes"].numpy(), _unbits(d["occupied"]))


def _found(f: Found | None) -> dict | None:
    if f is None:
        return None
    return {"control_points": _f64(f.control_points), "outline": float(f.outline),
            "normals": None if f.normals is None else _f64(f.normals),
            "contour": None if f.contour is None else _f64(f.contour)}


def _unfound(d: dict | None) -> Found | None:
    if d is None:
        return None
    arr = lambda k: None if d[k] is None else d[k].numpy().astype(np.float64)  # noqa: E731
    return Found(arr("control_points"), arr("normals"), arr("contour"), float(d["outline"]))


def _superquadrics(sq: SuperquadricSet | None) -> list | None:
    if sq is None:
        return None
    return [_f64(sq.scale), _f64(sq.shape), _f64(sq.rotation), _f64(sq.translation), _f64(sq.drawn),
            _f64(sq.drawn_cells), _f64(sq.tapers), _f64(sq.bends)]


def _unsuperquadrics(tensors: list | None) -> SuperquadricSet | None:
    """Shape parameters, then the drawn flags, the outline cells, the tapers and the bends, as float tensors
    (a checkpoint from before tapering and bending has no tapers and bends)."""
    if tensors is None:
        return None
    a = [t.numpy().astype(np.float64) for t in tensors]
    sq = SuperquadricSet(*[x.reshape(-1, n) for x, n in zip(a[:4], (3, 2, 4, 3))])
    cells = a[5].reshape(len(sq), *OUTLINE_CELLS) > 0.5
    deformed = len(a) > 6 and (a[6].any() or a[7].any())
    return replace(sq, outline=a[4].reshape(-1) > 0.5, outline_cells=None if cells.all() else cells,
                   taper=a[6].reshape(-1, 2) if deformed else None, bend=a[7].reshape(-1, 2) if deformed else None)


def checkpoint_payload(state: FitState, stage: str | None = None, step: int = 0) -> dict:
    """The checkpoint of ``state``: the finished stages' results, and (``stage``, ``step``) where a gradient
    stage in progress stands. Tensors and plain types only, so it is read with ``weights_only``."""
    c = state.carving
    return {
        "format": "doodle-checkpoint", "version": CHECKPOINT_VERSION, "config": state.config.to_dict(),
        "done": list(state.done), "stage": stage, "step": int(step),
        "generator": state.gen.get_state(), "rng": state.rng.bit_generator.state,
        "carving": None if c is None else {"origin": _f64(c.grid.origin), "voxel": float(c.grid.voxel),
                                           "axes": _f64(c.grid.axes), "occupied": _bits(c.occupied)},
        "occluder": _voxels(state.occluder), "hull": _voxels(state.hull),
        "found": _found(state.found), "interior": None if state.interior is None else _f64(state.interior),
        "init_method": state.init_method,
        "superquadrics": _superquadrics(state.superquadrics), "judged": state.judged,
        "chosen": _found(state.chosen),
        "curve_state": None if state.curve_state is None else state.curve_state.to_dict(),
        "curve_control": None if state.curve_control is None else _f64(state.curve_control),
        "curves": None if state.curves is None else _found(Found(state.curves.control_points, state.curves.normals,
                                                                 state.curves.contour)),
        "outline_drawn": state.outline_drawn,
    }


def restore(state: FitState, ck: dict) -> None:
    """Fill ``state`` with a checkpoint's stage results (see :func:`checkpoint_payload`)."""
    state.done = [s for s in ck["done"] if s in STAGE_NAMES]
    state.gen.set_state(ck["generator"])
    state.rng.bit_generator.state = ck["rng"]
    if ck["carving"] is not None:
        c = ck["carving"]
        occupied = _unbits(c["occupied"])
        grid = VoxelGrid(c["origin"].numpy(), float(c["voxel"]), occupied.shape, c["axes"].numpy())
        state.carving = Carving(grid, occupied)
    state.occluder, state.hull = _unvoxels(ck["occluder"]), _unvoxels(ck["hull"])
    state.found, state.chosen = _unfound(ck["found"]), _unfound(ck["chosen"])
    state.interior = None if ck["interior"] is None else ck["interior"].numpy()
    state.init_method = ck["init_method"]
    state.superquadrics = _unsuperquadrics(ck["superquadrics"])
    state.judged = bool(ck["judged"])
    state.curve_state = None if ck["curve_state"] is None else StageState.from_dict(ck["curve_state"])
    state.curve_control = None if ck["curve_control"] is None else ck["curve_control"].numpy()
    curves = _unfound(ck["curves"])
    if curves is not None:
        state.curves = CurveSet(curves.control_points, state.config.width_px, curves.normals, curves.contour)
    state.outline_drawn = ck["outline_drawn"]


def check_resumable(ck: dict, cfg: FitConfig, path: Path) -> None:
    """Refuse a checkpoint made with other options (one line naming the option)."""
    mine, default = cfg.to_dict(), FitConfig().to_dict()
    for key in RESUME_KEYS:
        theirs = ck["config"].get(key, default[key])  # an option newer than the checkpoint had its default
        if theirs != mine[key]:
            raise DoodleError(f"{path}: checkpoint was made with {key}={theirs!r}, not "
                              f"{mine[key]!r}; use the same options to resume")


def save_checkpoint(path: Path, payload: dict) -> bool:
    """Write a checkpoint atomically; a full disk or an unwritable folder warns once and the fit goes on."""
    try:
        with atomic_path(path) as tmp:
            torch.save(payload, tmp)
        return True
    except (OSError, RuntimeError, DoodleError) as exc:  # torch reports a full disk as RuntimeError
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        warnings.warn(f"{path}: checkpoint not written ({reason}); fitting goes on", RuntimeWarning, stacklevel=2)
        return False


def load_checkpoint(path: Path) -> dict:
    """Read a checkpoint: tensors and plain types only (``weights_only``), so a crafted file runs no code."""
    try:
        if path.stat().st_size > MAX_CHECKPOINT_BYTES:
            raise DoodleError(f"{path}: larger than {MAX_CHECKPOINT_BYTES} bytes; not a doodle checkpoint")
        ck = torch.load(path, map_location="cpu", weights_only=True)
    except FileNotFoundError:
        raise DoodleError(f"{path}: no checkpoint to resume from") from None
    except DoodleError:
        raise
    except Exception as exc:  # torch raises many types for corrupt or foreign (pickled-object) files
        raise DoodleError(f"{path}: not a doodle checkpoint, or one that would run code when read "
                          f"({type(exc).__name__})") from None
    if not isinstance(ck, dict) or ck.get("format") != "doodle-checkpoint":
        raise DoodleError(f"{path}: not a doodle checkpoint")
    if ck.get("version") != CHECKPOINT_VERSION:
        raise DoodleError(f"{path}: checkpoint version {ck.get('version')!r}; this doodle resumes version "
                          f"{CHECKPOINT_VERSION} (start the fit again)")
    return ck
