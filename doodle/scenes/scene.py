"""The typed result of every dataset parser: cameras, images, masks, points and the scene frame."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from PIL import Image

from ..cameras import Camera, azimuth_elevation, output_size
from ..strokes.model import DefaultCamera, SceneFrame

#: Largest coordinate a scene file may hold (scene units): far beyond any capture, near enough that squares
#: and SVDs stay finite.
MAX_COORD = 1e9


@dataclass
class Scene:
    """Posed images of one object.

    Images are ``uint8 (H, W, 3)`` composited over white; masks are ``bool (H, W)`` (``True`` = object) or
    absent; points are SfM points ``(P, 3)`` or absent. All geometry is in the input's world coordinates.
    ``masks_automatic``: the masks were made from the photos (:mod:`doodle.scenes.automask`), so each boundary
    may be a pixel or two off, differently in each view; given masks (alpha, a folder) are taken as exact.
    """

    cameras: list[Camera]
    images: list[np.ndarray]
    frame: SceneFrame
    masks: list[np.ndarray] | None = None
    points: np.ndarray | None = None
    source: str = ""
    image_paths: list[Path] = field(default_factory=list)
    masks_automatic: bool = False
    point_views: list[np.ndarray] | None = None
    """Optional, per point: the indices of the views that observed it (SfM tracks); a point is surely visible
    in those views. ``None`` when the points came without tracks."""
    lens: list[Callable[[np.ndarray], np.ndarray] | None] | None = None
    """Optional, per view: maps a mask drawn on the photo (resized to the view's size) into the view's pinhole
    geometry, for photos taken through a distorting lens and undistorted on loading; ``None`` (for all views or
    one) when the photo's geometry is the view's."""

    def __len__(self) -> int:
        return len(self.cameras)

    def subset(self, indices: list[int] | np.ndarray) -> "Scene":
        """The scene restricted to the given views."""
        idx = [int(i) for i in indices]
        views = None
        if self.point_views is not None:
            new_index = np.full(len(self), -1)
            new_index[idx] = np.arange(len(idx))
            views = [new_index[v][new_index[v] >= 0] for v in self.point_views]
        return Scene(
            [self.cameras[i] for i in idx], [self.images[i] for i in idx], self.frame,
            [self.masks[i] for i in idx] if self.masks is not None else None, self.points, self.source,
            [self.image_paths[i] for i in idx] if self.image_paths else [], self.masks_automatic, views,
            [self.lens[i] for i in idx] if self.lens is not None else None,
        )


def working_scene(scene: Scene, size: int) -> Scene:
    """The scene with images, masks and cameras resized so the larger side is ``size`` pixels (never enlarged)."""
    out_images, out_masks, out_cams = [], [], []
    for k, (cam, img) in enumerate(zip(scene.cameras, scene.images)):
        factor = min(1.0, size / max(cam.width, cam.height))
        c = cam.scaled(factor) if factor < 1 else cam
        if (c.width, c.height) != (img.shape[1], img.shape[0]):
            img = np.asarray(Image.fromarray(img).resize((c.width, c.height), Image.Resampling.BOX))
        out_images.append(img)
        out_cams.append(c)
        if scene.masks is not None:
            m = scene.masks[k]
            if m.shape != (c.height, c.width):
                m = np.asarray(Image.fromarray(m.astype(np.uint8) * 255).resize((c.width, c.height), Image.Resampling.BOX)) > 127
            out_masks.append(m)
    return Scene(out_cams, out_images, scene.frame, out_masks if scene.masks is not None else None, scene.points,
                 scene.source, scene.image_paths, scene.masks_automatic, scene.point_views, scene.lens)


def closest_point_to_axes(cameras: list[Camera]) -> np.ndarray:
    """Least-squares point nearest to all optical axes (the point the cameras look at)."""
    A = np.zeros((3, 3))
    b = np.zeros(3)
    for cam in cameras:
        d = cam.forward
        P = np.eye(3) - np.outer(d, d)
        A += P
        b += P @ cam.center
    if np.linalg.matrix_rank(A) < 3:  # all axes parallel: fall back to the mean position ahead of the cameras
        return np.mean([c.center + c.forward for c in cameras], axis=0)
    return np.linalg.solve(A, b)


def camera_up(cameras: list[Camera]) -> np.ndarray:
    """The world's up as the photographer held the camera.

    Photographers keep the horizon level, so each camera's image-right axis is horizontal, and up is the
    direction most nearly perpendicular to all of them (the least eigenvector of ``Σ r rᵀ``), on the side of
    the image-up axes. Averaging the image-up axes instead leans towards the side most photos were taken
    from (27° on 46 SfM-posed Lego photos). Each camera contributes the image axes nearest the consensus, so
    that photos taken in portrait (rolled by 90°) or upside down agree with the landscape ones. When the
    right axes all agree (cameras that only pan sideways), they do not fix up, and the mean image-up is
    used within the plane they leave free.
    """
    axes = np.stack([np.stack([-c.R[1], c.R[1], c.R[0], -c.R[0]]) for c in cameras])  # (N, 4, 3)
    up = axes[:, 0].mean(axis=0)
    for _ in range(3):
        if np.linalg.norm(up) < 1e-6:
            return np.array([0.0, 0.0, 1.0])
        pick = np.argmax(axes @ up, axis=1)
        up = axes[np.arange(len(cameras)), pick].mean(axis=0)
    right = np.cross(np.stack([c.R[2] for c in cameras]), axes[np.arange(len(cameras)), pick])  # (N, 3)
    values, vectors = np.linalg.eigh(right.T @ right)  # ascending
    if values[1] > 0.05 * values[2]:  # the right axes span a plane: its normal is up
        level = vectors[:, 0] * np.sign(vectors[:, 0] @ up or 1.0)
    else:  # they (nearly) share one direction: keep the mean up, without its share along that direction
        level = up - (up @ vectors[:, 2]) * vectors[:, 2]
    if np.linalg.norm(level) < 1e-6:
        return up / max(np.linalg.norm(up), 1e-12)
    return level / np.linalg.norm(level)


def estimate_frame(cameras: list[Camera], up: np.ndarray | None = None, points: np.ndarray | None = None,
                   full_size: tuple[float, float] | None = None,
                   sphere: tuple[np.ndarray, float] | None = None) -> SceneFrame:
    """Scene frame from camera poses: ``up`` is :func:`camera_up` unless given; ``center`` is the point
    nearest all optical axes; ``radius`` the largest sphere around it that every camera sees whole (its
    median), shrunk to the 98th percentile of point distances when SfM points are given. A layout that
    says where the object is (``sphere``: center and radius of a sphere holding it) centres the frame there,
    the radius capped by that sphere's.
    The default orbit camera takes the median distance, field of view and elevation, and view 0 the first
    camera's azimuth; its image size is the first photo's ``full_size`` (before any downscaling; default: the
    first camera's) with the long side capped at 1024 px.
    """
    if not cameras:
        raise ValueError("no cameras")
    if up is None:
        up = camera_up(cameras)
    up = np.asarray(up, dtype=np.float64) / np.linalg.norm(up)
    center = closest_point_to_axes(cameras) if sphere is None else np.asarray(sphere[0], dtype=np.float64)
    dists = np.array([np.linalg.norm(c.center - center) for c in cameras])
    half_fov = np.array([math.atan(0.5 * min(c.width / c.fx, c.height / c.fy)) for c in cameras])
    radius = float(np.median(dists * np.sin(half_fov)))
    if points is not None and len(points) >= 10:
        radius = min(radius, float(np.percentile(np.linalg.norm(points - center, axis=1), 98)))
    if sphere is not None:
        radius = min(radius, float(sphere[1]))
    frame = SceneFrame(up=up, center=center, radius=radius)
    angles = [azimuth_elevation(c.center, frame) for c in cameras]
    c0 = cameras[0]
    out_w, out_h = output_size(*(full_size or (c0.width, c0.height)))
    frame.camera = DefaultCamera(
        fov_deg=float(np.median([c.fov_deg for c in cameras])),
        distance=float(np.median(dists)),
        elevation_deg=float(np.clip(np.median([a[1] for a in angles]), -80, 80)),
        width=out_w, height=out_h, azimuth_deg=float(angles[0][0]),
    )
    return frame


def dominant_plane(points: np.ndarray, radius: float, iterations: int = 400, min_share: float = 0.2,
                   seed: int = 0) -> tuple[np.ndarray, float, np.ndarray] | None:
    """The plane holding most points within ``1 %`` of ``radius`` (RANSAC): ``(unit normal, offset, inliers)``
    with ``normal · p = offset`` on it, or ``None`` when no plane holds ``min_share`` of the points."""
    if len(points) < 30:
        return None
    rng = np.random.default_rng(seed)
    tol = 0.01 * radius
    best, best_n, best_d = None, 0, 0.0
    for _ in range(iterations):
        a, b, c = points[rng.choice(len(points), 3, replace=False)]
        n = np.cross(b - a, c - a)
        if np.linalg.norm(n) < 1e-12:
            continue
        n /= np.linalg.norm(n)
        count = int((np.abs(points @ n - a @ n) < tol).sum())
        if count > best_n:
            best, best_n, best_d = n, count, float(a @ n)
    if best is None or best_n < min_share * len(points):
        return None
    return best, best_d, np.abs(points @ best - best_d) < tol


HULL_DISAGREE = 0.03
"""With automatic masks, the share of the views seeing a voxel whose masks may call it background without
carving it from a hull (``doodle.fit.discovery.evidence.carve_hull``: the evidence's, the occluder, the thick volume). Their boundaries
are a pixel or two off, differently in each photo, and one mask a pixel too tight carves a strict hull there
for every view: it comes out thinner than the object, the contour points lifted onto it fall inside the other
views' outlines, and the outline's votes land beside the hull's surface. 3 % (none under 34 views) is what
:mod:`.automask`'s own hull allows (its ``AGREE`` is ``1 - HULL_DISAGREE``). Given masks keep the strict hull: on them a tolerant one fills what
only a few views see (Lego's held-out recall 0.809 → 0.774)."""
