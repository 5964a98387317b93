"""Ray marching against the superquadric union: hidden-line tests and union silhouettes (masks).

A segment is blocked when a point strictly inside the union (``log f < 0``) lies on it. Only the part of the
segment inside each superquadric's bounding sphere (radius ``|a|``: ``f ≤ 1`` implies ``|x_i| ≤ a_i``) is
sampled, so cost scales with what the rays actually pass near.
"""

from __future__ import annotations

import numpy as np

from ..cameras import Camera
from ..strokes.model import SuperquadricSet
from ..strokes.superquadric import log_inside_outside, quaternion_to_matrix


def segments_blocked(origins: np.ndarray, ends: np.ndarray, sq: SuperquadricSet, samples: int = 32) -> np.ndarray:
    """Whether each segment ``origins[k] → ends[k]`` ``(P, 3)`` passes through the union's interior, ``(P,)``."""
    P = len(origins)
    blocked = np.zeros(P, bool)
    if len(sq) == 0 or P == 0:
        return blocked
    d = ends - origins
    L = np.linalg.norm(d, axis=1)
    u = d / np.maximum(L, 1e-12)[:, None]
    R = quaternion_to_matrix(sq.rotation)  # (M, 3, 3) local → world
    s = (np.arange(samples) + 0.5) / samples
    for j in range(len(sq)):
        rad = float(np.linalg.norm(sq.scale[j]))
        oc = sq.translation[j] - origins
        b = np.einsum("ij,ij->i", oc, u)
        h2 = rad * rad - (np.einsum("ij,ij->i", oc, oc) - b * b)
        t0 = np.maximum(b - np.sqrt(np.maximum(h2, 0)), 0.0)
        t1 = np.minimum(b + np.sqrt(np.maximum(h2, 0)), L)
        idx = np.flatnonzero((h2 > 0) & (t1 > t0) & ~blocked)
        if len(idx) == 0:
            continue
        t = t0[idx, None] + (t1 - t0)[idx, None] * s  # (K, S)
        q = origins[idx, None, :] + t[..., None] * u[idx, None, :]
        local = (q - sq.translation[j]) @ R[j]
        lf = log_inside_outside(local.reshape(1, -1, 3), sq.scale[j:j + 1], sq.shape[j:j + 1]).reshape(len(idx), samples)
        blocked[idx[(lf < 0).any(axis=1)]] = True
    return blocked






def ray_origins(camera: Camera, points: np.ndarray) -> np.ndarray:
    """Where the camera ray through each world point starts: the centre (perspective) or the image plane."""
    if camera.projection == "orthographic":
        depth = (points - camera.center) @ camera.forward
        return points - depth[:, None] * camera.forward
    return np.broadcast_to(camera.center, points.shape)


def occluded(points: np.ndarray, camera: Camera, sq: SuperquadricSet, margin: float, samples: int = 32) -> np.ndarray:
    """Points ``(P, 3)`` hidden from ``camera`` by the union, ``(P,)``.

    The march stops ``margin`` (scene units) short of each point, so points on or just under the union's
    surface — feature curves lying on the object the superquadrics approximate — stay visible.
    """
    origins = ray_origins(camera, points)
    d = points - origins
    L = np.linalg.norm(d, axis=1, keepdims=True)
    ends = origins + d * np.clip((L - margin) / np.maximum(L, 1e-12), 0, 1)
    return segments_blocked(origins, ends, sq, samples)


def union_mask(sq: SuperquadricSet, camera: Camera, samples: int = 48, far: float | None = None) -> np.ndarray:
    """Boolean image ``(H, W)`` of the pixels whose ray meets the union (pixel centres)."""
    o, d = camera.rays()
    o, d = o.reshape(-1, 3), d.reshape(-1, 3)
    if far is None:
        reach = np.linalg.norm(sq.translation - camera.center, axis=1) + np.linalg.norm(sq.scale, axis=1)
        far = float(reach.max()) if len(sq) else 1.0
    return segments_blocked(o, o + far * d, sq, samples).reshape(camera.height, camera.width)
