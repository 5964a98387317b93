"""Fitting configuration: one dataclass, mapped 1:1 onto ``doodle fit`` options."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Literal, Union

InitMethod = Literal["auto", "points", "hull", "bbox"]


@dataclass
class FitConfig:
    curves: int = 32
    """Number of cubic Bézier curves (view-independent strokes)."""
    superquadrics: Union[int, Literal["auto"]] = "auto"
    """Number of superquadrics, or ``"auto"``: none when the images' lines are mostly long straight edges
    (straightness ≥ ``straight_threshold``: boxy objects, which curves draw exactly); otherwise fit up to
    ``max_superquadrics``, drop those that add less than 2 % silhouette IoU, refit the rest, and drop all if together they
    cannot explain the silhouette."""
    straight_threshold: float = 0.6
    max_superquadrics: int = 8
    iterations: int = 1500
    """Adam steps of the curve stage."""
    sq_iterations: int = 400
    """Adam steps of the superquadric stage (before the curve stage, as in the paper)."""
    size: int = 256
    """Working resolution: images are resized so their larger side has this many pixels."""
    views_per_step: int = 8
    seed: int = 0
    device: str = "cpu"
    objective: str = "edges"
    """Name of a registered objective (see :mod:`doodle.fit.objectives`)."""
    init: InitMethod = "auto"
    """Where initial strokes are placed: SfM ``points``, a visual ``hull`` carved from the masks, random in the
    bounding box (``bbox``), or ``auto`` (points, else hull, else bbox)."""
    prune_curves: bool = True
    """After fitting, drop curves that do not lie on lines across the views (median distance above
    ``curve_max_distance_px``) or are shorter than 2 % of the image; ``curves`` is then a maximum."""
    curve_max_distance_px: float = 2.5
    lr_curves: float = 0.01
    """Adam learning rate of the curve control points, in units of the scene radius."""
    lr_superquadrics: float = 0.02
    width_px: float = 1.5
    checkpoint_every: int = 200
    preview_every: int = 250
    preview_dir: Path | None = None

    def to_dict(self) -> dict:
        d = asdict(self)
        d["preview_dir"] = str(self.preview_dir) if self.preview_dir else None
        return d
