"""Initial stroke placement: farthest-point sampling on SfM points or on a visual hull carved from masks."""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from ...scenes import Scene


def farthest_points(points: np.ndarray, k: int, rng: np.random.Generator) -> np.ndarray:
    """``k`` points spread out by farthest-point sampling (the first one random). ``(P, 3)`` → ``(k, 3)``."""
    if len(points) == 0:
        raise ValueError("no points to sample from")
    k = min(k, len(points))
    chosen = [int(rng.integers(len(points)))]
    d = np.linalg.norm(points - points[chosen[0]], axis=1)
    for _ in range(k - 1):
        i = int(np.argmax(d))
        chosen.append(i)
        d = np.minimum(d, np.linalg.norm(points - points[i], axis=1))
    return points[chosen]


def visual_hull(scene: Scene, resolution: int = 64, slack_px: int = 1) -> tuple[np.ndarray, np.ndarray, float]:
    """Voxels inside every mask (each mask grown by ``slack_px``), within the scene's bounding sphere.

    Returns:
        ``(interior centres (P, 3), surface centres (S, 3), voxel size)``. A view carves only the voxels it
        sees; voxels seen by fewer than 30 % of the views are dropped (nothing decides about them).
    """
    if scene.masks is None:
        raise ValueError("the scene has no masks")
    f = scene.frame
    r = f.radius * 1.3
    g = (np.arange(resolution) + 0.5) / resolution * 2 * r - r
    pts = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3) + f.center
    inside = np.linalg.norm(pts - f.center, axis=1) <= 1.15 * f.radius
    seen_by = np.zeros(len(pts), int)
    for cam, mask in zip(scene.cameras, scene.masks):
        grown = ndimage.binary_dilation(mask, iterations=slack_px) if slack_px else mask
        uv, z = cam.project(pts)
        u, v = np.floor(uv[:, 0]).astype(int), np.floor(uv[:, 1]).astype(int)
        seen = (z > 0) & (u >= 0) & (v >= 0) & (u < cam.width) & (v < cam.height)
        keep = np.ones(len(pts), bool)
        keep[seen] = grown[v[seen], u[seen]]
        inside &= keep
        seen_by += seen
    inside &= seen_by >= max(2, 0.3 * len(scene.cameras))
    vol = inside.reshape((resolution,) * 3)
    surface = vol & ~ndimage.binary_erosion(vol)
    return pts[inside], pts[surface.ravel()], 2 * r / resolution


def initial_points(scene: Scene, method: str, rng: np.random.Generator,
                   log=lambda msg: None) -> tuple[np.ndarray, np.ndarray, str]:
    """Sample locations for initial strokes: ``(surface-like points, interior points, method used)``.

    ``auto`` takes SfM points when the scene has at least 50, else the visual hull when it has masks, else
    points triangulated with the known poses, else random points in the bounding box. ``points`` on a scene
    without SfM points triangulates them (pycolmap, known poses).
    """
    from ...errors import SceneError
    from ...scenes.triangulate import triangulate_scene_points

    if method == "auto":
        if scene.points is not None and len(scene.points) >= 50:
            method = "points"
        elif scene.masks is not None:
            method = "hull"
        else:
            try:
                scene.points = triangulate_scene_points(scene, log=log)
                method = "points"
            except SceneError as exc:
                log(f"no SfM points ({exc}); falling back to the bounding box")
                method = "bbox"
    if method == "points":
        if scene.points is None or len(scene.points) == 0:
            scene.points = triangulate_scene_points(scene, log=log)
        d = np.linalg.norm(scene.points - scene.frame.center, axis=1)
        pts = scene.points[d <= 1.2 * scene.frame.radius]
        pts = pts if len(pts) >= 10 else scene.points
        return pts, pts, "points"
    if method == "hull":
        interior, surface, _ = visual_hull(scene)
        if len(interior) >= 10:
            return surface, interior, "hull"
        method = "bbox"  # the masks disagree (bad poses or masks): fall back
    r = scene.frame.radius * 0.7
    pts = scene.frame.center + rng.uniform(-r, r, (4000, 3))
    return pts, pts, "bbox"
