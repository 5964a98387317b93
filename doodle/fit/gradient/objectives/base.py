"""The objective interface of the gradient stages. An objective sees strokes only through this API, so any
objective registered beside the weight-free ``edges`` (the paper's perceptual one, say, with weights from a
local path) shares the stroke model, the cameras and the optimiser."""

from __future__ import annotations

from typing import Protocol

import torch

from ....strokes.model import SceneFrame
from ..params import CurveParams, SuperquadricParams
from ..targets import ViewTargets

Terms = dict[str, torch.Tensor]
"""Named loss terms of one step; ``"total"`` is what the optimiser minimises."""


class Objective(Protocol):
    name: str

    def begin(self, targets: ViewTargets, frame: SceneFrame, generator: torch.Generator) -> None:
        """Called before each stage with that stage's targets."""

    def superquadric_terms(self, sq: SuperquadricParams, views: torch.Tensor) -> Terms:
        """Loss of the superquadrics on the training views ``views`` (indices)."""

    def curve_terms(self, curves: CurveParams, views: torch.Tensor) -> Terms:
        """Loss of the curves (superquadrics frozen) on the training views ``views``."""
