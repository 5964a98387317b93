"""Stage 1, prepare: check the options against the scene, bring the images to the working size, seed the
random generators and choose the fit's path (:class:`~doodle.fit.state.Plan`)."""

from __future__ import annotations

from typing import Callable

import numpy as np
import torch

from ...errors import DoodleError
from ...scenes import Scene, working_scene
from ..config import FitConfig
from ..gradient.objectives import make_objective
from ..state import FitState, Plan

NAME = "prepare"


def device_of(name: str) -> torch.device:
    """The torch device ``name``, or a one-line error when this machine has none such."""
    if name.startswith("cuda") and not torch.cuda.is_available():
        raise DoodleError(f"--device {name}: CUDA is not available on this machine (use --device cpu)")
    try:
        return torch.device(name)
    except RuntimeError as exc:
        raise DoodleError(f"--device {name}: {exc}") from None


def validate(cfg: FitConfig, scene: Scene) -> None:
    """Refuse options that cannot fit this scene, in one line naming the option (and the scene)."""
    cfg.check()
    if cfg.curves == 0 and scene.masks is None:
        raise DoodleError(f"{scene.source}: --curves 0 leaves only superquadrics, which need masks, and the scene "
                          "has none (give --masks DIR or allow curves)")
    if len(scene) < 2:
        raise DoodleError(f"{scene.source}: need at least 2 views to fit, found {len(scene)}")
    make_objective(cfg.objective)  # an unknown objective fails now, not after minutes of discovery


def plan(cfg: FitConfig, masks: bool) -> Plan:
    """The path: curves from the evidence (masks and curves wanted), or from points by the gradient stage;
    superquadrics fitted to the volume (``auto`` beside the compact outline), grown against the silhouettes
    (``auto`` otherwise), a fixed number, or none."""
    discover = cfg.discover and masks and cfg.curves != 0
    if cfg.superquadrics == 0 or not masks:
        sq = "none"
    elif cfg.superquadrics != "auto":
        sq = "fixed"
    elif not cfg.outline_hull and (discover or cfg.curves == 0):
        sq = "abstract"
    else:
        sq = "grow"
    return Plan(discover=discover, superquadrics=sq, masks=masks)


def prepare(scene: Scene, cfg: FitConfig, say: Callable[[str], None], progress: bool = True,
            shared: dict | None = None) -> FitState:
    """The fit's state before any stage ran."""
    validate(cfg, scene)
    device = device_of(cfg.device)
    work = working_scene(scene, cfg.size)
    gen = torch.Generator(device=device)
    gen.manual_seed(cfg.seed)
    if cfg.superquadrics != 0 and work.masks is None:
        say("superquadrics: the scene has no masks, fitting curves only")
    return FitState(cfg, scene, work, plan(cfg, work.masks is not None), device, np.random.default_rng(cfg.seed),
                    gen, say, progress, {} if shared is None else shared)
