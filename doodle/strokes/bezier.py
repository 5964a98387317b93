"""Cubic Bézier curves in any dimension (pure functions, numpy or torch).

``B(t) = Σ_j C(3, j) t^j (1 - t)^(3 - j) p_j`` for control points ``p`` of shape ``(..., 4, D)``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..arrays import check_shape, is_tensor, ops

if TYPE_CHECKING:  # annotations only: numpy callers never import torch
    import torch

# The evaluation functions below are written against ``ops`` (numpy or torch), so numpy callers (the
# exporters, many small calls per view) skip the conversion to torch.


def bernstein(t: torch.Tensor) -> torch.Tensor:
    """Cubic Bernstein basis ``b_j(t)``.

    Args:
        t: parameters, shape ``(T,)``.
    Returns:
        ``(T, 4)``; each row sums to 1.

    >>> import numpy as np
    >>> bernstein(np.array([0.0, 0.5, 1.0])).round(3).tolist()
    [[1.0, 0.0, 0.0, 0.0], [0.125, 0.375, 0.375, 0.125], [0.0, 0.0, 0.0, 1.0]]
    """
    t = t[..., None]
    s = 1.0 - t
    return ops(t).concatenate([s**3, 3 * t * s**2, 3 * t**2 * s, t**3], axis=-1)


def bezier_points(control: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
    """Evaluate curves at parameters ``t``.

    Args:
        control: ``(..., 4, D)`` control points.
        t: ``(T,)`` parameters in [0, 1].
    Returns:
        ``(..., T, D)`` points.
    """
    check_shape(control, (4, None), "control")
    if is_tensor(control):
        t = ops(control).asarray(t, control)
    return bernstein(t) @ control


def bezier_derivative(control: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
    """First derivative ``dB/dt`` at ``t``: a quadratic Bézier on ``3 (p_{j+1} - p_j)``.

    Args:
        control: ``(..., 4, D)``.
        t: ``(T,)``.
    Returns:
        ``(..., T, D)``.
    """
    check_shape(control, (4, None), "control")
    d = 3.0 * (control[..., 1:, :] - control[..., :-1, :])
    if is_tensor(control):
        t = ops(control).asarray(t, control)
    t = t[..., None]
    s = 1.0 - t
    return ops(t).concatenate([s**2, 2 * t * s, t**2], axis=-1) @ d


def bezier_segment(control: torch.Tensor, t0: float, t1: float) -> torch.Tensor:
    """Control points of the piece of the curve between parameters ``t0`` and ``t1`` (exact).

    The sub-curve is the polar form (blossom) evaluated at ``(t0, t0, t0)``, ``(t0, t0, t1)``,
    ``(t0, t1, t1)``, ``(t1, t1, t1)``.

    Args:
        control: ``(..., 4, D)``.
    Returns:
        ``(..., 4, D)`` with ``segment(t=0) = B(t0)`` and ``segment(t=1) = B(t1)``.

    >>> import numpy as np
    >>> c = np.array([[0.0, 0], [1, 2], [3, 2], [4, 0]])
    >>> seg = bezier_segment(c, 0.25, 0.75)
    >>> bool(np.allclose(bezier_points(seg, np.array([0.5])), bezier_points(c, np.array([0.5]))))
    True
    """
    check_shape(control, (4, None), "control")

    def blossom(u1: float, u2: float, u3: float) -> torch.Tensor:
        pts = control
        for u in (u1, u2, u3):  # de Casteljau with a different parameter at each level
            pts = (1.0 - u) * pts[..., :-1, :] + u * pts[..., 1:, :]
        return pts[..., 0, :]

    parts = [blossom(t0, t0, t0), blossom(t0, t0, t1), blossom(t0, t1, t1), blossom(t1, t1, t1)]
    return ops(control).stack(parts, -2)


def bezier_length(control: torch.Tensor, samples: int = 64) -> torch.Tensor:
    """Arc length by dense polyline sampling. ``(..., 4, D)`` → ``(...)``."""
    pts = bezier_points(control, np.linspace(0.0, 1.0, samples))
    return ops(control).norm(pts[..., 1:, :] - pts[..., :-1, :], -1).sum(-1)
