"""Test helpers importable from every test module (pytest puts tests/ on sys.path)."""

from __future__ import annotations

import numpy as np

from doodle.strokes import CurveSet, SceneFrame, StrokeSet, SuperquadricSet
from doodle.strokes.superquadric import matrix_to_quaternion


def random_strokes(seed: int = 0, n_curves: int = 32, n_sq: int = 8, radius: float = 1.5) -> StrokeSet:
    """A valid stroke set with random geometry inside the bounding sphere."""
    rng = np.random.default_rng(seed)
    rot = np.stack([matrix_to_quaternion(_proper(r)) for r in np.linalg.qr(rng.normal(size=(n_sq, 3, 3)))[0]]) if n_sq else np.zeros((0, 4))
    return StrokeSet(
        SceneFrame(radius=radius),
        CurveSet(rng.uniform(-radius * 0.7, radius * 0.7, (n_curves, 4, 3))),
        SuperquadricSet(rng.uniform(0.1, 0.5, (n_sq, 3)) * radius, rng.uniform(0.1, 1.9, (n_sq, 2)), rot,
                        rng.uniform(-0.5, 0.5, (n_sq, 3)) * radius),
        provenance={"tool": "doodle test", "source": "random", "iterations": 0, "seconds": 0.0},
    )


def _proper(r: np.ndarray) -> np.ndarray:
    return r if np.linalg.det(r) > 0 else -r
