"""Cameras in the OpenCV convention: x right, y down, z forward; extrinsics map world → camera.

``p_cam = R p_world + t``. Perspective: ``u = fx x/z + cx``, ``v = fy y/z + cy``. Orthographic: ``u = fx x + cx``,
``v = fy y + cy`` with ``fx``, ``fy`` in pixels per scene unit. Pixel centres sit at integer + 0.5
(pixel ``(0, 0)`` covers ``[0, 1]²``), as in NeRF and COLMAP.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Literal

import numpy as np

from ..arrays import check_shape, is_tensor, ops

if TYPE_CHECKING:  # annotations only: numpy callers never import torch
    import torch

Projection = Literal["perspective", "orthographic"]


def project_points(points, R, t, K, orthographic: bool = False):
    """Project world points to pixels.

    Args:
        points: ``(..., 3)`` world points (numpy or torch; ``R``, ``t``, ``K`` are converted to match).
        R: ``(3, 3)`` world-to-camera rotation; t: ``(3,)``.
        K: ``(4,)`` = ``(fx, fy, cx, cy)``.
        orthographic: parallel projection along the camera's z axis.
    Returns:
        ``uv (..., 2)`` pixels and ``depth (...)`` (camera z). Perspective divides by ``depth`` as is:
        callers mask points with ``depth ≤ near`` (see :mod:`doodle.exporters.project`).

    >>> import numpy as np
    >>> uv, z = project_points(np.array([[0.0, 0, 2]]), np.eye(3), np.zeros(3), np.array([100.0, 100, 50, 50]))
    >>> uv.tolist(), z.tolist()
    ([[50.0, 50.0]], [2.0])
    """
    check_shape(points, (3,), "points")
    xp = ops(points)
    R, t, K = (xp.asarray(a, points) for a in (R, t, K))
    pc = points @ xp.transpose(R) + t
    z = pc[..., 2]
    xy = pc[..., :2] if orthographic else pc[..., :2] / z[..., None]
    return xy * K[:2] + K[2:], z


def look_at(eye: np.ndarray, target: np.ndarray, up: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World-to-camera ``(R, t)`` of a camera at ``eye`` looking at ``target`` with ``up`` pointing up in the image.

    Raises:
        ValueError: if ``eye == target`` or the view direction is parallel to ``up``.
    """
    eye, target, up = (np.asarray(v, dtype=np.float64) for v in (eye, target, up))
    forward = target - eye
    dist = np.linalg.norm(forward)
    if dist < 1e-12:
        raise ValueError("camera position equals its target")
    z = forward / dist
    x = np.cross(z, up)  # image x (right) = forward × up; image y (down) = forward × right
    if np.linalg.norm(x) < 1e-9:
        raise ValueError("view direction is parallel to the up vector")
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.stack([x, y, z])
    return R, -R @ eye


OUTPUT_CAP = 1024  # px, the long side of default exports


def output_size(width: float, height: float, cap: int = OUTPUT_CAP) -> tuple[int, int]:
    """The default export size for photos of ``width × height``: their size, the long side capped at ``cap``."""
    f = min(1.0, cap / max(width, height))
    return max(1, round(width * f)), max(1, round(height * f))


@dataclass
class Camera:
    """A pinhole (or orthographic) camera with square or non-square pixels."""

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int
    R: np.ndarray = field(default_factory=lambda: np.eye(3))
    """World-to-camera rotation ``(3, 3)``."""
    t: np.ndarray = field(default_factory=lambda: np.zeros(3))
    """World-to-camera translation ``(3,)``."""
    projection: Projection = "perspective"
    name: str = ""

    @property
    def K(self) -> np.ndarray:
        """``(fx, fy, cx, cy)``."""
        return np.array([self.fx, self.fy, self.cx, self.cy], dtype=np.float64)

    @property
    def center(self) -> np.ndarray:
        """Camera centre in world coordinates, ``−Rᵀ t`` (for orthographic cameras, a point on the axis)."""
        return -self.R.T @ self.t

    @property
    def forward(self) -> np.ndarray:
        """Unit viewing direction (camera +z) in world coordinates."""
        return self.R[2].copy()

    @property
    def c2w(self) -> np.ndarray:
        """Camera-to-world ``(4, 4)`` matrix (OpenCV axes)."""
        m = np.eye(4)
        m[:3, :3] = self.R.T
        m[:3, 3] = self.center
        return m

    def project(self, points: np.ndarray | torch.Tensor):
        """Project world points ``(..., 3)`` → ``(uv (..., 2), depth (...))`` (numpy or torch)."""
        if not is_tensor(points):
            points = np.asarray(points, dtype=np.float64)
        return project_points(points, self.R, self.t, self.K, self.projection == "orthographic")

    def rays(self) -> tuple[np.ndarray, np.ndarray]:
        """World-space ray origins and unit directions through every pixel centre, ``(H, W, 3)`` each."""
        v, u = np.meshgrid(np.arange(self.height) + 0.5, np.arange(self.width) + 0.5, indexing="ij")
        return self.rays_at(u, v)

    def rays_at(self, u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World-space ray origins and unit directions through pixel positions ``u, v`` (any equal shapes)."""
        x = (u - self.cx) / self.fx
        y = (v - self.cy) / self.fy
        Rt = self.R.T
        if self.projection == "orthographic":
            origins = np.stack([x, y, np.zeros_like(x)], -1) @ Rt.T + self.center
            dirs = np.broadcast_to(self.forward, origins.shape).copy()
        else:
            d = np.stack([x, y, np.ones_like(x)], -1) @ Rt.T
            dirs = d / np.linalg.norm(d, axis=-1, keepdims=True)
            origins = np.broadcast_to(self.center, dirs.shape).copy()
        return origins, dirs

    def scaled(self, factor: float) -> "Camera":
        """The same camera for an image resized by ``factor`` (intrinsics scale, pose unchanged)."""
        w, h = max(1, round(self.width * factor)), max(1, round(self.height * factor))
        sx, sy = w / self.width, h / self.height
        return replace(self, fx=self.fx * sx, fy=self.fy * sy, cx=self.cx * sx, cy=self.cy * sy, width=w, height=h)

    def resized(self, width: int, height: int | None = None) -> "Camera":
        """The same camera for an image of ``width`` × ``height`` pixels (height keeps the aspect by default)."""
        height = height if height is not None else max(1, round(self.height * width / self.width))
        sx, sy = width / self.width, height / self.height
        return replace(self, fx=self.fx * sx, fy=self.fy * sy, cx=self.cx * sx, cy=self.cy * sy, width=width, height=height)

    @property
    def fov_deg(self) -> float:
        """Horizontal field of view in degrees (perspective only)."""
        return math.degrees(2 * math.atan(0.5 * self.width / self.fx))
