"""The visual hull, carved once per fit from the masks on a grid fitted to the object.

The hull is carved coarse to fine with the masks' signed distance transforms: a cell whose projection lies
wholly outside some mask is empty, wholly inside every mask full, and only the cells in between are split,
so the cost follows the hull's surface, not its volume. Everything else a fit takes from the object's volume
comes from this one carving (:mod:`doodle.fit.stages.volume`): the 3D edge evidence's grid, the coarse
occluder, the hull whose outline ``--outline hull`` draws, the thick part superquadrics may explain.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from ...cameras import Camera
from ...scenes import Scene
from ...scenes.scene import HULL_DISAGREE
from ...strokes.model import Voxels
from ...workers import cpu_count


@dataclass
class VoxelGrid:
    """A grid fitted to the object: voxel ``(i, j, k)`` has centre ``origin + (i, j, k) · voxel @ axes``.

    ``axes`` ``(3, 3)``: the grid's unit axes in world coordinates, one per row (the identity for a grid
    aligned with the world's axes).
    """

    origin: np.ndarray
    voxel: float
    shape: tuple[int, int, int]
    axes: np.ndarray = field(default_factory=lambda: np.eye(3))

    def centres(self, ijk: np.ndarray) -> np.ndarray:
        """World centres ``(P, 3)`` of voxel indices ``(P, 3)`` (fractional indices give points between)."""
        return self.origin + (ijk * self.voxel) @ self.axes

    def coordinates(self, points: np.ndarray) -> np.ndarray:
        """Fractional voxel indices ``(P, 3)`` of world points: the inverse of :meth:`centres`."""
        return ((points - self.origin) @ self.axes.T) / self.voxel

    def index(self, points: np.ndarray) -> np.ndarray:
        """Nearest voxel indices ``(P, 3)`` of world points (not clipped to the grid)."""
        return np.rint(self.coordinates(points)).astype(np.int64)

    def to_world(self, vectors: np.ndarray) -> np.ndarray:
        """Directions ``(..., 3)`` along the grid's axes → world directions."""
        return vectors @ self.axes

    def volume(self, occupied: np.ndarray) -> Voxels:
        """The stroke file's voxel volume of ``occupied`` ``bool`` (this grid's shape) on this grid (copied)."""
        return Voxels(self.origin.copy(), float(self.voxel), self.axes.copy(), np.array(occupied, bool))


def fit_axes(points: np.ndarray, up: np.ndarray, prefer_world: float = 0.9, steps: int = 36) -> np.ndarray:
    """Axes ``(3, 3)`` (rows) of a box around ``points`` ``(P, 3)`` that is small: one axis along ``up``, the
    other two turned about it to the angle giving the smallest box.

    An object posed by structure-from-motion lies at any angle to the world's axes, and a box aligned
    with them can hold half again its volume: the voxels, sized by the box, would be that much coarser. The
    world's axes are kept unless the turned box is smaller than ``prefer_world`` × theirs (objects
    modelled upright in a world frame keep their grid exactly).
    """
    def volume(axes: np.ndarray) -> float:
        q = points @ axes.T
        return float(np.prod(q.max(axis=0) - q.min(axis=0)))

    world = np.eye(3)
    up = np.asarray(up, dtype=np.float64) / np.linalg.norm(up)
    a = np.eye(3)[int(np.argmin(np.abs(up)))]
    e1 = np.cross(up, a)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(up, e1)
    best, best_volume = world, volume(world)
    for theta in np.linspace(0, 0.5 * np.pi, steps, endpoint=False):
        x = np.cos(theta) * e1 + np.sin(theta) * e2
        axes = np.stack([x, np.cross(up, x), up])
        v = volume(axes)
        if v < best_volume * (prefer_world if best is world else 1.0):
            best, best_volume = axes, v
    return best


def project_points(cam: Camera, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pixel indices ``(u, v)`` (floor) and depth of world points; float32 math, it is the hot loop."""
    R, t = cam.R.astype(np.float32), cam.t.astype(np.float32)
    pc = pts @ R.T
    # the translation added column by column: the same sums as ``pc + t``, whose broadcast over rows of 3
    # took half of this function's time (the edge vote's hot loop: 90 views × every candidate voxel on Lego)
    x, y, z = pc[:, 0] + t[0], pc[:, 1] + t[1], pc[:, 2] + t[2]
    zs = np.where(z > 1e-6, z, 1e-6)
    u = np.floor(x / zs * np.float32(cam.fx) + np.float32(cam.cx)).astype(np.int32)
    v = np.floor(y / zs * np.float32(cam.fy) + np.float32(cam.cy)).astype(np.int32)
    return u, v, z


#: The coarse pass's first cube: its half-side (scene radii) and cells along a side; how much a side grows (× that
#: half-side) where the object reaches it, and how many times at most.
FIRST_SIDE, FIRST_CELLS = 1.15, 48
GROW, GROW_TRIES = 0.25, 4


#: Points of one thread's share in :func:`_classify` at least (fewer are not worth a thread).
CLASSIFY_CHUNK = 1 << 15


def _classify(points: np.ndarray, half_diag: float, cameras: list[Camera], sdf: list[np.ndarray],
              min_seen: int, disagree: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Cells of centre ``points`` and half-diagonal ``half_diag``: ``(surely inside, possibly inside)``.

    A cell is surely empty when its projected disc lies outside the masks of more than ``disagree`` × the
    views that see it (``0``: of any), surely full when no more of them leave any of it out. Views that do
    not see the centre do not carve (a part out of frame is not absent).
    """
    pts = points.astype(np.float32)
    # the views' counts are sums over cameras, point by point: chunks of points in threads give the same counts
    # (numpy releases the GIL in the projection and lookups)
    chunk = max(CLASSIFY_CHUNK, -(-len(pts) // cpu_count()))
    starts = range(0, len(pts), chunk)
    if len(starts) > 1:
        with ThreadPoolExecutor(len(starts)) as pool:
            parts = list(pool.map(lambda a: _view_counts(pts[a:a + chunk], half_diag, cameras, sdf), starts))
        outside, unsure, seen = (np.concatenate(c) for c in zip(*parts))
    else:
        outside, unsure, seen = _view_counts(pts, half_diag, cameras, sdf)
    allowed = np.floor(disagree * seen)
    maybe = (outside <= allowed) & (seen >= min_seen)
    return maybe & (unsure <= allowed), maybe


def _view_counts(pts: np.ndarray, half_diag: float, cameras: list[Camera], sdf: list[np.ndarray]
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For cells of centre ``pts`` ``(n, 3)`` float32: how many views' masks miss each cell's disc, do not hold
    all of it, and see its centre (see :func:`_classify`)."""
    outside = np.zeros(len(pts), np.int32)  # views whose mask misses the cell's disc
    unsure = np.zeros(len(pts), np.int32)  # views whose mask does not hold all of it
    seen = np.zeros(len(pts), np.int32)
    for cam, sd in zip(cameras, sdf):
        u, v, z = project_points(cam, pts)
        ok = (z > 1e-6) & (u >= 0) & (v >= 0) & (u < cam.width) & (v < cam.height)
        rho = np.float32(max(cam.fx, cam.fy) * half_diag) / np.where(z > 1e-6, z, 1e-6) + 1.0
        d = np.zeros(len(pts), np.float32)
        d[ok] = sd[v[ok], u[ok]]
        outside += ok & (d <= -rho)
        unsure += ok & (d <= rho)
        seen += ok
    return outside, unsure, seen


def _first_pass(center: np.ndarray, r: float, up: np.ndarray, cameras: list[Camera], sdf: list[np.ndarray],
                min_seen: int, disagree: float) -> tuple[np.ndarray, np.ndarray, float]:
    """The coarse pass: cells of side ``2 r /`` :data:`FIRST_CELLS` over a box that starts as the cube of half-side
    ``r`` about ``center``; their centres ``(n, 3)``, whether each may hold the object, and the cell's side.

    A scene's frame is an estimate (SfM's: about the point the cameras aim at, which on DTU's skull is its face):
    where the object reaches a face of the box it goes on beyond it, and that side grows by :data:`GROW` × ``r``
    (at most :data:`GROW_TRIES` times) — else the hull is the object cut off there (the back of the skull's
    cranium, lost in every side view). Not the sides below (``up``): under an object that rests on something no
    view carves a wedge that reaches far down, and the object does not go on there."""
    n0 = FIRST_CELLS
    cell = 2 * r / n0
    lo, hi = center - r, center + r
    below_lo, below_hi = -up < -0.5, up < -0.5  # the axis directions that point down (a face's outward normal)
    for attempt in range(GROW_TRIES + 1):
        axes = [lo[a] + (np.arange(int(np.ceil((hi[a] - lo[a]) / cell - 1e-6))) + 0.5) * cell for a in range(3)]
        pts0 = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
        _, maybe0 = _classify(pts0, np.sqrt(3) * cell / 2, cameras, sdf, min_seen, disagree)
        box = maybe0.reshape([len(g) for g in axes])
        touch_lo = np.array([np.take(box, 0, axis=a).any() for a in range(3)]) & ~below_lo
        touch_hi = np.array([np.take(box, -1, axis=a).any() for a in range(3)]) & ~below_hi
        if attempt == GROW_TRIES or not (touch_lo.any() or touch_hi.any()):
            break
        lo = lo - touch_lo * GROW * r
        hi = hi + touch_hi * GROW * r
    return pts0, maybe0, cell


def carve_hull(scene: Scene, max_voxels: int = 192, slack_px: float = 1.0, min_seen_frac: float = 0.3,
               levels: int = 3, sdf: list[np.ndarray] | None = None, disagree: float | None = None
               ) -> tuple[VoxelGrid, np.ndarray]:
    """Visual hull on a grid fitted to the object: ``(grid, occupied bool (X, Y, Z))``.

    A coarse pass over the scene's frame (:func:`_first_pass`, grown where the object reaches past it) finds the
    object's box, turned about the scene's up to fit it
    (:func:`fit_axes`); the fine grid covers that box with
    ``max_voxels`` voxels along its longest side and is carved coarse to fine (``levels`` halvings).
    ``sdf``: the masks' signed distances (see :class:`ViewMaps`), when already computed. ``disagree``: the
    share of the views seeing a voxel whose masks may call it background without carving it; ``None``:
    :data:`HULL_DISAGREE` for automatic masks (``scene.masks_automatic``), 0 for given ones (exact: a tolerant
    hull would fill what few views see).
    """
    if scene.masks is None:
        raise ValueError("the scene has no masks")
    if disagree is None:
        disagree = HULL_DISAGREE if scene.masks_automatic else 0.0
    cams = scene.cameras
    if sdf is None:
        def signed(m: np.ndarray) -> np.ndarray:
            inside, outside = ndimage.distance_transform_edt(m), ndimage.distance_transform_edt(~m)
            return (np.where(m, inside, -outside) + slack_px).astype(np.float32)

        with ThreadPoolExecutor(cpu_count()) as pool:  # scipy's transforms release the GIL
            sdf = list(pool.map(signed, scene.masks))
    min_seen = max(2, int(min_seen_frac * len(cams)))
    f = scene.frame
    pts0, maybe0, cell0 = _first_pass(f.center, FIRST_SIDE * f.radius, f.up, cams, sdf, min_seen, disagree)
    if not maybe0.any():
        raise ValueError("the masks do not agree on any voxel (wrong poses or masks?)")
    axes = fit_axes(pts0[maybe0], f.up)
    q = pts0[maybe0] @ axes.T  # box in the grid's frame
    lo = q.min(axis=0) - cell0
    hi = q.max(axis=0) + cell0
    voxel = float((hi - lo).max()) / max_voxels
    step = 2 ** levels
    shape = tuple(int(np.ceil((hi[a] - lo[a]) / (voxel * step))) * step for a in range(3))
    grid = VoxelGrid((lo + 0.5 * voxel) @ axes, voxel, shape, axes)  # type: ignore[arg-type]
    occupied = np.zeros(shape, bool)
    # coarse-to-fine: cells of `step` voxels, split while undecided
    coarse = np.stack(np.meshgrid(*[np.arange(s // step) for s in shape], indexing="ij"), -1).reshape(-1, 3) * step
    size = step
    while True:
        centres = grid.centres(coarse + (size - 1) / 2)
        full, maybe = _classify(centres, np.sqrt(3) * size * voxel / 2 if size > 1 else 0.0, cams, sdf, min_seen,
                                disagree)
        for i, j, k in coarse[full]:
            occupied[i:i + size, j:j + size, k:k + size] = True
        if size == 1:
            break
        split = coarse[maybe & ~full]
        half = size // 2
        offsets = np.stack(np.meshgrid(*[[0, half]] * 3, indexing="ij"), -1).reshape(-1, 3)
        coarse = (split[:, None, :] + offsets[None]).reshape(-1, 3)
        size = half
    return grid, occupied


def coarsen(occupied: np.ndarray, max_voxels: int) -> tuple[np.ndarray, int]:
    """``occupied`` on a grid ``k`` times coarser (blocks at least half full), ``k`` the smallest factor that
    brings the longest side to ``max_voxels`` or fewer. Block ``(i, j, k)``'s centre is fine voxel
    ``k·(i, j, k) + (k − 1)/2``."""
    k = max(1, int(np.ceil(max(occupied.shape) / max_voxels)))
    if k == 1:
        return occupied.copy(), 1
    pad = [(0, (-s) % k) for s in occupied.shape]
    a = np.pad(occupied, pad).astype(np.float32)
    X, Y, Z = (s // k for s in a.shape)
    return a.reshape(X, k, Y, k, Z, k).mean(axis=(1, 3, 5)) >= 0.5, k


def coarsened(grid: VoxelGrid, occupied: np.ndarray, max_voxels: int) -> tuple[VoxelGrid, np.ndarray]:
    """The carving on a grid ``k`` times coarser (:func:`coarsen`) with at most ``max_voxels`` along its
    longest side: the occluder's, the thick part's and the gradient path's start points' grid."""
    occ, k = coarsen(occupied, max_voxels)
    return VoxelGrid(grid.centres(np.full(3, (k - 1) / 2)), grid.voxel * k, occ.shape, grid.axes), occ
