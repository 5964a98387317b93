"""3D edge evidence by direct multi-view voting: where in space do the images' lines agree?

A point on a 3D feature line projects onto an image line in (nearly) every view that sees it; a point on a
smooth face, or off the object, does so only by coincidence. So every voxel near the visual hull's surface
gets the mean, over the views that see it, of how close its projection falls to that view's nearest line:

    score(p) = Σ_v vis_v(p) · exp(−d_v(π_v(p))² / 2σ²) / (Σ_v vis_v(p) + 1)

with ``d_v`` the distance transform of view ``v``'s line map (px), ``σ`` about one pixel, and ``vis_v(p)``
whether the carved hull leaves ``p`` in sight (its depth is at most the hull's depth at that pixel plus a
small margin). The ``+ 1`` damps voxels that only a view or two see. This is what NEF learns with a neural
edge field over hours; here it is one pass over the voxels, seconds on a CPU, no weights.

The hull comes from :mod:`doodle.fit.volume.carve` (carved once per fit).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from skimage import feature

from ...arrays import ink_box, silhouette_boundary
from ...cameras import Camera
from ...scenes import Scene
from ..volume.carve import VoxelGrid, carve_hull, project_points


@dataclass
class Evidence:
    """The voting result on a grid around the visual hull.

    ``score`` is the vote (0 where nothing was voted), ``occupied`` the carved hull, ``seen`` the number of
    views that see each candidate voxel, ``lines`` the per-view line maps and ``depth`` the hull's per-view
    depth maps (``inf`` where the hull is not), both at the evidence image size. ``free``: the hull voxels
    the views see through (:mod:`.sightlines`; ``None`` until judged), which ``depth`` then leaves out.
    """

    grid: VoxelGrid
    score: np.ndarray
    occupied: np.ndarray
    seen: np.ndarray
    cameras: list[Camera]
    lines: list[np.ndarray]
    depth: list[np.ndarray]
    margin: float
    free: np.ndarray | None = None


def thin_parts(mask: np.ndarray, thin: float = 0.06, inside: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(axes, region)`` of the mask's parts narrower than ``thin`` × its box diagonal: the region (what an
    opening with a disc of that width removes, computed with distance transforms; ``inside`` is the mask's
    own distance transform when already at hand) and its skeleton."""
    from skimage.morphology import skeletonize

    ys, xs = np.nonzero(mask)
    if len(ys) == 0:
        return np.zeros_like(mask), np.zeros_like(mask)
    diag = float(np.hypot(ys.max() - ys.min() + 1, xs.max() - xs.min() + 1))
    r = int(round(0.5 * thin * diag))
    if r < 1:
        return np.zeros_like(mask), np.zeros_like(mask)
    core = (ndimage.distance_transform_edt(mask) if inside is None else inside) > r
    opened = ndimage.distance_transform_edt(~core) <= r + 1 if core.any() else core
    region = mask & ~opened
    region = ndimage.binary_opening(region)  # no single-pixel slivers along thick parts' borders
    return (skeletonize(region) if region.any() else region), region


def _gradients(image: np.ndarray, sigma: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Grey image in [0, 1] and the Sobel gradients ``(gx, gy)`` of its Gaussian-smoothed version."""
    gray = image.astype(np.float32).mean(axis=2) / 255.0
    smooth = ndimage.gaussian_filter(gray, sigma)
    return gray, ndimage.sobel(smooth, 1), ndimage.sobel(smooth, 0)


AXIS_MAX_WIDTH = 0.02
"""A thin part's axis is a line of the evidence only where the part is at most this share of the image's larger
side wide in the median along it (5 px at 256): there one stroke draws both rims within the lines' tolerance. A
wider part (a chair's leg, a lamp's pole at 10 px) is drawn by its rims, as a person draws it; its axis was a
line down its middle (the chair's held-out precision 0.806 with it, 0.855 without)."""


def _lines(gray, gx, gy, mask, inside, sigma, low, high, density, thin, frame) -> np.ndarray:
    hi = high
    if mask is not None and density < 1:
        core = ndimage.binary_erosion(mask, iterations=2)
        if core.sum() > 100:
            hi = max(high, float(np.quantile(np.hypot(gx, gy)[core], 1.0 - density)))
    edges = feature.canny(gray, sigma=sigma, low_threshold=max(low, 0.5 * hi), high_threshold=hi)
    if mask is None:
        return edges
    boundary = silhouette_boundary(mask)
    lines = boundary | (edges & ndimage.binary_dilation(mask, iterations=2))
    if thin > 0:
        lines |= narrow_axes(mask, thin, inside, AXIS_MAX_WIDTH * frame)
    return lines


def narrow_axes(mask: np.ndarray, thin: float, inside: np.ndarray | None, max_width: float) -> np.ndarray:
    """The axes of ``mask``'s thin parts (:func:`thin_parts`) whose median width along the axis is at most
    ``max_width`` px. Judged part by part (each connected piece of the thin region), not pixel by pixel: a pole
    whose width wavers about the limit keeps its whole axis or none of it, never pieces."""
    inside = ndimage.distance_transform_edt(mask) if inside is None else inside  # thin_parts reads it too
    axes, region = thin_parts(mask, thin, inside)
    if not axes.any():
        return axes
    width = 2 * inside
    labels, n = ndimage.label(region, np.ones((3, 3), bool))
    on = axes & (labels > 0)
    median = np.asarray(ndimage.median(width[on], labels[on], np.arange(1, n + 1)))
    keep = np.concatenate([[False], median <= max_width])
    return on & keep[labels]


def object_lines(image: np.ndarray, mask: np.ndarray | None, sigma: float = 1.5, low: float = 0.04,
                 high: float = 0.08, density: float = 0.08, thin: float = 0.06) -> np.ndarray:
    """Boolean line map for 3D evidence: the mask boundary, the object's strongest Canny edges, and the
    axes of its thin parts.

    Thresholds are gradient magnitudes of the grey image in [0, 1] (scikit-image's Sobel of the
    Gaussian-smoothed image; a step of contrast ``c`` gives about ``2c`` at σ = 1.5): at least ``high``,
    so shading noise stays out however little of the frame the object fills, and raised until at most
    ``density`` of the object's pixels seed an edge, so busy surfaces (studs, print) keep only their
    strongest lines. The low threshold is half the high one. A part narrower than ``thin`` × the object's
    size (a cable, a leg, a handle) adds its axis, which every view agrees on, while its two rims move with
    the view (:func:`thin_parts`), where it is narrow in the image too (:data:`AXIS_MAX_WIDTH`).
    """
    box = _object_box(mask)
    lines = np.zeros(image.shape[:2], bool)
    gray, gx, gy = _gradients(image[box], sigma)
    lines[box] = _lines(gray, gx, gy, None if mask is None else mask[box], None, sigma, low, high, density, thin,
                        max(image.shape[:2]))
    return lines


CROP_PAD = 24
"""Pixels kept around the mask's box when a view's line maps are computed on that box alone: every line lies
within 2 px of the mask, and the smoothing and Canny's hysteresis reach about 10 px, so beyond 24 px nothing
that is drawn changes. On Lego the object fills a third of the frame, and the maps cost that share."""


def _object_box(mask: np.ndarray | None) -> tuple[slice, slice]:
    """The mask's bounding box grown by :data:`CROP_PAD` px, clipped to the image (the whole image when there
    is no mask or it is empty)."""
    box = None if mask is None else ink_box(mask, CROP_PAD)
    return (slice(None), slice(None)) if box is None else box


@dataclass
class ViewMaps:
    """Per-view inputs of the vote: ``lines`` (bool), ``response`` (line closeness in [0, 1]),
    ``directions`` ``(H, W, 2)`` of the nearest line, ``sdf`` signed distance to the mask boundary (px,
    positive inside, grown by the carving slack)."""

    lines: np.ndarray
    response: np.ndarray
    directions: np.ndarray
    sdf: np.ndarray | None


def view_maps(image: np.ndarray, mask: np.ndarray, sigma: float = 1.5, sigma_px: float = 1.0, thin: float = 0.06,
              slack_px: float = 1.0, with_sdf: bool = True) -> ViewMaps:
    """Everything the vote needs from one view, sharing the distance transforms and the smoothed gradients.

    The response of a pixel is ``exp(−d² / 2σ²)`` of its distance ``d`` to the nearest line; its direction is
    that line's (across the image gradient there, or the mask's gradient on the mask boundary, where the
    object may match the background's brightness). ``with_sdf=False`` leaves out the signed distance (``None``),
    which only carving reads: a fit carves once, before discovery.
    """
    # Only the signed distance needs the whole frame (the carving reads it far from the object); the line maps
    # are computed on the object's box (:data:`CROP_PAD`), where every line lies.
    box = _object_box(mask)
    crop = mask[box]
    inside = ndimage.distance_transform_edt(crop)
    sdf = None
    if with_sdf:
        sdf = -ndimage.distance_transform_edt(~mask)
        sdf[box] = np.where(crop, inside, sdf[box])
        sdf = (sdf + slack_px).astype(np.float32)
    gray, gx, gy = _gradients(image[box], sigma)
    lines = _lines(gray, gx, gy, crop, inside, sigma, 0.04, 0.08, 0.08, thin, max(mask.shape))
    m = ndimage.gaussian_filter(crop.astype(np.float32), sigma)
    rim = crop ^ ndimage.binary_erosion(crop)
    gx = np.where(rim, ndimage.sobel(m, 1), gx)
    gy = np.where(rim, ndimage.sobel(m, 0), gy)
    norm = np.maximum(np.hypot(gx, gy), 1e-12)
    dist, (iy, ix) = ndimage.distance_transform_edt(~lines, return_indices=True)
    shape = mask.shape
    full_lines = np.zeros(shape, bool)
    full_lines[box] = lines
    directions = np.zeros((*shape, 2), np.float32)
    directions[box] = np.stack([-gy / norm, gx / norm], -1).astype(np.float32)[iy, ix]
    response = np.zeros(shape, np.float32)  # beyond the box, lines are more than CROP_PAD px away: 0
    response[box] = np.exp(-dist**2 / (2 * sigma_px**2))
    return ViewMaps(full_lines, response, directions, sdf)


def curve_samples(controls: np.ndarray, voxel: float, spacing_px: float) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                                                np.ndarray]:
    """Points along cubics ``(N, 4, 3)`` about ``spacing_px`` apart in views where a voxel of ``voxel`` spans a
    pixel (4 to 4000 a cubic): the points ``float32 (S, 3)``, their parameters ``(S,)``, their cubic ``(S,)`` and
    each cubic's count ``(N,)``."""
    from ...strokes.bezier import bezier_points

    rough = bezier_points(controls, np.linspace(0, 1, 9))
    length = np.linalg.norm(np.diff(rough, axis=1), axis=2).sum(1)
    n_samples = np.clip(np.ceil(length / voxel / spacing_px * 1.2).astype(int), 4, 4000)
    params = [np.linspace(0, 1, n) for n in n_samples]
    points = np.concatenate([bezier_points(c, t) for c, t in zip(controls, params)]).astype(np.float32)
    return points, np.concatenate(params), np.repeat(np.arange(len(controls)), n_samples), n_samples


def depth_maps(grid: VoxelGrid, occupied: np.ndarray, cameras: list[Camera]) -> list[np.ndarray]:
    """Per view, the depth of the hull's nearest surface voxel centre at every pixel (``inf`` off the hull).

    Each surface voxel is splatted to the pixel of its centre; pixels left without one take the nearest depth
    of their 3 × 3 neighbourhood. Where voxels project larger than a pixel, a pixel that no front voxel's
    centre lands in keeps a back-face voxel's depth (on Lego at the evidence size, a quarter of the pixels
    are 6 voxels or more too deep), so the vote sees into the hull there. That is kept on purpose, measured:
    the hull cannot be carved in concavities no view looks into from outside (the space above Lego's plate
    beside its tracks, where the tracks' lower edges lie 8 voxels inside the hull in every view), and the
    leak lets a share of the views vote for such edges. The exact front face (each voxel covering its
    projected footprint) raised precision and lowered recall: Lego F 0.755 → 0.73–0.75 with margins of 6, 9
    and 12 voxels (Cheburashka 0.839 → 0.835–0.859, rocker arm 0.829 → 0.808–0.836), and an explicit soft
    visibility (hidden views voting at a quarter weight) gave Lego 0.727.
    """
    surface = occupied & ~ndimage.binary_erosion(occupied)
    pts = grid.centres(np.argwhere(surface)).astype(np.float32)
    out = []
    for cam in cameras:
        u, v, z = project_points(cam, pts)
        ok = (z > 1e-6) & (u >= 0) & (v >= 0) & (u < cam.width) & (v < cam.height)
        zbuf = np.full(cam.height * cam.width, np.inf, np.float32)
        np.minimum.at(zbuf, v[ok] * cam.width + u[ok], z[ok])
        zbuf = zbuf.reshape(cam.height, cam.width)
        if ok.any():  # the filling, on the hull's box grown by 2 px (beyond it every pixel stays inf): 3x faster
            box = (slice(max(int(v[ok].min()) - 2, 0), int(v[ok].max()) + 3),
                   slice(max(int(u[ok].min()) - 2, 0), int(u[ok].max()) + 3))
            crop = zbuf[box]
            holes = ~np.isfinite(crop)
            crop[holes] = ndimage.minimum_filter(crop, size=3)[holes]
        out.append(zbuf)
    return out


def _vote(pts: np.ndarray, cams: list[Camera], response: list[np.ndarray], directions: list[np.ndarray],
          depth: list[np.ndarray], margin: float) -> tuple[np.ndarray, np.ndarray]:
    """Consistency score and number of views that see them, for points ``(P, 3)`` (see the module doc)."""
    iu = np.triu_indices(3)
    M = np.zeros((len(pts), 6), np.float32)  # Σ w n nᵀ (upper triangle)
    total = np.zeros(len(pts), np.float32)
    count = np.zeros(len(pts), np.int16)
    for cam, resp, dirs, zb in zip(cams, response, directions, depth):
        u, v, z = project_points(cam, pts)
        ok = (z > 1e-6) & (u >= 0) & (v >= 0) & (u < cam.width) & (v < cam.height)
        idx = np.flatnonzero(ok)
        idx = idx[z[idx] <= zb[v[idx], u[idx]] + margin]
        count[idx] += 1
        w = resp[v[idx], u[idx]]
        keep = w > 0.05  # far from every line: votes 0 either way
        idx, w = idx[keep], w[keep]
        # the plane through the eye that holds the image line: normal = ray × line direction
        d = dirs[v[idx], u[idx]]
        ray = np.stack([(u[idx] + 0.5 - cam.cx) / cam.fx, (v[idx] + 0.5 - cam.cy) / cam.fy,
                        np.ones(len(idx))], -1).astype(np.float32)
        along = np.stack([d[:, 0] / cam.fx, d[:, 1] / cam.fy, np.zeros(len(idx))], -1).astype(np.float32)
        n = np.cross(ray, along) @ cam.R.astype(np.float32)  # camera → world (row form of Rᵀ n)
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
        M[idx] += w[:, None] * (n[:, iu[0]] * n[:, iu[1]])
        total[idx] += w
    full = np.zeros((len(pts), 3, 3), np.float32)
    full[:, iu[0], iu[1]] = M
    full[:, iu[1], iu[0]] = M
    # A 3D line lies in every view's plane: their normals leave one direction (the line's) free, so the
    # smallest eigenvalue stays 0; clutter in all directions raises it to a third of the total.
    smallest = np.linalg.eigvalsh(full)[:, 0]
    return np.maximum(total - 3.0 * smallest, 0.0) / (count + 1.0), count


def edge_evidence(scene: Scene, max_voxels: int = 192, band: int = 12, margin_voxels: float = 6.0,
                  sigma_px: float = 1.0, grow: int = 4, thin: float = 0.06, chunk: int = 1 << 16,
                  disagree: float | None = None, carving: tuple[VoxelGrid, np.ndarray] | None = None) -> Evidence:
    """Vote for 3D edges on a grid around the visual hull (see the module docstring).

    Args:
        scene: posed images with masks, at the evidence resolution (a voxel should project to about a pixel).
        max_voxels: grid voxels along the hull box's longest side.
        band: candidates are hull voxels at most this many voxels under the hull's surface …
        grow: … or at most this many outside it.
        margin_voxels: a voxel counts as visible when at most this far behind the hull's depth map.
        sigma_px: width of the line response.
        disagree: of the hull's carving (see :func:`~doodle.fit.volume.carve.carve_hull`).
        carving: the hull ``(grid, occupied)`` already carved from this scene with ``max_voxels`` (a fit's volume
            stage); ``None``: carved here.

    The per-view maps and the vote run in threads (numpy and scipy release the GIL in them): no worker
    processes, nothing to fork.
    """
    from concurrent.futures import ThreadPoolExecutor

    from ...workers import cpu_count

    if scene.masks is None:
        raise ValueError("the scene has no masks")
    with ThreadPoolExecutor(min(cpu_count(), 8)) as pool:
        maps = list(pool.map(lambda im: view_maps(im[0], im[1], sigma_px=sigma_px, thin=thin,
                                                  with_sdf=carving is None), zip(scene.images, scene.masks)))
        grid, occupied = carving if carving is not None else \
            carve_hull(scene, max_voxels, sdf=[vm.sdf for vm in maps], disagree=disagree)
        cams = scene.cameras
        lines = [vm.lines for vm in maps]
        response = [vm.response for vm in maps]
        directions = [vm.directions for vm in maps]
        del maps
        depth = depth_maps(grid, occupied, cams)
        inner = ndimage.binary_erosion(occupied, iterations=band) if band > 0 else np.zeros_like(occupied)
        # a voxel or two outside the hull too: poses a pixel off carve the hull a little too small
        cand = np.argwhere(ndimage.binary_dilation(occupied, iterations=grow) & ~inner)
        margin = margin_voxels * grid.voxel
        parts = list(pool.map(lambda s: _vote(grid.centres(cand[s:s + chunk]).astype(np.float32), cams, response,
                                              directions, depth, margin), range(0, len(cand), chunk)))
    score = np.zeros(occupied.shape, np.float32)
    seen = np.zeros(occupied.shape, np.int16)
    if parts:
        score[tuple(cand.T)] = np.concatenate([p[0] for p in parts])
        seen[tuple(cand.T)] = np.concatenate([p[1] for p in parts])
    return Evidence(grid, score, occupied, seen, cams, lines, depth, margin)
