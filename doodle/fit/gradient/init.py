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


def hull_points(grid, occupied: np.ndarray, max_voxels: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """``(interior (P, 3), surface (S, 3))`` voxel centres of a carved hull (``occupied`` on ``grid``, see
    :mod:`doodle.fit.volume.carve`) brought to at most ``max_voxels`` a side: where the gradient path's curves
    and superquadrics start."""
    from ..volume.carve import coarsened

    g, occ = coarsened(grid, occupied, max_voxels)
    surface = occ & ~ndimage.binary_erosion(occ)
    return g.centres(np.argwhere(occ)), g.centres(np.argwhere(surface))


def initial_points(scene: Scene, method: str, rng: np.random.Generator, log=lambda msg: None,
                   carving: tuple | None = None) -> tuple[np.ndarray, np.ndarray, str]:
    """Sample locations for initial strokes: ``(surface-like points, interior points, method used)``.

    ``auto`` takes SfM points when the scene has at least 50, else the visual hull (``carving``, the fit's
    ``(grid, occupied)``) when there is one, else points triangulated with the known poses, else random
    points in the bounding box. ``points`` on a scene without SfM points triangulates them (pycolmap, known
    poses).
    """
    from ...errors import SceneError
    from ...scenes.triangulate import triangulate_scene_points

    if method == "auto":
        if scene.points is not None and len(scene.points) >= 50:
            method = "points"
        elif carving is not None:
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
    if method == "hull" and carving is not None:
        interior, surface = hull_points(*carving)
        if len(interior) >= 10:
            return surface, interior, "hull"
        method = "bbox"  # the masks disagree (bad poses or masks): fall back
    r = scene.frame.radius * 0.7
    pts = scene.frame.center + rng.uniform(-r, r, (4000, 3))
    return pts, pts, "bbox"
