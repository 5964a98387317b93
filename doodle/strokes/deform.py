"""Barr's global deformations of a superquadric: linear tapering and circular bending along its local ``z``.

A plain superquadric explains a cone-like part (a lamp shade, a spout) or a curved one (a horn, a handle, a
tail) poorly: its best fit overshoots one end and falls short at the other, and its outline strays from the
part's. Barr (1984) deforms the superquadric's local frame; the superquadric-recovery literature (Solina &
Bajcsy 1990; EMS, Marching-Primitives) uses the same two deformations, in this order:

- **tapering**, ``taper = (t_x, t_y)`` in ``[−1, 1]``: ``x ← (1 + t_x z/a₃) x``, ``y ← (1 + t_y z/a₃) y``
  (the cross-section grows linearly along ``z``; ``±1`` closes one end to a point);
- **bending**, ``bend = (b_x, b_y)`` in the local ``xy`` plane: the ``z`` axis bends into a circular arc
  toward the direction of ``b``, turning by ``|b|`` radians over ``z ∈ [0, a₃]`` (curvature ``κ = |b|/a₃``);
  cross-sections stay planar, perpendicular to the arc, and lengths along the axis are kept.

Points move from the undeformed local frame to the deformed one with :func:`deform` and back with
:func:`undeform` (exact inverses inside the part; the bending's inverse needs ``1 − κ r > 0``, the part not
folded over its own centre of curvature, which :data:`BEND_MAX` keeps). The bending is written in the
curvature ``κ`` (signed) and the unit direction of its plane, through ``sinc``-like functions of ``κ z``,
so it is exact and smooth at ``κ = 0`` (the plain superquadric) and its gradients are finite there — the fit
starts every part unbent.

Every function works on numpy arrays (exporters, float64) and torch tensors (fitting, autograd); shapes
broadcast: points ``(..., 3)``, ``scale (..., 3)``, ``taper (..., 2)``, ``curvature (...)``, ``direction
(..., 2)``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..arrays import ops

#: Largest tapering factor: ``±1`` closes an end to a point, so a fit stops short of it.
TAPER_MAX = 0.9
#: Largest bend, radians over the half-length: 72°, a quarter circle over the whole part is 90° each side.
#: Beyond it a bent part's inner side folds over its centre of curvature for stout parts.
BEND_MAX = 1.25


def _sinc(x: Any) -> Any:
    """``sin x / x`` (1 at 0)."""
    return ops(x).sinc(x / math.pi)


def taper(x: Any, scale: Any, factors: Any) -> Any:
    """Tapered points: ``x ← (1 + t_x z/a₃) x``, ``y ← (1 + t_y z/a₃) y``, ``z`` kept."""
    k = 1.0 + factors * (x[..., 2:3] / scale[..., 2:3])
    return _cat(x[..., :2] * k, x[..., 2:3])


def untaper(x: Any, scale: Any, factors: Any) -> Any:
    """Inverse of :func:`taper` (points beyond a closed end map far outside)."""
    xp = ops(x)
    k = 1.0 + factors * (x[..., 2:3] / scale[..., 2:3])
    k = xp.where(xp.abs(k) < 1e-3, 1e-3 + 0.0 * k, k)
    return _cat(x[..., :2] / k, x[..., 2:3])


def _cat(xy: Any, z: Any) -> Any:
    """``(..., 2)`` and ``(..., 1)`` → ``(..., 3)``."""
    return ops(xy).cat([xy, z], -1)


def bend(x: Any, curvature: Any, direction: Any) -> Any:
    """Bent points: the ``z`` axis becomes an arc of ``curvature`` (signed, 1/length) in the plane of
    ``direction`` (unit, ``(..., 2)``), lengths along it kept.

    With ``r = x_xy · d`` and ``γ = κ z``: ``x_xy ← x_xy + z² h(γ) κ (1 − κ r) d``, ``z ← z sinc(γ) (1 − κ r)``,
    ``h(γ) = (1 − cos γ)/γ² = sinc²(γ/2)/2``.
    """
    k = curvature[..., None]
    z = x[..., 2:3]
    r = (x[..., :2] * direction).sum(-1, keepdims=True)
    g = k * z
    lever = 1.0 - k * r
    h = 0.5 * _sinc(0.5 * g) ** 2
    return _cat(x[..., :2] + (z * z * h * k * lever) * direction, z * _sinc(g) * lever)


def unbend(x: Any, curvature: Any, direction: Any) -> Any:
    """Inverse of :func:`bend`, exact where ``1 − κ r > 0``.

    With ``u = κ (x_xy · d)``, ``a = κ z``, ``b = 1 − u``: the bent angle is ``atan2(a, b)``, so the unbent
    ``z = z · atan2(a, b)/a`` and ``r = (2U − κ(U² + z²)) / (1 + √(a² + b²))`` (``U = x_xy · d``), both smooth
    at ``κ = 0``.
    """
    xp = ops(x)
    k = curvature[..., None]
    z = x[..., 2:3]
    U = (x[..., :2] * direction).sum(-1, keepdims=True)
    a, b = k * z, 1.0 - k * U
    small = xp.abs(a) < 1e-4
    safe = xp.where(small, 1e-4 + 0.0 * a, a)
    q = xp.where(small, (1.0 - a * a / (3.0 * b * b)) / b, xp.atan2(safe, b) / safe)
    r = (2.0 * U - k * (U * U + z * z)) / (1.0 + xp.sqrt(a * a + b * b))
    return _cat(x[..., :2] - (U - r) * direction, z * q)


def bend_axis(bend_vectors: Any, scale: Any) -> tuple[Any, Any]:
    """Curvature ``(...)`` and unit direction ``(..., 2)`` of bend vectors ``(..., 2)`` (see the module doc);
    an unbent part gets curvature 0 and direction ``(1, 0)``."""
    xp = ops(bend_vectors)
    angle = xp.norm(bend_vectors, -1)
    unit = bend_vectors / xp.clip_min(angle, 1e-12)[..., None]
    fallback = xp.asarray([1.0, 0.0], bend_vectors) + 0.0 * bend_vectors
    direction = xp.where((angle > 1e-12)[..., None], unit, fallback)
    return angle / scale[..., 2], direction


def deform(x: Any, scale: Any, taper_factors: Any, curvature: Any, direction: Any) -> Any:
    """Undeformed local points → deformed ones: :func:`taper`, then :func:`bend`."""
    return bend(taper(x, scale, taper_factors), curvature, direction)


def undeform(x: Any, scale: Any, taper_factors: Any, curvature: Any, direction: Any) -> Any:
    """Deformed local points → undeformed ones: :func:`unbend`, then :func:`untaper`."""
    return untaper(unbend(x, curvature, direction), scale, taper_factors)


def deformed_normals(x: np.ndarray, normals: np.ndarray, scale: np.ndarray, taper_factors: np.ndarray,
                     curvature: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """Unit normals ``(..., 3)`` of the deformed surface at the images of undeformed surface points ``x`` whose
    undeformed normals are ``normals``: ``J⁻ᵀ n`` with the deformation's Jacobian ``J`` by central differences
    (numpy, float64: exporters only)."""
    h = 1e-5 * np.linalg.norm(scale, axis=-1)[..., None, None] * np.eye(3)  # (..., 3, 3): one step per row
    xs = x[..., None, :]
    ahead = deform(xs + h, scale[..., None, :], taper_factors[..., None, :], curvature[..., None], direction[..., None, :])
    behind = deform(xs - h, scale[..., None, :], taper_factors[..., None, :], curvature[..., None], direction[..., None, :])
    jt = (ahead - behind) / (2 * np.diagonal(h, axis1=-2, axis2=-1)[..., None])  # (..., 3, 3): row i = ∂D/∂x_i = Jᵀ
    n = np.linalg.solve(jt, normals[..., None])[..., 0]
    return n / np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-12)


def bound_factor(taper_factors: np.ndarray, bend_vectors: np.ndarray) -> np.ndarray:
    """``(M,)`` factors by which a deformed superquadric's bounding radius ``|a|`` grows, at most: tapering
    scales a cross-section by ``1 + |t|``; bending keeps lengths along the axis and moves the rest by at most
    ``κ r z``-order terms, bounded by ``1 + |b|``."""
    return (1.0 + np.abs(taper_factors).max(axis=-1)) * (1.0 + np.linalg.norm(bend_vectors, axis=-1))
