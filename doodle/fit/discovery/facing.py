"""Which way a curve faces: the normals of the two faces that meet along it, read off the visual hull.

The exporters hide a curve point when both faces turn away from the camera (``CurveSet.normals``), so a
sketch of curves alone has no back lines. Near each end of a curve (a sixth of the way in, away from the
corner where other faces meet) the hull's outward normals within a few voxels are split into two groups
(2-means, seeded with the two most different ones): a crease gives two distinct face normals; a smooth
surface one (both faces the same); a wire thinner than the neighbourhood normals pointing every way,
whose mean is short, and then zero normals, which never hide.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from ...strokes.bezier import bezier_points
from ..volume.carve import VoxelGrid

FIT_GRAZING = 0.15
"""Cosine by which a face may turn away from a training view and still count as facing it (about 9°):
stricter than the exporters' 0.3 (about 17°), so a curve that the training views see stays visible from the
views between them (see :func:`curve_normals`)."""


def _two_faces(normals: np.ndarray, same_deg: float = 25.0, spread: float = 0.35) -> np.ndarray:
    """``(2, 3)`` face normals from the outward normals ``(K, 3)`` around a point (zeros: no direction)."""
    if len(normals) < 3:
        return np.zeros((2, 3))
    mean = normals.mean(axis=0)
    if np.linalg.norm(mean) < spread:  # normals all around: a wire
        return np.zeros((2, 3))
    far = normals[np.argmin(normals @ (mean / np.linalg.norm(mean)))]
    seeds = np.stack([normals[np.argmin(normals @ far)], far])
    for _ in range(5):
        label = np.argmax(normals @ seeds.T, axis=1)
        for k in range(2):
            if (label == k).any():
                m = normals[label == k].mean(axis=0)
                seeds[k] = m / max(np.linalg.norm(m), 1e-12)
    if seeds[0] @ seeds[1] > np.cos(np.radians(same_deg)):
        m = mean / np.linalg.norm(mean)
        return np.stack([m, m])
    # the smoothed hull blends the faces near the crease: take each group's quarter farthest from the other
    split = seeds[0] - seeds[1]
    along = normals @ split
    faces = []
    for k, sign in ((0, 1.0), (1, -1.0)):
        mine = along[label == k] * sign
        pure = normals[label == k][mine >= np.quantile(mine, 0.75)]
        m = pure.mean(axis=0)
        faces.append(m / max(np.linalg.norm(m), 1e-12))
    return np.stack(faces)


def curve_normals(controls: np.ndarray, grid: VoxelGrid, occupied: np.ndarray, cameras=None, depth=None,
                  margin: float = 0.0, radius_voxels: float = 3.5, grazing: float = FIT_GRAZING) -> np.ndarray:
    """Face normals ``(N, 2, 2, 3)`` of cubics ``(N, 4, 3)`` (start/end × face) from a carved hull.

    Without ``cameras``/``depth`` the hull normals near each probe are split in two groups (2-means). With
    them (the evidence's views and hull depth maps), the pair of nearby hull normals — or zeros, never
    hiding — that best reproduces the hull's own verdict on which training views see the probe is chosen
    (a missed visible view counts double: a missing line is worse than a back line). A face counts as facing
    a training view here only when turned away by less than ``grazing``, stricter than the exporters: the
    margin keeps a curve that the training views see visible from the views between them (held-out line F:
    chair 0.838 → 0.854, lamp 0.801 → 0.817, Lego 0.749 → 0.756).
    """
    out = np.zeros((len(controls), 2, 2, 3))
    if len(controls) == 0 or not occupied.any():
        return out
    smooth = ndimage.gaussian_filter(occupied.astype(np.float32), 1.0)
    surface = np.argwhere(occupied & ~ndimage.binary_erosion(occupied))
    g = np.stack([ndimage.sobel(smooth, axis=a) for a in range(3)], -1)[tuple(surface.T)]
    ok = np.linalg.norm(g, axis=1) > 1e-6
    surface, g = surface[ok], g[ok]
    outward = grid.to_world(-g / np.linalg.norm(g, axis=1, keepdims=True))
    tree = cKDTree(grid.centres(surface))
    probes = bezier_points(controls, np.array([1 / 6, 5 / 6])).reshape(-1, 3)  # (N·2, 3)
    near = tree.query_ball_point(probes, radius_voxels * grid.voxel)
    if cameras is None or depth is None:
        for k, idx in enumerate(near):
            out[k // 2, k % 2] = _two_faces(outward[idx])
        return out
    seen, to_eye = _visibility(probes, cameras, depth, margin)
    for k, idx in enumerate(near):
        out[k // 2, k % 2] = _best_pair(outward[idx], seen[k], to_eye[k], grazing)
    return out


def _visibility(points: np.ndarray, cameras, depth, margin: float) -> tuple[np.ndarray, np.ndarray]:
    """Per point and view: ``seen`` (1 visible, 0 hidden, −1 out of frame) and the unit direction to the eye."""
    from ..volume.carve import project_points

    seen = np.full((len(points), len(cameras)), -1, np.int8)
    to_eye = np.zeros((len(points), len(cameras), 3))
    for v, (cam, zb) in enumerate(zip(cameras, depth)):
        u, w, z = project_points(cam, points.astype(np.float32))
        ok = (z > 1e-6) & (u >= 0) & (w >= 0) & (u < cam.width) & (w < cam.height)
        seen[ok, v] = (z[ok] <= zb[w[ok], u[ok]] + margin).astype(np.int8)
        d = cam.center - points
        to_eye[:, v] = d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12)
    return seen, to_eye


def _best_pair(normals: np.ndarray, seen: np.ndarray, to_eye: np.ndarray, grazing: float,
               candidates: int = 12) -> np.ndarray:
    """The pair of candidate normals whose facing rule best predicts ``seen`` (see :func:`curve_normals`)."""
    use = seen >= 0
    if not use.any() or len(normals) == 0 or seen[use].all():
        return np.zeros((2, 3))  # seen from everywhere (a wire, an outer rim): never hide
    if len(normals) > candidates:  # a few representatives: farthest-point sampling on the sphere
        pick = [0]
        d = normals @ normals[0]
        for _ in range(candidates - 1):
            pick.append(int(np.argmin(d)))
            d = np.maximum(d, normals @ normals[pick[-1]])
        normals = normals[pick]
    cands = np.vstack([normals, np.zeros((1, 3))])
    facing = (to_eye[use] @ cands.T > -grazing) | (np.arange(len(cands)) == len(cands) - 1)  # (V, C)
    truth = seen[use].astype(bool)
    either = facing[:, :, None] | facing[:, None, :]  # (V, C, C)
    cost = (2.0 * (truth[:, None, None] & ~either) + (~truth[:, None, None] & either)).sum(axis=0)
    a, b = np.unravel_index(np.argmin(cost), cost.shape)
    return np.stack([cands[a], cands[b]])
