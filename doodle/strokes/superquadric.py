"""Superquadrics: inside-outside function, analytic normals, parametric surface, union.

Conventions (DESIGN.md): scale ``a (…, 3)``, shape ``ε = (ε1, ε2) (…, 2)``, rotation unit quaternion
``(w, x, y, z) (…, 4)``, translation ``t (…, 3)``. Local coordinates ``x = Rᵀ (p − t)``. In the local frame

    f(x) = ((x/a1)^(2/ε2) + (y/a2)^(2/ε2))^(ε2/ε1) + (z/a3)^(2/ε1)

with ``f = 1`` on the surface, ``f < 1`` inside. All functions work in log space, which keeps values and
gradients finite for ε in [0.1, 1.9], points on the axes (where ``x^(2/ε)`` has an unbounded derivative
for ε > 1) and points far away (where ``f`` overflows float32 for small ε). The price is a tiny bias:
``x²`` is replaced by ``x² + EPS_SQ`` (relative to the scale), i.e. at most ``EPS_SQ^(1/ε)`` in ``f``.

A tapered or bent superquadric (:mod:`doodle.strokes.deform`) is tested in its *canonical* frame: world
points are taken to the local frame and undeformed there (:func:`canonical`), where ``f`` is the plain one's.
Its ``deformation`` travels as ``(taper (M, 2), curvature (M,), direction (M, 2))``, or ``None`` when no
superquadric of a set is deformed (the plain path, bit for bit as before).
"""

from __future__ import annotations

import math

from typing import TYPE_CHECKING

import numpy as np

from ..arrays import check_shape, ops
from .deform import bend_axis, bound_factor, deform, deformed_normals, undeform

if TYPE_CHECKING:  # annotations only: numpy callers never import torch
    import torch

#: Added to squared normalised coordinates so log and fractional powers stay finite on the axes.
EPS_SQ = 1e-12


def quaternion_to_matrix(q: torch.Tensor) -> torch.Tensor:
    """Rotation matrices from quaternions ``(w, x, y, z)``; ``q`` is normalised first.

    Args:
        q: ``(..., 4)``.
    Returns:
        ``(..., 3, 3)``, mapping local to world: ``p = R x + t``.

    >>> import numpy as np
    >>> quaternion_to_matrix(np.array([1.0, 0, 0, 0])).tolist()
    [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    """
    check_shape(q, (4,), "rotation")
    xp = ops(q)
    q = q / xp.clip_min(xp.norm(q, -1, True), 1e-12)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    rows = [
        1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
        2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
        2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y),
    ]
    return xp.stack(rows, -1).reshape(*q.shape[:-1], 3, 3)


def matrix_to_quaternion(R):
    """Unit quaternion ``(w, x, y, z)`` with ``w ≥ 0`` from rotation matrices ``(..., 3, 3)`` (numpy or torch).

    >>> import numpy as np
    >>> matrix_to_quaternion(np.diag([1.0, -1.0, -1.0])).round(6).tolist()
    [0.0, 1.0, 0.0, 0.0]
    """
    check_shape(R, (3, 3), "R")
    xp = ops(R)
    m = R
    tr = m[..., 0, 0] + m[..., 1, 1] + m[..., 2, 2]
    cands = xp.stack(
        [
            xp.stack([1 + tr, m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1]], -1),
            xp.stack([m[..., 2, 1] - m[..., 1, 2], 1 + m[..., 0, 0] - m[..., 1, 1] - m[..., 2, 2], m[..., 0, 1] + m[..., 1, 0], m[..., 0, 2] + m[..., 2, 0]], -1),
            xp.stack([m[..., 0, 2] - m[..., 2, 0], m[..., 0, 1] + m[..., 1, 0], 1 - m[..., 0, 0] + m[..., 1, 1] - m[..., 2, 2], m[..., 1, 2] + m[..., 2, 1]], -1),
            xp.stack([m[..., 1, 0] - m[..., 0, 1], m[..., 0, 2] + m[..., 2, 0], m[..., 1, 2] + m[..., 2, 1], 1 - m[..., 0, 0] - m[..., 1, 1] + m[..., 2, 2]], -1),
        ],
        -2,
    )  # (..., 4, 4): row k is 4·q·q_k, best conditioned where q_k is largest
    best = xp.stack([1 + tr, 1 + m[..., 0, 0] - m[..., 1, 1] - m[..., 2, 2],
                     1 - m[..., 0, 0] + m[..., 1, 1] - m[..., 2, 2], 1 - m[..., 0, 0] - m[..., 1, 1] + m[..., 2, 2]], -1).argmax(-1)
    flat, pick = cands.reshape(-1, 4, 4), best.reshape(-1)
    q = flat[xp.arange(len(pick)), pick].reshape(*tuple(best.shape), 4)
    q = q / xp.norm(q, -1, True)
    return xp.where(q[..., :1] < 0, -q, q)


def world_to_local(points: torch.Tensor, rotation: torch.Tensor, translation: torch.Tensor) -> torch.Tensor:
    """Express world points in each superquadric's frame: ``x = Rᵀ (p − t)``.

    Args:
        points: ``(P, 3)``.
        rotation: ``(M, 4)`` quaternions.
        translation: ``(M, 3)``.
    Returns:
        ``(M, P, 3)``.
    """
    check_shape(points, (3,), "points")
    R = quaternion_to_matrix(rotation)  # (M, 3, 3)
    d = points[None, :, :] - translation[:, None, :]
    return d @ R  # row-vector form of Rᵀ d


def _log_terms(x: torch.Tensor, scale: torch.Tensor, shape: torch.Tensor):
    """Log-domain pieces of ``f``: ``lA, lB, lC`` and the squared normalised coordinates."""
    u = (x / scale[..., None, :]) ** 2 + EPS_SQ  # (M, P, 3)
    e1 = shape[..., None, 0]
    e2 = shape[..., None, 1]
    lu = ops(x).log(u)
    return lu[..., 0] / e2, lu[..., 1] / e2, lu[..., 2] / e1, u, e1, e2


def log_inside_outside(x: torch.Tensor, scale: torch.Tensor, shape: torch.Tensor) -> torch.Tensor:
    """``log f`` of local points.

    Args:
        x: ``(M, P, 3)`` points in each superquadric's local frame (see :func:`world_to_local`).
        scale: ``(M, 3)``; shape: ``(M, 2)``.
    Returns:
        ``(M, P)``; ``< 0`` inside, ``0`` on the surface.

    >>> import numpy as np
    >>> x = np.array([[[1.0, 0, 0], [0, 0, 0.5]]])
    >>> log_inside_outside(x, np.array([[1.0, 1, 1]]), np.array([[1.0, 1]])).round(4).tolist()
    [[0.0, -1.3863]]
    """
    xp = ops(x)
    lA, lB, lC, *_ = _log_terms(x, scale, shape)
    e1, e2 = shape[..., None, 0], shape[..., None, 1]
    lT = (e2 / e1) * xp.logaddexp(lA, lB)
    return xp.logaddexp(lT, lC)


def inside_outside(x: torch.Tensor, scale: torch.Tensor, shape: torch.Tensor) -> torch.Tensor:
    """``f`` of local points, ``(M, P, 3)`` → ``(M, P)``; ``exp`` of :func:`log_inside_outside`,
    clamped to 1e30 so far-away points stay finite."""
    xp = ops(x)
    return xp.exp(xp.clip_max(log_inside_outside(x, scale, shape), 69.0))


def local_gradient_log(x: torch.Tensor, scale: torch.Tensor, shape: torch.Tensor) -> torch.Tensor:
    """Analytic ``∇ log f`` in the local frame (same direction as ``∇f``), ``(M, P, 3)``.

    With ``wT = σ(lT − lC)``, ``wA = σ(lA − lB)``::

        ∂/∂x = wT wA (2/ε1) x/(a1² u),   ∂/∂y = wT (1 − wA) (2/ε1) y/(a2² v),   ∂/∂z = (1 − wT)(2/ε1) z/(a3² w)
    """
    xp = ops(x)
    lA, lB, lC, u, e1, e2 = _log_terms(x, scale, shape)
    lT = (e2 / e1) * xp.logaddexp(lA, lB)
    wT = xp.sigmoid(lT - lC)
    wA = xp.sigmoid(lA - lB)
    a2 = scale[..., None, :] ** 2
    common = 2.0 * x / (a2 * u) / e1[..., None]
    weights = xp.stack([wT * wA, wT * (1 - wA), 1 - wT], -1)
    return weights * common


def deformation_of(sq) -> tuple | None:
    """``(taper, curvature, direction)`` of a :class:`~doodle.strokes.model.SuperquadricSet`'s tapering and
    bending (numpy), or ``None`` when none of them is deformed."""
    if not len(sq) or not sq.deformed.any():
        return None
    return (sq.tapers, *bend_axis(sq.bends, sq.scale))


def canonical(points, scale, rotation, translation, deformation: tuple | None = None):
    """World points ``(P, 3)`` (or ``(M, P, 3)``, each superquadric its own) in each superquadric's canonical
    frame, ``(M, P, 3)``: :func:`world_to_local`, then undeformed (``deformation``: see the module doc)."""
    if points.ndim == 3:
        R = quaternion_to_matrix(rotation)
        x = (points - translation[:, None, :]) @ R
    else:
        x = world_to_local(points, rotation, translation)
    if deformation is None:
        return x
    taper, curvature, direction = deformation
    return undeform(x, scale[:, None, :], taper[:, None, :], curvature[:, None], direction[:, None, :])


def bounding_radius(sq) -> np.ndarray:
    """``(M,)`` radius about each superquadric's centre that holds it (``|a|`` for a plain one, which holds
    the box ``|x_i| ≤ a_i``; grown by :func:`~doodle.strokes.deform.bound_factor` for a deformed one)."""
    reach = np.linalg.norm(sq.scale, axis=1)
    return reach * bound_factor(sq.tapers, sq.bends) if len(sq) and sq.deformed.any() else reach


def world_boxes(sq, grid: tuple[int, int] = (33, 64)) -> tuple[np.ndarray, np.ndarray]:
    """``(M, 3)`` lower and ``(M, 3)`` upper corners of each superquadric's axis-aligned box in the world. A plain
    one's holds the corners of its local box ``|x_i| ≤ a_i`` (a safe bound); a deformed one's holds its surface
    sampled on a ``grid`` of η × ω, grown by 2 % of ``|a|`` for what the samples step over. The bending sphere
    of :func:`bounding_radius` may be several times larger (a bent part of DTU's skull, 0.6 across, reached
    2.6 from the centre and put a training camera "inside" the object)."""
    if not len(sq):
        return np.zeros((0, 3)), np.zeros((0, 3))
    R = quaternion_to_matrix(np.asarray(sq.rotation, float))
    corners = np.stack(np.meshgrid(*[[-1.0, 1.0]] * 3, indexing="ij"), -1).reshape(-1, 3)
    samples = [corners * a for a in sq.scale]
    margin = np.zeros(len(sq))
    bent = np.flatnonzero(sq.deformed)
    if len(bent):
        eta, omega = np.meshgrid(np.linspace(-np.pi / 2, np.pi / 2, grid[0]), np.linspace(-np.pi, np.pi, grid[1]),
                                 indexing="ij")
        those = sq.subset(sq.deformed)
        b = (slice(None), None, None)  # each deformed superquadric over the whole grid
        deformation = tuple(d[b] for d in deformation_of(those))
        p, _ = deformed_surface_points_at(eta, omega, those.scale[b], those.shape[b], deformation)
        for j, i in enumerate(bent):
            samples[i] = p[j].reshape(-1, 3)
        margin = np.where(sq.deformed, 0.02 * np.linalg.norm(sq.scale, axis=1), 0.0)
    world = [x @ R[i].T + sq.translation[i] for i, x in enumerate(samples)]
    lo = np.stack([w.min(axis=0) for w in world]) - margin[:, None]
    hi = np.stack([w.max(axis=0) for w in world]) + margin[:, None]
    return lo, hi


def union_log_inside_outside(
    points: torch.Tensor, scale: torch.Tensor, shape: torch.Tensor, rotation: torch.Tensor, translation: torch.Tensor,
    deformation: tuple | None = None,
) -> torch.Tensor:
    """``log min_i f_i`` of world points: the union of superquadrics. ``(P, 3)`` → ``(P,)``.

    An empty set gives ``+inf`` (everything outside).
    """
    xp = ops(points)
    if scale.shape[0] == 0:
        return xp.full(points.shape[:-1], math.inf, points)
    x = canonical(points, scale, rotation, translation, deformation)
    return xp.min(log_inside_outside(x, scale, shape), 0)


def world_normals(
    points: torch.Tensor, scale: torch.Tensor, shape: torch.Tensor, rotation: torch.Tensor, translation: torch.Tensor
) -> torch.Tensor:
    """Unit outward normals ``∇f/|∇f|`` of each superquadric at world points, ``(M, P, 3)``."""
    x = world_to_local(points, rotation, translation)
    xp = ops(points)
    g = local_gradient_log(x, scale, shape)
    R = quaternion_to_matrix(rotation)
    n = g @ xp.transpose(R)  # row-vector form of R g
    return n / xp.clip_min(xp.norm(n, -1, True), 1e-12)


def _signed_pow(v: torch.Tensor, e: torch.Tensor) -> torch.Tensor:
    """``sgn(v)|v|^e`` with round-off zeros kept at zero: ``sin(π) = 1.2e-16`` to the power 0.1 is 0.025,
    which would open the ω = ±π seam of a box-like superquadric by 2.5 % of its size."""
    xp = ops(v)
    a = xp.abs(v)
    return xp.where(a < 1e-9, 0.0 * v, xp.sign(v) * xp.clip_min(a, 1e-9) ** e)


def surface_points(
    eta: torch.Tensor, omega: torch.Tensor, scale: torch.Tensor, shape: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor]:
    """Parametric surface points and analytic unit normals in the local frame.

    ``x = a1 c(η,ε1) c(ω,ε2)``, ``y = a2 c(η,ε1) s(ω,ε2)``, ``z = a3 s(η,ε1)`` with
    ``c(θ,e) = sgn(cos θ)|cos θ|^e``, ``s(θ,e) = sgn(sin θ)|sin θ|^e``; the normal is
    ``(c(η,2−ε1) c(ω,2−ε2)/a1, c(η,2−ε1) s(ω,2−ε2)/a2, s(η,2−ε1)/a3)`` normalised.

    Args:
        eta: ``(...)`` latitudes in [−π/2, π/2]; omega: ``(...)`` longitudes in [−π, π], same shape.
        scale: ``(M, 3)``; shape: ``(M, 2)``.
    Returns:
        points ``(M, ..., 3)`` and unit normals ``(M, ..., 3)``.
    """
    extra = (None,) * eta.ndim
    return surface_points_at(eta, omega, scale[(slice(None), *extra)], shape[(slice(None), *extra)])


def surface_points_at(
    eta: torch.Tensor, omega: torch.Tensor, scale: torch.Tensor, shape: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor]:
    """:func:`surface_points` with the superquadric given per point: ``eta``, ``omega`` ``(...)``, ``scale``
    ``(..., 3)`` and ``shape`` ``(..., 2)`` broadcast together (points of many superquadrics in one call).

    >>> import numpy as np
    >>> p, n = surface_points_at(np.zeros(2), np.zeros(2), np.array([[1.0, 2, 3], [2, 2, 2]]), np.ones((2, 2)))
    >>> p.tolist(), n.tolist()
    ([[1.0, 0.0, 0.0], [2.0, 0.0, 0.0]], [[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    """
    xp = ops(scale)
    e1, e2 = shape[..., 0], shape[..., 1]
    ce, se, co, so = xp.cos(eta), xp.sin(eta), xp.cos(omega), xp.sin(omega)
    c1, n1 = _signed_pow(ce, e1), _signed_pow(ce, 2 - e1)
    p = xp.stack([c1 * _signed_pow(co, e2), c1 * _signed_pow(so, e2), _signed_pow(se, e1)], -1) * scale
    n = xp.stack([n1 * _signed_pow(co, 2 - e2), n1 * _signed_pow(so, 2 - e2), _signed_pow(se, 2 - e1)], -1) / scale
    return p, n / xp.clip_min(xp.norm(n, -1, True), 1e-12)


def deformed_surface_points_at(eta, omega, scale, shape, deformation: tuple | None = None):
    """:func:`surface_points_at` of tapered and bent superquadrics (numpy): points and unit normals in the
    local frame after the deformation (``(taper (..., 2), curvature (...), direction (..., 2))`` broadcast
    with the points; ``None``: plain)."""
    p, n = surface_points_at(eta, omega, scale, shape)
    if deformation is None:
        return p, n
    taper, curvature, direction = deformation
    n = deformed_normals(p, n, scale, taper, curvature, direction)
    return deform(p, scale, taper, curvature, direction), n
