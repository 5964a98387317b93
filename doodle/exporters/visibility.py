"""Ray marching against the superquadric union: hidden-line tests and union silhouettes (masks).

A segment is blocked when a point strictly inside the union (``log f < 0``) lies on it. Per superquadric, only
segments that cross its bounding sphere and then its bounding box (``f ≤ 1`` implies ``|x_i| ≤ a_i``), and
miss a body it surely contains (an inscribed octahedron or ellipsoid: superquadrics with ε ≤ 2 are convex),
are sampled, and only inside the box, so cost scales with the rays that actually graze a surface.
"""

from __future__ import annotations

import numpy as np

from ..arrays import first_occupied, free_space
from ..cameras import Camera
from ..strokes.model import SuperquadricSet, Voxels
from ..strokes.superquadric import (bounding_radius, canonical, deformation_of, log_inside_outside,
                                    quaternion_to_matrix)


def _slab(o: np.ndarray, u: np.ndarray, half: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ray parameters ``(t_in, t_out)`` where rays ``o + t u`` (local frames, ``(..., 3)``) cross the boxes
    ``|x_i| ≤ half_i``; ``t_in > t_out`` when they miss."""
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / np.where(np.abs(u) > 1e-12, u, 1e-12)
        ta, tb = (-half - o) * inv, (half - o) * inv
    lo, hi = np.minimum(ta, tb), np.maximum(ta, tb)
    # Explicit per-axis max/min: numpy reductions over a length-3 last axis are several times slower.
    return (np.maximum(np.maximum(lo[..., 0], lo[..., 1]), lo[..., 2]),
            np.minimum(np.minimum(hi[..., 0], hi[..., 1]), hi[..., 2]))


def _inner_hit(o: np.ndarray, u: np.ndarray, L: np.ndarray, scale: np.ndarray, shape: np.ndarray) -> np.ndarray:
    """Segments ``o + t u``, ``0 ≤ t ≤ L`` (local frames, ``(K, 3)``) that surely enter their superquadric
    (``scale``, ``shape`` ``(K, ·)``) because they enter a body it contains: every ε ≤ 2 superquadric contains
    the octahedron ``Σ|x_i|/a_i ≤ 1``; with both ε ≤ 1 it also contains the ellipsoid ``Σ(x_i/a_i)² ≤ 1``."""
    o, u = o / scale, u / scale
    # Ellipsoid: the quadratic |o + t u|² − 1 at its minimum over [0, L].
    a, b, c = (u * u).sum(axis=1), (o * u).sum(axis=1), (o * o).sum(axis=1) - 1.0
    t = np.clip(-b / np.maximum(a, 1e-30), 0.0, L)
    ellipsoid = (shape.max(axis=1) <= 1.0) & (a * t * t + 2 * b * t + c < 0)
    # Octahedron: Σ|o_i + t u_i| is convex and piecewise linear in t; its minimum is at an end or a kink.
    with np.errstate(divide="ignore", invalid="ignore"):
        kinks = np.clip(-o / np.where(np.abs(u) > 1e-12, u, 1e-12), 0.0, L[:, None])
    t = np.concatenate([np.zeros((len(o), 1)), L[:, None], kinks], axis=1)  # (K, 5)
    x = np.abs(o[:, None, :] + t[..., None] * u[:, None, :])
    octahedron = (x[..., 0] + x[..., 1] + x[..., 2] < 1.0).any(axis=1)
    return ellipsoid | octahedron


def segments_blocked(origins: np.ndarray, ends: np.ndarray, sq: SuperquadricSet, samples: int = 32,
                     exclude: np.ndarray | None = None, chunk: int = 1 << 15) -> np.ndarray:
    """Whether each segment ``origins[k] → ends[k]`` ``(P, 3)`` passes through the union's interior, ``(P,)``.

    ``exclude`` ``(P,)`` names one superquadric per segment to ignore (−1: none): a silhouette point cannot be
    hidden by its own (convex) superquadric, whose surface its ray only grazes. All superquadrics are tested
    at once (segment–superquadric pairs); ``chunk`` segments at a time bound the memory.
    """
    P = len(origins)
    if len(sq) == 0 or P == 0:
        return np.zeros(P, bool)
    if P > chunk:
        return np.concatenate([
            segments_blocked(origins[k:k + chunk], ends[k:k + chunk], sq, samples,
                             None if exclude is None else exclude[k:k + chunk], chunk) for k in range(0, P, chunk)])
    d = ends - origins
    L = np.linalg.norm(d, axis=1)
    u = d / np.maximum(L, 1e-12)[:, None]
    # Bounding spheres first (radius |a| holds the box |x_i| ≤ a_i, which holds f ≤ 1), as (P, M) products:
    # the squared distance of each sphere's centre from each segment's line, and where along it.
    c = sq.translation
    radius2 = bounding_radius(sq) ** 2
    b = u @ c.T - (origins * u).sum(axis=1, keepdims=True)  # (P, M): t of the centre's foot point
    dist2 = (c ** 2).sum(axis=1) - 2 * origins @ c.T + (origins ** 2).sum(axis=1, keepdims=True) - b * b
    h = np.sqrt(np.maximum(radius2 - dist2, 0.0))
    candidate = (dist2 < radius2) & (b + h > 0) & (b - h < L[:, None])
    if exclude is not None:
        candidate &= exclude[:, None] != np.arange(len(sq))[None, :]
    p, j = np.nonzero(candidate)
    blocked = np.zeros(P, bool)
    deformation = deformation_of(sq)
    if deformation is not None:  # tapered or bent: sampled along the chord of the bounding sphere
        bent = sq.deformed[j]
        t0 = np.maximum((b - h)[p[bent], j[bent]], 0.0)
        t1 = np.minimum((b + h)[p[bent], j[bent]], L[p[bent]])
        blocked |= _deformed_blocked(origins, u, p[bent], j[bent], t0, t1, sq, deformation, samples, P)
        p, j = p[~bent], j[~bent]
    # Then the boxes themselves, in each superquadric's frame: only segments crossing a box can be blocked by
    # it, and only inside it.
    R = quaternion_to_matrix(sq.rotation)[j]  # (K, 3, 3) local → world
    o_loc = ((origins[p] - c[j])[:, None, :] @ R)[:, 0]  # row-vector form of Rᵀ(o − t)
    u_loc = (u[p][:, None, :] @ R)[:, 0]
    t0, t1 = _slab(o_loc, u_loc, sq.scale[j])
    t0, t1 = np.maximum(t0, 0.0), np.minimum(t1, L[p])
    near = t1 > t0
    p, j, o_loc, u_loc, t0, t1 = p[near], j[near], o_loc[near], u_loc[near], t0[near], t1[near]
    blocked[p[_inner_hit(o_loc, u_loc, L[p], sq.scale[j], sq.shape[j])]] = True
    todo = ~blocked[p]
    j, p, o_loc, u_loc, t0, t1 = j[todo], p[todo], o_loc[todo], u_loc[todo], t0[todo], t1[todo]
    if len(p):
        t = t0[:, None] + (t1 - t0)[:, None] * ((np.arange(samples) + 0.5) / samples)  # (K, S)
        local = o_loc[:, None, :] + t[..., None] * u_loc[:, None, :]
        lf = log_inside_outside(local, sq.scale[j], sq.shape[j])  # (K, S): pair k is "superquadric" k
        blocked[p[(lf < 0).any(axis=1)]] = True
    return blocked


def _deformed_blocked(origins: np.ndarray, u: np.ndarray, p: np.ndarray, j: np.ndarray, t0: np.ndarray,
                      t1: np.ndarray, sq: SuperquadricSet, deformation: tuple, samples: int, P: int) -> np.ndarray:
    """Segment–superquadric pairs ``(p, j)`` of tapered or bent superquadrics, sampled over ``[t0, t1]`` and
    tested in the canonical frame (no box or inscribed body: the deformation curves a ray there)."""
    out = np.zeros(P, bool)
    live = t1 > t0
    p, j, t0, t1 = p[live], j[live], t0[live], t1[live]
    if not len(p):
        return out
    t = t0[:, None] + (t1 - t0)[:, None] * ((np.arange(2 * samples) + 0.5) / (2 * samples))  # (K, S)
    world = origins[p][:, None, :] + t[..., None] * u[p][:, None, :]  # pair k's samples: "superquadric" k's
    x = canonical(world, sq.scale[j], sq.rotation[j], sq.translation[j], tuple(a[j] for a in deformation))
    out[p[(log_inside_outside(x, sq.scale[j], sq.shape[j]) < 0).any(axis=1)]] = True
    return out


def ray_origins(cameras: list[Camera], points: np.ndarray, view: np.ndarray) -> np.ndarray:
    """Where the camera ray through each world point ``(P, 3)``, seen from ``cameras[view[k]]``, starts: the
    camera centre (perspective) or the point's foot on the image plane (orthographic)."""
    centers = np.array([c.center for c in cameras]).reshape(-1, 3)[view]
    ortho = np.array([c.projection == "orthographic" for c in cameras])[view]
    if not ortho.any():
        return centers
    forward = np.array([c.forward for c in cameras]).reshape(-1, 3)[view]
    depth = ((points - centers) * forward).sum(axis=1, keepdims=True)
    return np.where(ortho[:, None], points - depth * forward, centers)


# samples per voxel width along a segment: 2 (every half voxel) never steps over a voxel it crosses
SAMPLES_PER_VOXEL = 2


def volume_blocked(origins: np.ndarray, ends: np.ndarray, volume: Voxels) -> np.ndarray:
    """Whether each segment ``origins[k] → ends[k]`` ``(P, 3)`` passes through an occupied voxel of
    ``volume``, ``(P,)``: sampled at most every half voxel where it crosses the grid's box, a sample blocking
    when its nearest voxel is occupied.

    The samples are visited in order, skipping through empty space (:func:`~doodle.arrays.first_occupied`): a
    camera ray to a point on the object crosses mostly empty space, so a few dozen lookups replace hundreds,
    with the same answer as testing every sample.
    """
    P = len(origins)
    out = np.zeros(P, bool)
    if P == 0 or not volume.occupied.any():
        return out
    shape = np.array(volume.occupied.shape, float)
    a, b = volume.coordinates(origins), volume.coordinates(ends)  # voxel centres at integers
    t_in, t_out = _slab(a - (shape - 1) / 2, b - a, (shape + 1) / 2)  # the segment is t ∈ [0, 1]
    t_in, t_out = np.clip(t_in, 0, 1), np.clip(t_out, 0, 1)
    length = np.linalg.norm(b - a, axis=1)
    ray = np.flatnonzero((t_out > t_in) & (length > 0))
    free = free_space(volume.occupied)
    start, step = a[ray] + t_in[ray, None] * (b - a)[ray], (t_out - t_in)[ray, None] * (b - a)[ray]
    n = np.ceil((t_out - t_in)[ray] * length[ray] * SAMPLES_PER_VOXEL).astype(np.intp) + 1  # samples 0 … n − 1
    step /= np.maximum(n - 1, 1)[:, None]
    reach = np.abs(step).max(axis=1)  # voxels moved along the steepest axis per sample
    out[ray] = first_occupied(free, lambda rows, j: start[rows] + j[:, None] * step[rows], reach, n) >= 0
    return out


#: Voxels of slack a point keeps against the occluder volume beyond ``margin``: the volume is the visual
#: hull on a coarse grid, a voxel or so wider than the object, and a wire inside it must not hide itself.
VOLUME_SLACK = 1.5


def occluded(points: np.ndarray, view: np.ndarray, cameras: list[Camera], sq: SuperquadricSet, margin: float,
             samples: int = 32, exclude: np.ndarray | None = None, volume: Voxels | None = None) -> np.ndarray:
    """Points ``(P, 3)`` hidden from ``cameras[view[k]]`` by the union, ``(P,)``: one query for many views.

    The march stops ``margin`` (scene units) short of each point, so points on or just under the union's
    surface — feature curves lying on the object the superquadrics only approximate — stay visible. With
    ``volume`` (the stroke set's occluder), a point is also hidden behind its occupied voxels, up to
    ``margin`` and :data:`VOLUME_SLACK` voxels short of it.
    """
    origins = ray_origins(cameras, points, view)
    d = points - origins
    L = np.linalg.norm(d, axis=1, keepdims=True)
    ends = origins + d * np.clip((L - margin) / np.maximum(L, 1e-12), 0, 1)
    hidden = segments_blocked(origins, ends, sq, samples, exclude)
    if volume is not None:
        stop = margin + VOLUME_SLACK * volume.voxel
        ends = origins + d * np.clip((L - stop) / np.maximum(L, 1e-12), 0, 1)
        hidden |= volume_blocked(origins, ends, volume)
    return hidden


def union_mask(sq: SuperquadricSet, camera: Camera, samples: int = 48, far: float | None = None) -> np.ndarray:
    """Boolean image ``(H, W)`` of the pixels whose ray meets the union (pixel centres)."""
    o, d = camera.rays()
    o, d = o.reshape(-1, 3), d.reshape(-1, 3)
    if far is None:
        reach = np.linalg.norm(sq.translation - camera.center, axis=1) + bounding_radius(sq)
        far = float(reach.max()) if len(sq) else 1.0
    return segments_blocked(o, o + far * d, sq, samples).reshape(camera.height, camera.width)
