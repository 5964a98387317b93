"""Torch parameterisations of the stroke model for optimisation, and conversion to/from :class:`StrokeSet`.

Superquadric parameters are unconstrained: ``scale = exp(log_scale)``, ``ε = 0.1 + 1.8 σ(raw)`` (so the
file's ``[0.1, 1.9]`` range holds by construction), quaternions normalised on use.
"""

from __future__ import annotations



import numpy as np
import torch

from ...strokes.model import CurveSet, SuperquadricSet

SHAPE_LO, SHAPE_HI = 0.1, 1.9


class SuperquadricParams(torch.nn.Module):
    def __init__(self, scale: np.ndarray, shape: np.ndarray, rotation: np.ndarray, translation: np.ndarray):
        super().__init__()
        f32 = dict(dtype=torch.float32)
        s = np.clip((np.asarray(shape) - SHAPE_LO) / (SHAPE_HI - SHAPE_LO), 1e-4, 1 - 1e-4)
        self.log_scale = torch.nn.Parameter(torch.tensor(np.log(scale), **f32))
        self.raw_shape = torch.nn.Parameter(torch.tensor(np.log(s / (1 - s)), **f32))
        self.rotation = torch.nn.Parameter(torch.tensor(rotation, **f32))
        self.translation = torch.nn.Parameter(torch.tensor(translation, **f32))

    def __len__(self) -> int:
        return int(self.log_scale.shape[0])

    def values(self) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
        """``scale, shape, unit quaternion, translation``."""
        shape = SHAPE_LO + (SHAPE_HI - SHAPE_LO) * torch.sigmoid(self.raw_shape)
        q = self.rotation / self.rotation.norm(dim=-1, keepdim=True).clamp_min(1e-8)
        return self.log_scale.exp(), shape, q, self.translation

    def to_set(self) -> SuperquadricSet:
        scale, shape, q, t = (v.detach().double().cpu().numpy() for v in self.values())
        return SuperquadricSet(scale, np.clip(shape, SHAPE_LO, SHAPE_HI), q * np.sign(q[:, :1] + 1e-12), t)

    @classmethod
    def from_set(cls, sq: SuperquadricSet) -> "SuperquadricParams":
        return cls(sq.scale, sq.shape, sq.rotation, sq.translation)


class CurveParams(torch.nn.Module):
    def __init__(self, control_points: np.ndarray):
        super().__init__()
        self.control = torch.nn.Parameter(torch.tensor(control_points, dtype=torch.float32))

    def __len__(self) -> int:
        return int(self.control.shape[0])

    def to_set(self, width_px: float) -> CurveSet:
        return CurveSet(self.control.detach().double().cpu().numpy(), width_px)


def initial_curves(centers: np.ndarray, length: float, rng: np.random.Generator) -> np.ndarray:
    """Short straight curves ``(N, 4, 3)`` through ``centers`` in random directions."""
    d = rng.normal(size=centers.shape)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    s = np.array([-0.5, -1 / 6, 1 / 6, 0.5])
    return centers[:, None, :] + length * s[None, :, None] * d[:, None, :]


def initial_superquadrics(centers: np.ndarray, radius: float) -> SuperquadricSet:
    """Ellipsoids of scale ``0.2 · radius`` at ``centers``."""
    m = len(centers)
    return SuperquadricSet(np.full((m, 3), 0.2 * radius), np.full((m, 2), 0.9),
                           np.tile([1.0, 0.0, 0.0, 0.0], (m, 1)), centers.copy())




