"""Where a view sees the floor: the support plane is photo-consistent, what stands on it is not.

A pixel whose ray meets the support plane at a point ``X`` shows the floor when the other photos, looking at
``X``, see its colour there too; a pixel of the object (or of anything standing on the floor) shows something
above ``X``, and the other photos, looking at ``X`` from elsewhere, see the floor behind it instead, a different
colour wherever the floor has texture. So the busier the floor, a carpet, the surer the cue that colour models
alone lose on. The photos compared look from 20-80° away (near ones would see a tall object in front of the
same floor point), and the median of their errors counts: where the object hides ``X`` from some of them, the
others decide. On a plain floor every pixel agrees by accident and the cue says nothing, which is where colour
models do well.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from ...cameras import Camera
from .region import ObjectRegion

NEIGHBOURS = 8
"""Photos each view's floor is compared with: looking at the object from 20-80° away (:func:`_neighbours`)."""
FLOOR_CONTRAST = 1.5
"""A pixel shows the floor when its colour error is under this many times the typical error at the floor's own
points (and :data:`FLOOR_MIN_ERROR`) ..."""
OFF_CONTRAST = 4.0
"""... and something above the floor when it is over this many times (and twice :data:`FLOOR_MIN_ERROR`); in
between, the cue says nothing."""
FLOOR_MIN_ERROR = 10.0
"""8-bit levels (mean over the channels): JPEG noise and a pixel of misregistration stay under it."""
FLOOR_MAX_TYPICAL = 20.0
"""When the floor's own points disagree by more than this between views (grazing views, where a plane a little
off shifts the floor by pixels), the cue is not used in that view."""


def _neighbours(k: int, cams: list[Camera], focus: np.ndarray, n: int) -> list[int]:
    """Up to ``n`` views looking at ``focus`` from 20-80° away from view ``k``, evenly picked (the nearest ones
    when too few are that far). Near views see a tall object in front of the same floor (a cranium above a
    support hides the same floor point from views a few degrees apart): it would pass for floor."""
    d = np.array([c.center - focus for c in cams])
    d /= np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12)
    angle = np.degrees(np.arccos(np.clip(d @ d[k], -1.0, 1.0)))
    angle[k] = np.inf
    ring = np.flatnonzero((angle >= 20) & (angle <= 80))
    if len(ring) < 3:
        return [int(j) for j in np.argsort(angle)[:n]]
    ring = ring[np.argsort(angle[ring])]
    return [int(ring[i]) for i in np.unique(np.linspace(0, len(ring) - 1, min(n, len(ring))).round().astype(int))]


def floor_error(k: int, cams: list[Camera], colours: list[np.ndarray], region: ObjectRegion) -> np.ndarray:
    """``float (H, W)`` for view ``k``: how far each pixel's colour is from what other views see at the point
    where its ray meets the support (the median over :data:`NEIGHBOURS` of them, 8-bit levels), ``inf`` where the
    ray misses the support (above the horizon, or no support) or fewer than two of them see it. ``colours``: every view's image as ``float
    (H, W, 3)`` at its camera's size, blurred (:func:`blurred`)."""
    cam = cams[k]
    H, W = colours[k].shape[:2]
    out = np.full((H, W), np.inf, np.float32)
    if region.plane is None:
        return out
    n, d = region.plane
    v, u = np.mgrid[0:H, 0:W]
    origin, ray = cam.rays_at(u.ravel() + 0.5, v.ravel() + 0.5)
    denom = ray @ n
    t = (d - origin @ n) / np.where(np.abs(denom) > 1e-12, denom, 1e-12)
    hits = (t > 0) & (denom < 0)
    X = origin[hits] + t[hits, None] * ray[hits]
    mine = colours[k].reshape(-1, 3)[hits]
    errors = []
    for j in _neighbours(k, cams, region.focus, NEIGHBOURS):
        other = cams[j]
        pc = X @ other.R.T + other.t
        z = pc[:, 2]
        uv = pc[:, :2] / np.where(z > 1e-9, z, 1e-9)[:, None] * [other.fx, other.fy] + [other.cx, other.cy]
        Hj, Wj = colours[j].shape[:2]
        ok = (z > 1e-9) & (uv[:, 0] >= 0) & (uv[:, 1] >= 0) & (uv[:, 0] < Wj) & (uv[:, 1] < Hj)
        e = np.full(len(X), np.inf, np.float32)
        seen = colours[j][uv[ok, 1].astype(int), uv[ok, 0].astype(int)]
        e[ok] = np.abs(seen - mine[ok]).mean(axis=1)
        errors.append(e)
    errors = np.stack(errors)
    seen = np.isfinite(errors).sum(axis=0)
    middle = np.sort(errors, axis=0)[np.maximum((seen - 1) // 2, 0), np.arange(errors.shape[1])]
    out.ravel()[np.flatnonzero(hits)] = np.where(seen >= 2, middle, np.inf)
    return out


def blurred(image: np.ndarray) -> np.ndarray:
    """An image as ``float32``, box-blurred over 1.3 % of its long side (5 px at 384): the colours
    :func:`floor_error` compares (a pixel or two of misregistration, and a floor's finest grain, cost little)."""
    k = max(3, 2 * round(0.0065 * max(image.shape[:2])) + 1)
    return ndimage.uniform_filter(image.astype(np.float32), size=(k, k, 1))


def floor_pixels(error: np.ndarray, floor_uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(floor, off_floor)``, ``bool (H, W)``: the pixels that show the floor, and those that show something
    standing on it, by their :func:`floor_error` against its typical value in this view (at the floor's own
    points ``floor_uv (P, 2)``, or over all the pixels that meet the floor) (see :data:`FLOOR_CONTRAST`, :data:`OFF_CONTRAST`), each cleaned of
    specks."""
    H, W = error.shape
    finite = error[np.isfinite(error)]
    if len(finite) < 100:
        return np.zeros_like(error, bool), np.zeros_like(error, bool)
    # The floor's typical error: a low quantile at its points (those the object hides in this view, when no
    # tracks tell, land on it and disagree), or of all the pixels that meet it (mostly floor in a photo of an
    # object), whichever is lower.
    typical = float(np.percentile(finite, 25))
    if len(floor_uv):
        u, v = np.clip(floor_uv.astype(int), 0, [W - 1, H - 1]).T
        at = error[v, u]
        at = at[np.isfinite(at)]
        if len(at) >= 10:
            typical = min(typical, float(np.percentile(at, 30)))
    if typical > FLOOR_MAX_TYPICAL:  # the floor itself does not agree between views here: the cue says nothing
        return np.zeros_like(error, bool), np.zeros_like(error, bool)
    floor = error < max(FLOOR_MIN_ERROR, FLOOR_CONTRAST * typical)
    off = np.isfinite(error) & (error > max(2 * FLOOR_MIN_ERROR, OFF_CONTRAST * typical))
    return ndimage.binary_opening(floor, iterations=2), ndimage.binary_opening(off, iterations=1)
