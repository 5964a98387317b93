"""Where the object is in 3D, from what an object-centric capture guarantees.

- **Fixation.** Photos of one object are aimed at it: the point nearest all optical axes is on it or near it.
- **Support.** It stands on something (a table, a floor, a carpet): the dominant plane among the 3D points that
  every camera looks down on, and that reaches beyond the object, found by RANSAC. Its points, and what lies
  beyond it, are background.
- **One object.** The object's points are the cluster of points above the support that holds the fixation
  point (or lies nearest it): points in other clusters (a shelf behind, a chance match floating alone) are
  background too.

The object points seed every view's cut as object and the background points as background
(:mod:`.cut`); the plane also bounds the hull carved from the views' masks (:mod:`.hull`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from ...cameras import Camera, project_points
from ...errors import SceneError
from ..scene import Scene, closest_point_to_axes

PLANE_TOL = 0.01
"""Points within this share of the scene radius of the support plane lie on it."""
LOCAL_REACH = 0.5
"""When no support is found among triples drawn anywhere, more are drawn (:data:`FALLBACK_DRAWS` times as many),
and as many within this share of the scene radius of one another (:func:`_local_triples`)."""
FALLBACK_DRAWS = 10
FALLBACK_POINTS = 4000
"""The fallback's planes are ranked on at most this many of the points (30,000 points and no support: 1.0 s,
5.2 s ranked on all), then counted on all."""
PLANE_CANDIDATES = 5
"""Planes tried as the support, most points first: the skull's base, under its table's, is no support."""


@dataclass
class ObjectRegion:
    """The object in 3D: its points, the points that are surely not it, the fixation point and the support."""

    focus: np.ndarray
    object_points: np.ndarray
    background_points: np.ndarray
    plane: tuple[np.ndarray, float] | None
    """``(unit normal towards the cameras, offset)``: ``normal · p = offset`` on the support; ``None`` when
    there is none (an object held up, or photographed on a plain backdrop that gave no points)."""
    radius: float
    """The scene radius: the largest sphere about the focus that every camera sees whole (its median)."""
    background_views: list[np.ndarray] | None = None
    """Per background point, the views that observed it (SfM tracks; ``None``: unknown): a point of the floor
    behind the object projects onto the object in the views that do not see it."""

    def height(self, points: np.ndarray) -> np.ndarray:
        """Signed distance of ``points`` above the support (``+inf`` without one)."""
        if self.plane is None:
            return np.full(len(points), np.inf)
        n, d = self.plane
        return points @ n - d


def reaches_border(points: np.ndarray, cameras: list[Camera], band: float = 0.03) -> float:
    """Share of the views in which some of ``points`` ``(P, 3)`` land within ``band`` (of the image's width or
    height) of the frame's edge: a table or floor continues out of the photos, an object is framed by them."""
    reach = []
    for cam in cameras:
        uv, ok = in_view(cam, points)
        size = np.array([cam.width, cam.height], float)
        uv = uv[ok]
        reach.append(bool(((uv < band * size) | (uv > (1 - band) * size)).any()))
    return float(np.mean(reach)) if reach else 0.0


def in_view(cam: Camera, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pixel positions ``(P, 2)`` of world points and whether each lands in the frame in front of the camera
    (in the points' precision: a carving's million float32 voxels project at twice float64's speed)."""
    with np.errstate(divide="ignore", invalid="ignore"):  # points at the eye's depth are not in view anyway
        uv, z = project_points(pts, cam.R, cam.t, cam.K, cam.projection == "orthographic")
    ok = (z > 1e-9) & (uv[:, 0] >= 0) & (uv[:, 1] >= 0) & (uv[:, 0] < cam.width) & (uv[:, 1] < cam.height)
    return uv, ok


def support_plane(points: np.ndarray, cameras: list[Camera], focus: np.ndarray, radius: float,
                  everything: np.ndarray | None = None, iterations: int = 2000, seed: int = 0
                  ) -> tuple[np.ndarray, float] | None:
    """The plane the object stands on: ``(unit normal towards the cameras, offset)``, or ``None``.

    RANSAC over ``points``: a hypothesis counts when at least 90 % of the cameras and the fixation point ``focus``
    lie above it and at most 5 % of the points lie below it (a floor has nothing under it; a plane through the
    object has half of it below); the ones with most points within :data:`PLANE_TOL` of ``radius`` are tried in turn
    (:data:`PLANE_CANDIDATES`), each while at least 20 points and 3 % of them lie on it (a plain paper or table
    gives few features: the object may give many more). It is the support, not the object's own base, when its
    points spread beyond the points above it and continue out of the photos (among ``everything``, when given, they
    come within 3 % of the frame's edge in half the views): a base plate twice as wide as the object on it and
    framed by every photo (Lego's) is part of the object.
    """
    if len(points) < 30:
        return None
    rng = np.random.default_rng(seed)
    tol = PLANE_TOL * radius
    eyes = np.array([c.center for c in cameras])
    least = max(20, 0.03 * len(points))

    for fallback in (False, True):
        if not fallback:
            tri, sample = points[rng.integers(0, len(points), (iterations, 3))], points
        else:
            # none of those planes is the support: it may have given few of the points (all three of a triple on
            # it once in share⁻³ draws): FALLBACK_DRAWS times as many triples, and as many of neighbours, ranked
            # on a sample of the points
            sample = points[rng.choice(len(points), min(len(points), FALLBACK_POINTS), replace=False)]
            tri = np.concatenate([sample[rng.integers(0, len(sample), (FALLBACK_DRAWS * iterations, 3))],
                                  _local_triples(sample, LOCAL_REACH * radius, iterations, rng)])
        for n, d, count in _planes(tri, sample, eyes, focus, tol):
            if sample is not points:  # ranked on the sample: counted on all
                count = int((np.abs(points @ n - d) < tol).sum())
            if count < least:
                continue
            found = _as_support(n, d, points, cameras, tol, everything)
            if found is not None:
                return found
    return None


def _as_support(n: np.ndarray, d: float, points: np.ndarray, cameras: list[Camera], tol: float,
                everything: np.ndarray | None) -> tuple[np.ndarray, float] | None:
    """The plane ``n · p = d`` refitted to the ``points`` on it, when it is the support (see
    :func:`support_plane`), else ``None``."""
    on = np.abs(points @ n - d) < tol
    centroid = points[on].mean(axis=0)  # refit on its inliers (least squares), kept facing the cameras
    normal = np.linalg.svd(points[on] - centroid)[2][-1]
    n, d = (normal, float(normal @ centroid)) if normal @ n > 0 else (-normal, float(-normal @ centroid))
    above = (points @ n - d) > 3 * tol
    if above.sum() < 10:
        return n, d  # nothing stands on it but what the photos are of: a plain support seen all round
    # Medians: a smooth object gives a few points, and a few chance matches of the carpet just above the plane
    # among them spread them as wide as the floor (the carpet cow's 8 points and 4 such: 1.23 against the
    # floor's 1.44 at the 90th percentile, 0.52 against 0.96 at the median)
    centre = np.median(points[above], axis=0)

    def spread(p: np.ndarray) -> float:
        flat = (p - centre) - np.outer((p - centre) @ n, n)
        return float(np.median(np.linalg.norm(flat, axis=1)))

    if spread(points[np.abs(points @ n - d) < tol]) < 1.3 * spread(points[above]):
        return None  # within the object's footprint: a base, part of the object
    pool = points if everything is None else everything
    if reaches_border(pool[np.abs(pool @ n - d) < tol], cameras) < 0.5:
        return None  # framed by the photos like the object: a base plate, not the table
    return n, d


def _planes(tri: np.ndarray, points: np.ndarray, eyes: np.ndarray, focus: np.ndarray, tol: float,
            most: int = PLANE_CANDIDATES) -> list[tuple[np.ndarray, float, int]]:
    """Up to ``most`` distinct planes through the triples ``tri`` ``(T, 3, 3)``, each facing the cameras
    (``eyes``) and passing :func:`support_plane`'s tests, as ``(normal, offset, points within tol)``, most
    points first. Two are one when their normals are within 5° and their offsets within ``3 tol``."""
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(normals, axis=1)
    ok = length > 1e-12
    normals, tri = normals[ok] / length[ok, None], tri[ok]
    offsets = np.einsum("ij,ij->i", normals, tri[:, 0])
    flip = ((eyes @ normals.T - offsets) > 0).mean(axis=0) < 0.5  # orient each towards the cameras
    normals[flip], offsets[flip] = -normals[flip], -offsets[flip]
    counts = np.zeros(len(normals), int)
    for start in range(0, len(normals), 256):  # hypotheses in batches: (batch, points) heights
        n, d = normals[start:start + 256], offsets[start:start + 256]
        h = points @ n.T - d
        valid = (((eyes @ n.T - d) > 0).mean(axis=0) >= 0.9) & ((h < -3 * tol).mean(axis=0) <= 0.05) \
            & (focus @ n.T - d > -tol)
        counts[start:start + 256] = np.where(valid, (np.abs(h) < tol).sum(axis=0), 0)
    out: list[tuple[np.ndarray, float, int]] = []
    for k in np.argsort(-counts, kind="stable"):
        if counts[k] == 0 or len(out) == most:
            break
        if not any(normals[k] @ n > np.cos(np.radians(5)) and abs(offsets[k] - d) < 3 * tol for n, d, _ in out):
            out.append((normals[k], float(offsets[k]), int(counts[k])))
    return out


def _local_triples(points: np.ndarray, reach: float, n: int, rng: np.random.Generator) -> np.ndarray:
    """``(≤ n, 3, 3)`` triples of ``points``: a random one and two random others within ``reach`` of it. A support
    seen around a small object gives few of the points (DTU's skull on its table, triangulated with the known
    poses: 47 of 756), and three taken anywhere are all on it once in 2,000 draws; taken near one another, often
    (each one on the table has its neighbours on it)."""
    first = rng.integers(0, len(points), n)
    out = []
    for i, near in zip(first, cKDTree(points).query_ball_point(points[first], reach)):
        others = [j for j in near if j != i]
        if len(others) >= 2:
            out.append(points[[i, *rng.choice(others, 2, replace=False)]])
    return np.array(out).reshape(-1, 3, 3)


def _clusters(points: np.ndarray) -> np.ndarray:
    """Labels ``(P,)`` of the single-linkage clusters of ``points``: two points join when they are closer than
    three times the typical distance to a point's fourth neighbour."""
    tree = cKDTree(points)
    k = min(5, len(points))
    gap = float(np.median(tree.query(points, k=k)[0][:, -1])) if k > 1 else 0.0
    pairs = tree.query_pairs(max(3.0 * gap, 1e-12), output_type="ndarray")
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(points), len(points)))
    return connected_components(graph, directed=False)[1]


def _fixation_seeds(focus: np.ndarray, radius: float) -> np.ndarray:
    """A few points about the fixation point (2 % of the radius apart): they seed the object where the cameras
    aim, for an object that gave few points of its own (a smooth toy on a busy carpet)."""
    return focus + 0.02 * radius * np.vstack([np.zeros(3), np.eye(3), -np.eye(3)])


def object_region(scene: Scene) -> ObjectRegion:
    """The object's region in ``scene`` (see the module doc), from its points when it has any (without, the
    fixation point alone seeds the object).

    Raises:
        SceneError: when the cameras' focus is not above the support they look down on.
    """
    cams = scene.cameras
    focus = closest_point_to_axes(cams)
    radius = scene.frame.radius
    pts = scene.points if scene.points is not None else np.zeros((0, 3))
    near = np.linalg.norm(pts - focus, axis=1) < 1.5 * radius
    plane = support_plane(pts[near], cams, focus, radius, everything=pts) if near.sum() >= 30 else None
    height = pts @ plane[0] - plane[1] if plane is not None else np.full(len(pts), np.inf)
    candidate = near & (height > 3 * PLANE_TOL * radius)
    keep = np.zeros(len(pts), bool)
    if candidate.sum() >= 10:
        idx = np.flatnonzero(candidate)
        labels = _clusters(pts[idx])
        # The object's cluster: the one holding the point nearest the focus, or the largest within reach of it
        sizes = np.bincount(labels)
        dist = np.linalg.norm(pts[idx] - focus, axis=1)
        reach = np.array([dist[labels == k].min() for k in range(len(sizes))])
        mine = labels[np.argmin(dist)]
        if sizes[mine] < 10:
            within = np.flatnonzero(reach < 0.5 * radius)
            mine = within[np.argmax(sizes[within])] if len(within) else int(np.argmax(sizes))
        keep[idx[labels == mine]] = True
        # and the clusters that are part of it seen apart (a handle, a cable): those within its own reach
        centre = pts[keep].mean(axis=0)
        extent = float(np.percentile(np.linalg.norm(pts[keep] - centre, axis=1), 95))
        for k in range(len(sizes)):
            members = idx[labels == k]
            if k != mine and sizes[k] >= 10 and np.linalg.norm(pts[members].mean(axis=0) - centre) < 1.2 * extent:
                keep[members] = True
    if plane is not None and focus @ plane[0] - plane[1] <= PLANE_TOL * radius:
        raise SceneError(f"{scene.source}: the cameras do not aim at anything above the support they look down "
                         "on; give masks with --masks DIR (white = object)")
    # The object is where the cameras aim: seeded there too (a smooth object may give few points of its own)
    obj = np.vstack([pts[keep], _fixation_seeds(focus, radius)])
    centre = obj.mean(axis=0)
    extent = max(float(np.percentile(np.linalg.norm(obj - centre, axis=1), 95)), 0.5 * radius)
    # Background is only what surely is not the object: the support and what lies beyond it, and what stands
    # well apart from the object. A lone point beside it (a chance match, or a point on a smooth part too
    # sparse to join the cluster) seeds nothing either way.
    far = np.linalg.norm(pts - centre, axis=1) > 2.0 * extent
    background = ~keep & (far | (height <= PLANE_TOL * radius))
    views = None if scene.point_views is None or not len(pts) else \
        [scene.point_views[i] for i in np.flatnonzero(background)]
    return ObjectRegion(focus, obj, pts[background], plane, radius, views)
