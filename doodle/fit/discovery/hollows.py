"""Hollows: eye sockets, a nose, a mouth — what a person draws first inside a skull's outline.

A visual hull bridges a hollow: no silhouette looks into it, so the hull's surface passes over its opening
and the edge evidence on that surface (:mod:`.evidence`) is a blur of the rim seen from many sides. But
little light reaches into a hollow, and every view that looks into one sees a region darker than the surface
round it. Those dark regions are the hollow's silhouettes, as the masks are the object's: the voxels under
the hull's surface that project into a dark region in most of the views that see their side of the object
carve the hollow's own visual hull. Each one dark enough (:data:`DEEP`: little light reaches in) and of a size
a viewer reads as a part is drawn as a ring round its opening: the outline of the dark region that the view
looking most squarely into it sees there, at that view's pixels (:func:`_traced`: a nose's two lobes and
septum, a missing tooth's notch, which the vote's grid is too coarse for), lifted to the hull's surface that
bridges the opening.

Paint as dark is found the same way and drawn the same; which rings are drawn is the salience choice's
(:func:`.salience.choose_features`), beside the painted features.

Dark is relative: a region whose log brightness lies :data:`DARKER` below the mean over the object within
:data:`LOCAL_REACH` of the object's size (not below one global level: a hollow on the shaded side of an object
is dark against that side). A dark region touching the outline is a shading side or a cast shadow, not a
hollow, and is left out.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from skimage import measure

from ...arrays import along_polyline, spread_indices
from ...exporters.visibility import occluded
from ...strokes.bezier import bezier_points
from ...strokes.fitcurve import fit_cubics_many
from ..volume.carve import VoxelGrid, coarsened, project_points

#: How much darker (in log brightness) than the object round it a region is dark: 0.5 is 61 % of the brightness.
#: DTU's skull: the eye sockets, the nose and the mouth are 0.6–1.5 darker than the bone round them, shading on
#: its cranium under 0.3.
DARKER = 0.5
#: A hollow is at least this much darker on average (log brightness, 45 % of the brightness round it): little
#: light reaches into one. Shading and mid-tone paint stay above: the skull's eye sockets, nose and mouth measure
#: 0.9–1.6; the shaded undersides of the procedural mouse and cow and the calf's patches 0.58–0.69 (against a
#: local mean that includes them), the mouse's scroll-wheel slot 0.91.
DEEP = 0.8
#: The reach (share of the mask's box diagonal) of the local mean brightness a region is compared with.
LOCAL_REACH = 0.08
#: A dark region within this share of the mask's box diagonal of the outline touches it.
OUTLINE_BAND = 0.015
#: Share of the views that see a voxel in which it must project into a dark region to belong to a hollow.
DARK_SHARE = 0.5
#: How deep under the hull's surface (share of its longest side) hollows are looked for, and how far behind
#: the hull's depth a voxel still counts as seen (a hollow lies behind the surface that bridges it).
DEPTH = 0.1
#: The hollows' size (box diagonal over the object's) drawn: smaller ones are dots, larger ones a shaded side.
MIN_SIZE, MAX_SIZE = 0.03, 0.35
#: Views used (evenly spread) and the vote's grid (voxels along the hull's longest side).
VIEWS, VOXELS = 24, 96
#: The share of a ring the superquadrics may hide from the views that saw into its hollow (:func:`clear_of`).
HIDDEN = 0.1
#: The views within this angle (degrees) of a ring's facing see into its hollow (:func:`clear_of`).
FACING_DEG = 60.0
#: Gaps (voxels of the vote's grid) closed between the pieces of one hollow.
CLOSE = 1
#: A dark region of the view facing a hollow is part of its opening when at least this share of it lies on the
#: hollow's footprint (:func:`_traced`): more than half, so a shaded side that reaches it stays out.
OPENING_ON = 0.5


@dataclass
class Hollow:
    """One hollow (or dark patch): its ring and what its salience is made of."""

    cubics: np.ndarray
    """``(K, 4, 3)`` closed chains round its opening (one per dark region the view facing it sees there)."""
    points: np.ndarray
    """``(P, 3)`` samples along the ring."""
    share: float
    """Mean share of the views that see its voxels in which they project into a dark region."""
    darkness: float
    """How much darker (log brightness) than the object round it the views see it, mean over its voxels."""
    facing: np.ndarray
    """``(3,)`` unit: the mean direction to the views that saw into it."""


def wide_gaussian(image: np.ndarray, sigma: float, step: float = 8.0) -> np.ndarray:
    """``ndimage.gaussian_filter(image, sigma)`` of a 2D image for a wide ``sigma``, computed on the image
    averaged in blocks of ``sigma // step`` pixels and brought back to full size bilinearly: a Gaussian that
    wide varies little across a block, and the filter's taps fall by the block's area squared (a skull view's
    local mean at σ = 40 px: 0.55 → 0.13 s; the dark regions' drop differs by 1e-4 in the mean)."""
    f = int(sigma // step)
    if f < 2:
        return ndimage.gaussian_filter(image, sigma)
    h, w = image.shape
    padded = np.pad(image, ((0, -h % f), (0, -w % f)), mode="reflect")
    blocks = padded.reshape(padded.shape[0] // f, f, padded.shape[1] // f, f).mean(axis=(1, 3))
    # a block's mean is itself a blur of variance (f² − 1) / 12: the rest is the Gaussian's
    small = ndimage.gaussian_filter(blocks, np.sqrt(max(sigma**2 - (f * f - 1) / 12, 1e-6)) / f)
    return ndimage.zoom(small, f, order=1, grid_mode=True, mode="nearest")[:h, :w]


def dark_regions(image: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The regions of a view darker than the object round them, away from its outline, and by how much.

    Args:
        image: ``(H, W, 3)`` uint8; ``mask`` ``(H, W)`` bool, the object.

    Returns:
        ``dark`` ``(H, W)`` bool (see the module docstring) and ``drop`` ``(H, W)`` float32, the local mean
        log brightness minus the pixel's (0 off the object).
    """
    gray = np.log(ndimage.gaussian_filter(np.asarray(image, np.float32)[..., :3].mean(-1), 1.0) / 255.0 + 0.02)
    ys, xs = np.nonzero(mask)
    if len(ys) == 0:
        return np.zeros_like(mask), np.zeros(mask.shape, np.float32)
    diag = float(np.hypot(np.ptp(ys) + 1, np.ptp(xs) + 1))
    weight = mask.astype(np.float32)
    reach = LOCAL_REACH * diag
    local = wide_gaussian(gray * weight, reach) / np.maximum(wide_gaussian(weight, reach), 1e-6)
    drop = np.where(mask, local - gray, 0.0).astype(np.float32)
    dark = ndimage.binary_opening((drop > DARKER) & mask)
    band = ndimage.distance_transform_edt(mask) <= max(OUTLINE_BAND * diag, 2.0)
    labels, n = ndimage.label(dark)
    if n:
        touching = np.unique(labels[band & dark])
        dark &= ~np.isin(labels, touching[touching > 0])
    return dark, drop


def find_hollows(grid: VoxelGrid, occupied: np.ndarray, cameras: list, images: list[np.ndarray],
                 masks: list[np.ndarray], depth: list[np.ndarray], tolerance: float) -> list[Hollow]:
    """The hollows (and dark patches) of an object, each as a closed ring (see the module docstring).

    Args:
        grid, occupied: the carved hull (the views' free voxels left out).
        cameras, images, masks, depth: the views at the evidence size, with the hull's depth maps.
        tolerance: the rings' fitting tolerance (world units).
    """
    views = spread_indices(len(cameras), VIEWS)
    coarse, occ = coarsened(grid, occupied, VOXELS)
    reach = max(1, int(round(DEPTH * max(occ.shape))))
    band = occ & ~ndimage.binary_erosion(occ, iterations=reach)
    ijk = np.argwhere(band)
    if len(ijk) == 0:
        return []
    pts = coarse.centres(ijk).astype(np.float32)
    behind = DEPTH * max(occ.shape) * coarse.voxel
    dark_votes = np.zeros(len(pts), np.float32)
    seen = np.zeros(len(pts), np.float32)
    drops = np.zeros(len(pts), np.float32)
    centres = np.array([cameras[v].center for v in views])
    looked = []  # per view, the voxels it sees dark (for the rings' facing)
    darks: dict[int, np.ndarray] = {}  # per view, its dark regions: the rings' tracing reads them again
    for v in views:
        dark, drop = dark_regions(images[v], masks[v])
        darks[v] = dark
        u, w, z = project_points(cameras[v], pts)
        H, W = dark.shape
        ok = np.flatnonzero((z > 1e-6) & (u >= 0) & (w >= 0) & (u < W) & (w < H))
        ok = ok[(z[ok] <= depth[v][w[ok], u[ok]] + behind) & masks[v][w[ok], u[ok]]]
        seen[ok] += 1
        hit = ok[dark[w[ok], u[ok]]]
        dark_votes[hit] += 1
        drops[hit] += drop[w[hit], u[hit]]
        looked.append(hit)
    share = np.where(seen >= max(3, 0.2 * len(views)), dark_votes / np.maximum(seen, 1), 0.0)
    chosen = share >= DARK_SHARE
    vol = np.zeros(occ.shape, bool)
    vol[tuple(ijk[chosen].T)] = True
    # one hollow the views saw in pieces (a rod across an eye socket) is one: gaps of a voxel or two closed
    joined = ndimage.binary_closing(vol, np.ones((3, 3, 3)), iterations=CLOSE) & band
    labels, n = ndimage.label(joined, np.ones((3, 3, 3)))
    if n == 0:
        return []
    label_of = np.zeros(len(pts), int)
    label_of[chosen] = labels[tuple(ijk[chosen].T)]
    dark_seen = np.stack([np.bincount(label_of[hit], minlength=n + 1) for hit in looked])  # (views, n + 1)
    size = coarse.voxel * float(np.linalg.norm(occ.shape))
    out = []
    for k in range(1, n + 1):
        members = np.flatnonzero(label_of == k)
        if len(members) < 8:
            continue
        darkness = float(drops[members].sum() / max(dark_votes[members].sum(), 1.0))
        if darkness < DEEP:
            continue
        p = pts[members].astype(np.float64)
        extent = float(np.linalg.norm(p.max(0) - p.min(0))) / size
        if not MIN_SIZE <= extent <= MAX_SIZE:
            continue
        # the opening faces the views that saw into it
        to_eye = centres - p.mean(0)
        to_eye /= np.linalg.norm(to_eye, axis=1, keepdims=True)
        facing = (dark_seen[:, k, None] * to_eye).sum(0)
        if np.linalg.norm(facing) < 1e-9:
            continue
        facing /= np.linalg.norm(facing)
        # its opening as the view facing it sees it; where that view sees nothing dark there, the vote's own
        # outline (the hollow's waist), moved out to the surface that bridges the opening
        rings = _traced(p, facing, coarse.voxel, cameras, images, masks, depth, darks)
        if not rings:
            ring = _ring(p, facing, coarse.voxel)
            if ring is None:
                continue
            rings = [_onto_surface(ring, facing, grid, occupied, behind)]
        cubics = np.concatenate(fit_cubics_many(rings, tolerance, [True] * len(rings)))
        samples = bezier_points(cubics, np.linspace(0, 1, 12)).reshape(-1, 3)
        out.append(Hollow(cubics, samples, float(share[members].mean()), darkness, facing))
    return out


def clear_of(cubics: np.ndarray, facing: np.ndarray, sq, cameras: list, reach: float, step: float, margin: float,
             volume=None) -> np.ndarray | None:
    """A ring ``cubics`` ``(K, 4, 3)`` moved along ``facing``, as one, by the least multiple of ``step`` (at most
    ``reach``) that leaves at most :data:`HIDDEN` of it hidden by the superquadrics ``sq`` and the occluder
    ``volume`` (a :class:`~doodle.strokes.model.Voxels`, or ``None``) from the ``cameras`` that face it (within
    :data:`FACING_DEG` of ``facing``; ``margin``: the drawing's occlusion margin): a part's superquadric bulges
    over the hollows in it (a skull's over its eye sockets), as the coarse occluder does, and would hide their
    rings from the views that see into them. ``None`` when no move within ``reach`` does: a ring no view would
    see."""
    if len(sq) == 0 and volume is None:
        return cubics
    pts = bezier_points(cubics, np.linspace(0, 1, 8)).reshape(-1, 3)
    to_eye = np.array([c.center for c in cameras]).reshape(-1, 3) - pts.mean(0)
    cos = (to_eye / np.maximum(np.linalg.norm(to_eye, axis=1, keepdims=True), 1e-12)) @ facing
    facing_it = [cameras[k] for k in np.flatnonzero(cos >= np.cos(np.radians(FACING_DEG)))]
    if not facing_it:
        return None
    view = np.repeat(np.arange(len(facing_it)), len(pts))
    for s in np.arange(0.0, reach + 0.5 * step, step):
        moved = np.tile(pts + s * facing, (len(facing_it), 1))
        if occluded(moved + margin * facing, view, facing_it, sq, margin, volume=volume).mean() <= HIDDEN:
            return cubics + s * facing
    return None


def _traced(points: np.ndarray, facing: np.ndarray, voxel: float, cameras: list, images: list, masks: list,
            depth: list, darks: dict[int, np.ndarray] | None = None) -> list[np.ndarray]:
    """The opening of the hollow whose voxels are ``points`` ``(P, 3)``, traced in the view that looks most
    squarely into it (along ``facing``): the outlines of that view's dark regions (:func:`dark_regions`) lying
    mostly on the hollow's projection, each lifted to the hull's front depth there. ``[]`` when that view sees
    none. The vote's grid is too coarse for an opening's shape (a nose's two lobes and their septum, the
    notch of a missing tooth); the view's pixels are not. ``darks``: the views' dark regions already found, by
    view index (filled in here as more are)."""
    to_eye = np.array([c.center for c in cameras]) - points.mean(0)
    v = int(np.argmax((to_eye / np.linalg.norm(to_eye, axis=1, keepdims=True)) @ facing))
    darks = {} if darks is None else darks
    if v not in darks:
        darks[v] = dark_regions(images[v], masks[v])[0]
    cam, dark = cameras[v], darks[v]
    u, w, z = project_points(cam, points.astype(np.float32))
    H, W = dark.shape
    ok = (z > 1e-6) & (u >= 0) & (w >= 0) & (u < W) & (w < H)
    labels, n = ndimage.label(dark)
    if n == 0 or not ok.any():
        return []
    # the hollow's footprint: its voxels' pixels, grown by a voxel's size in this view
    foot = np.zeros_like(dark)
    foot[w[ok], u[ok]] = True
    px = max(1, int(np.ceil(voxel * cam.fx / float(np.median(z[ok])))))
    foot = ndimage.binary_dilation(foot, iterations=px)
    area = np.bincount(labels.ravel(), minlength=n + 1)
    on = np.bincount(labels[foot], minlength=n + 1)
    rings = []
    for k in np.flatnonzero((on >= OPENING_ON * area) & (area >= 4 * px * px)):
        if k == 0:
            continue
        outline = _outline(ndimage.binary_fill_holes(labels == k))
        if outline is not None:
            rings.append(_lifted(outline, cam, depth[v]))
    return rings


def _outline(region: np.ndarray, spacing: float = 1.5) -> np.ndarray | None:
    """``(S, 2)`` pixel positions ``(row, col)`` every ``spacing`` px round the outer outline of ``region``
    (bool ``(H, W)``), smoothed over a pixel; ``None`` for a speck."""
    soft = ndimage.gaussian_filter(np.pad(region, 2).astype(np.float32), 1.0)
    contours = measure.find_contours(soft, 0.5)
    if not contours:
        return None
    c = max(contours, key=len) - 2
    length = float(np.linalg.norm(np.diff(c, axis=0, append=c[:1]), axis=1).sum())
    if length < 8 * spacing:
        return None
    return along_polyline(c, int(length / spacing), closed=True)


def _lifted(outline: np.ndarray, cam, depth: np.ndarray, reach: int = 4, smooth: int = 9) -> np.ndarray:
    """``(S, 3)``: the pixels ``outline`` ``(S, 2)`` (row, col) of ``cam`` lifted to the hull's front depth
    round them. A hull's depth map keeps a back face's depth where no front voxel lands on a pixel
    (:func:`.evidence.depth_maps`): the nearest tenth of the depths within ``reach`` px is the front's; it is
    then smoothed along the ring over ``smooth`` samples (the voxels' stairs)."""
    H, W = depth.shape
    rows, cols = np.clip(np.rint(outline).astype(int), 0, [H - 1, W - 1]).T
    z = np.full(len(outline), np.nan)
    for i, (r, c) in enumerate(zip(rows, cols)):
        window = depth[max(r - reach, 0):r + reach + 1, max(c - reach, 0):c + reach + 1]
        finite = window[np.isfinite(window)]
        if len(finite):
            z[i] = np.percentile(finite, 10)
    z = np.where(np.isfinite(z), z, np.nanmedian(z)) if np.isfinite(z).any() else np.zeros(len(outline))
    z = ndimage.uniform_filter1d(z, smooth, mode="wrap")
    origins, dirs = cam.rays_at(outline[:, 1] + 0.5, outline[:, 0] + 0.5)
    return origins + dirs * (z / (dirs @ cam.forward))[:, None]


def _onto_surface(points: np.ndarray, normal: np.ndarray, grid: VoxelGrid, occupied: np.ndarray, reach: float
                  ) -> np.ndarray:
    """The ring ``points`` ``(P, 3)`` moved along ``normal``, as one, out to where the hull ``occupied`` ends
    (for three quarters of them; at most ``reach``): a ring drawn at a hollow's waist lies inside the hull,
    which hides it from every view; on the surface that bridges the opening it is drawn where the views look
    into the hollow. Moved point by point it would follow the bridge's bumps (a voxel hull's stairs)."""
    steps = np.arange(0.0, reach + grid.voxel, 0.5 * grid.voxel)
    q = points[:, None, :] + steps[None, :, None] * normal
    idx = np.rint(grid.coordinates(q.reshape(-1, 3))).astype(int)
    inside = ((idx >= 0) & (idx < np.array(occupied.shape))).all(1)
    occ = np.zeros(len(idx), bool)
    occ[inside] = occupied[tuple(idx[inside].T)]
    occ = occ.reshape(len(points), len(steps))
    # the last step inside before the first outside; a point never inside, or still inside at the reach (deep in
    # the hull, where the bridge is far), stays and counts as not moved: the ring follows the rest of it
    out = np.where(occ.any(1), np.argmax(~occ & (np.cumsum(occ, 1) > 0), 1), 0)
    last_in = np.maximum(out - 1, 0)
    return points + float(np.percentile(steps[last_in], 75)) * normal


def _ring(points: np.ndarray, normal: np.ndarray, voxel: float, samples: int = 48) -> np.ndarray | None:
    """``(samples, 3)`` the outline of ``points`` ``(P, 3)`` seen along ``normal`` (a unit vector), in the plane
    through their centroid normal to it: the hollow's waist, its widest section as the views see it."""
    centre = points.mean(0)
    u = np.cross(normal, [1.0, 0.0, 0.0] if abs(normal[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    ab = (points - centre) @ np.stack([u, v]).T / voxel  # in voxels
    lo = np.floor(ab.min(0)).astype(int) - 3
    ij = np.floor(ab).astype(int) - lo
    img = np.zeros(tuple(ij.max(0) + 4), bool)
    img[ij[:, 0], ij[:, 1]] = True
    img = ndimage.binary_fill_holes(ndimage.binary_closing(img, iterations=2))
    contours = measure.find_contours(np.pad(img, 1).astype(np.float32), 0.5)
    if not contours:
        return None
    c = max(contours, key=len) - 1 + lo + 0.5  # back to voxel units about the centre
    if len(c) < 8:
        return None
    c = ndimage.uniform_filter1d(along_polyline(c, samples, closed=True), 5, axis=0, mode="wrap")
    return centre + (c * voxel) @ np.stack([u, v])
