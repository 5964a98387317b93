"""Torch parameterisations of the stroke model for optimisation, and conversion to/from :class:`StrokeSet`.

Superquadric parameters are unconstrained: ``scale = exp(log_scale)``, ``ε = 0.1 + 1.8 σ(raw)`` (so the
file's ``[0.1, 1.9]`` range holds by construction), quaternions normalised on use. Tapering and bending
(:mod:`doodle.strokes.deform`) are parameters only of a ``deformable`` set (else fixed buffers, so the
gradient paths' optimisers and checkpoints are as before): ``taper = TAPER_MAX tanh(raw)``, and the bend as a
signed angle ``β = limit · tanh(raw)`` toward the direction at angle ``α`` in the local ``xy`` plane — not as a
vector, whose direction has no gradient at zero. ``limit`` keeps the part from folding over its centre of
curvature (``κ r < 0.9`` across its tapered cross-section) and under :data:`~doodle.strokes.deform.BEND_MAX`.
"""

from __future__ import annotations



import numpy as np
import torch

from ...strokes.deform import BEND_MAX, TAPER_MAX
from ...strokes.model import CurveSet, SuperquadricSet

SHAPE_LO, SHAPE_HI = 0.1, 1.9


#: How close to folding a bend may come: ``κ r`` at most this across the part's cross-section.
FOLD = 0.9


def _bend_limit(scale: torch.Tensor, taper: torch.Tensor) -> torch.Tensor:
    """Largest bend angle ``(M,)`` of superquadrics with ``scale (M, 3)`` and ``taper (M, 2)``."""
    widest = scale[:, :2].max(1).values * (1 + taper.abs().max(1).values)
    return (FOLD * scale[:, 2] / widest).clamp(max=BEND_MAX)


class SuperquadricParams(torch.nn.Module):
    def __init__(self, scale: np.ndarray, shape: np.ndarray, rotation: np.ndarray, translation: np.ndarray,
                 taper: np.ndarray | None = None, bend: np.ndarray | None = None, deformable: bool = False):
        super().__init__()
        f32 = dict(dtype=torch.float32)
        s = np.clip((np.asarray(shape) - SHAPE_LO) / (SHAPE_HI - SHAPE_LO), 1e-4, 1 - 1e-4)
        self.log_scale = torch.nn.Parameter(torch.tensor(np.log(scale), **f32))
        self.raw_shape = torch.nn.Parameter(torch.tensor(np.log(s / (1 - s)), **f32))
        self.rotation = torch.nn.Parameter(torch.tensor(rotation, **f32))
        self.translation = torch.nn.Parameter(torch.tensor(translation, **f32))
        m = len(self.log_scale)
        taper = np.zeros((m, 2)) if taper is None else np.asarray(taper, np.float64)
        bend = np.zeros((m, 2)) if bend is None else np.asarray(bend, np.float64)
        beta = np.linalg.norm(bend, axis=1)
        limit = _bend_limit(torch.as_tensor(np.asarray(scale, np.float64)), torch.as_tensor(taper)).numpy()
        ratio = np.clip(beta / limit, 0.0, 0.999)
        raw = {"raw_taper": np.arctanh(np.clip(taper / TAPER_MAX, -0.999, 0.999)), "raw_bend": np.arctanh(ratio),
               "bend_direction": np.arctan2(bend[:, 1], bend[:, 0])}
        for name, value in raw.items():
            tensor = torch.tensor(value, **f32)
            if deformable:
                setattr(self, name, torch.nn.Parameter(tensor))
            else:
                self.register_buffer(name, tensor)
        self.deformable = deformable

    def __len__(self) -> int:
        return int(self.log_scale.shape[0])

    def values(self) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
        """``scale, shape, unit quaternion, translation``."""
        shape = SHAPE_LO + (SHAPE_HI - SHAPE_LO) * torch.sigmoid(self.raw_shape)
        q = self.rotation / self.rotation.norm(dim=-1, keepdim=True).clamp_min(1e-8)
        return self.log_scale.exp(), shape, q, self.translation

    def taper_bend(self) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """``taper (M, 2)``, signed bend angle ``β (M,)`` and the bend's unit direction ``(M, 2)``."""
        taper = TAPER_MAX * torch.tanh(self.raw_taper)
        beta = _bend_limit(self.log_scale.exp(), taper) * torch.tanh(self.raw_bend)
        return taper, beta, torch.stack([torch.cos(self.bend_direction), torch.sin(self.bend_direction)], -1)

    def deformation(self) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor] | None:
        """``(taper, curvature, direction)`` for :func:`~doodle.strokes.superquadric.canonical`, or ``None``
        when the set is not deformable and none is deformed."""
        if not self.deformable and not (bool(self.raw_taper.any()) or bool(self.raw_bend.any())):
            return None
        taper, beta, direction = self.taper_bend()
        return taper, beta / self.log_scale.exp()[:, 2], direction

    def to_set(self) -> SuperquadricSet:
        scale, shape, q, t = (v.detach().double().cpu().numpy() for v in self.values())
        sq = SuperquadricSet(scale, np.clip(shape, SHAPE_LO, SHAPE_HI), q * np.sign(q[:, :1] + 1e-12), t)
        taper, beta, direction = (v.detach().double().cpu().numpy() for v in self.taper_bend())
        bend = beta[:, None] * direction
        return sq.with_deformation(np.where(np.abs(taper) < 1e-6, 0.0, taper), np.where(np.abs(bend) < 1e-6, 0.0, bend))

    @classmethod
    def from_set(cls, sq: SuperquadricSet, deformable: bool = False) -> "SuperquadricParams":
        return cls(sq.scale, sq.shape, sq.rotation, sq.translation, sq.taper, sq.bend, deformable)


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




