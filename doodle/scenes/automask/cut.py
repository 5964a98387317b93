"""One view's cut: OpenCV's GrabCut (colour models of object and background, a graph cut) seeded from 3D.

The seeds say what the views already know: pixels where object points land are surely object, pixels where
background points land (the support under the object, whatever stands around it) surely background, and
the region the object is expected in (the projected points' outline, or the hull carved from the first cuts)
probably object. GrabCut decides the rest by colour: a smooth, textureless part of the object without a
single point (a skull's cranium) joins the object by its colour, and a textured floor, however many features
it gave, stays background.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage


def grabcut(image: np.ndarray, seeds: np.ndarray, iterations: int = 4) -> np.ndarray:
    """GrabCut from a seed map of OpenCV labels (0 bg, 1 fg, 2 probably bg, 3 probably fg) → bool mask."""
    import cv2

    if not (seeds % 2 == 1).any() or not (seeds % 2 == 0).any():
        return seeds % 2 == 1
    labels = seeds.astype(np.uint8).copy()
    bgd, fgd = np.zeros((1, 65), np.float64), np.zeros((1, 65), np.float64)
    cv2.setRNGSeed(0)
    try:
        cv2.grabCut(np.ascontiguousarray(image[..., ::-1]), labels, None, bgd, fgd, iterations,
                    cv2.GC_INIT_WITH_MASK)
    except cv2.error:  # a colour model with too few samples: keep the seeds
        return seeds % 2 == 1
    return (labels == cv2.GC_FGD) | (labels == cv2.GC_PR_FGD)


def disc(r: float) -> np.ndarray:
    """A digital disc of radius ``r`` px (at least 1): a structuring element."""
    r = max(1, int(round(r)))
    y, x = np.ogrid[-r:r + 1, -r:r + 1]
    return x * x + y * y <= r * r


def _marks(shape: tuple[int, int], uv: np.ndarray, radius: float = 0.0) -> np.ndarray:
    """``bool (H, W)``: the pixels of the points ``uv (P, 2)``, grown by ``radius`` px."""
    H, W = shape
    out = np.zeros(shape, bool)
    if len(uv):
        u, v = np.clip(np.floor(uv).astype(int), 0, [W - 1, H - 1]).T
        out[v, u] = True
    return ndimage.binary_dilation(out, disc(radius)) if radius >= 1 else out


def point_seeds(seeds: np.ndarray, object_uv: np.ndarray, background_uv: np.ndarray) -> np.ndarray:
    """Mark the projected object points surely object and the projected background points surely background,
    except within a few pixels of an object point (where the object meets its support, both land)."""
    import cv2

    scale = max(seeds.shape) / 384
    obj = _marks(seeds.shape, object_uv)
    near_obj = ndimage.binary_dilation(obj, disc(4 * scale))
    bg = _marks(seeds.shape, background_uv, 1.5 * scale) & ~near_obj
    seeds[bg] = cv2.GC_BGD
    seeds[obj] = cv2.GC_FGD
    return seeds


ITERS = 1
#: A pixel whose channels average at least this (of 255) is overexposed: a highlight clipped to white.
CLIPPED = 245
#: A hole in a view's cut is filled when at least this share of it is overexposed (:func:`fill_highlights`).
HIGHLIGHT_SHARE = 0.5
BINS = 16
"""Levels per channel of the colour histograms (16³ colours)."""
RARE = 0.2
"""A colour is rare in a view's background below this share of a uniform histogram's density."""


def colour_bins(image: np.ndarray) -> np.ndarray:
    """``int (H, W)``: each pixel's colour bin (:data:`BINS` levels per RGB channel)."""
    q = (image.astype(np.int32) * BINS) // 256
    return (q[..., 0] * BINS + q[..., 1]) * BINS + q[..., 2]


def histogram(bins: np.ndarray, weight: float = 1.0) -> np.ndarray:
    """A colour histogram ``(BINS³,)`` of bin indices, smoothed over neighbouring colours and normalised."""
    h = np.bincount(bins.ravel(), minlength=BINS ** 3).astype(np.float64).reshape((BINS,) * 3)
    h = ndimage.gaussian_filter(h, 0.8, mode="constant")
    return weight * h.ravel() / max(h.sum(), 1e-12)


def likely_object(image: np.ndarray, object_colours: np.ndarray, object_uv: np.ndarray, surely_not: np.ndarray,
                  background_uv: np.ndarray, off_floor: np.ndarray | None = None, edge: bool = False) -> np.ndarray:
    """A generous first mask of one view: the pixels whose colour the object's points show more often than
    the view's background does, or that the background hardly shows (:data:`RARE`), connected to where the
    object's points land, with the points' outline.

    ``object_colours``: the histogram of the object points' colours over all the views (a smooth part without
    a point, a cranium, has the colour of the parts that have them); ``surely_not``: ``bool (H, W)``, the
    pixels that cannot be the object (beyond its reach), whose colours, with the background points', are the
    view's background (with the photo's edge when ``edge`` and these are few: an object is framed by its photos). ``off_floor``: the pixels whose ray meets the support where the other views see something
    else (:mod:`.floor`), object by that alone (a dark leg on a dark carpet). The mask errs towards the object:
    the views' hull takes away what they disagree on."""
    import cv2

    bins = colour_bins(image)
    bg_pixels = np.concatenate([bins[surely_not], bins[_marks(bins.shape, background_uv, 1.0)]])
    if edge and len(bg_pixels) < 0.05 * bins.size:  # little known background: the photo's edge is
        edge = np.ones(bins.shape, bool)
        w = max(2, round(0.02 * max(bins.shape)))
        edge[w:-w, w:-w] = False
        bg_pixels = np.concatenate([bg_pixels, bins[edge]])
    background = histogram(bg_pixels) if len(bg_pixels) else np.full(BINS ** 3, 1.0 / BINS ** 3)
    # likelier the object's than the background's, or hardly ever the background's (a dark leg on a red carpet,
    # when the points all lie on the body)
    likely = (object_colours[bins] > background[bins] + 1e-6) | (background[bins] < RARE / BINS ** 3)
    if off_floor is not None:
        likely |= off_floor
    points = _marks(bins.shape, object_uv)
    region = likely | points
    if len(object_uv) >= 3:
        outline = np.zeros(bins.shape, np.uint8)
        cv2.fillConvexPoly(outline, cv2.convexHull(object_uv.astype(np.float32)).astype(np.int32), 1)
        region |= outline.astype(bool)
    region = ndimage.binary_closing(region, disc(max(bins.shape) / 192)) & ~surely_not
    labels, n = ndimage.label(region)
    if n == 0:
        return region
    touched = np.unique(labels[points & region])
    return np.isin(labels, touched[touched > 0])


def fill_highlights(mask: np.ndarray, image: np.ndarray, floor: np.ndarray | None = None) -> np.ndarray:
    """``mask`` with its holes filled where the photo is overexposed (:data:`CLIPPED` over at least
    :data:`HIGHLIGHT_SHARE` of a hole) and the ``floor`` cue (:mod:`.floor`) sees no support.

    A clipped highlight has no colour: GrabCut's colour models may give a polished cranium's white patch to the
    background (DTU's skull photos at 512 px: holes of a fifth of the skull in three views, which carve a notch
    into every view's hull), while a hole through an object (a mug's handle) shows the floor or what stands
    behind, in colour. ``image`` ``(H, W, 3)`` uint8 at the mask's size."""
    labels, n = ndimage.label(~mask)
    if n == 0:
        return mask
    border = np.unique(np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]]))
    clipped = np.asarray(image, np.float32)[..., :3].mean(-1) >= CLIPPED
    index = np.arange(1, n + 1)
    share = ndimage.mean(clipped, labels, index)
    on_floor = ndimage.mean(floor, labels, index) if floor is not None else np.zeros(n)
    fill = index[(share >= HIGHLIGHT_SHARE) & (on_floor < 0.5) & ~np.isin(index, border)]
    return mask | np.isin(labels, fill) if len(fill) else mask


def hull_cut(image: np.ndarray, shadow: np.ndarray, object_uv: np.ndarray, background_uv: np.ndarray,
             band: float, floor: np.ndarray | None = None, off_floor: np.ndarray | None = None) -> np.ndarray:
    """A view's cut seeded by the consistency hull's projection ``shadow`` (probably object), a band of
    ``band`` px around it (probably background), beyond it and on the ``floor`` surely background, with the
    points' seeds; what stands off the floor within the hull's projection (``off_floor``, :mod:`.floor`) is
    surely object (a leg coloured like the floor boards). The result stays within the band."""
    import cv2

    near = ndimage.binary_dilation(shadow, disc(band))
    seeds = np.where(near, cv2.GC_PR_BGD, cv2.GC_BGD).astype(np.uint8)
    seeds[shadow] = cv2.GC_PR_FGD
    if floor is not None:
        seeds[floor & ~ndimage.binary_erosion(shadow, disc(band))] = cv2.GC_BGD
    if off_floor is not None:
        seeds[off_floor & shadow] = cv2.GC_FGD
    cut = grabcut(image, point_seeds(seeds, object_uv, background_uv), ITERS) & near
    return fill_highlights(cut, image, floor)
