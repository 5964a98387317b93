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
#: A pixel of the hull's projection is seeded probably background when its colour is at least this many times
#: likelier in the view's background than among the object's points (:func:`background_like`) and it is as
#: textured as a textured floor round it (:func:`textured_like_floor`). Carpet captures' masks (IoU with the
#: truth) without the cue: cow 0.923, calf 0.922; at odds 1 (colour alone): 0.971, 0.955, but DTU's skull
#: photos 0.973 → 0.965 (the back of its cranium, in shade, is as brown as the table); at odds 3 with the
#: texture test: 0.961, 0.955, DTU 0.973 (a plain table: the cue says nothing).
BACKGROUND_ODDS = 3.0
#: The floor round the hull's projection is textured (a carpet, not a plain table) when the median spread of
#: its grey levels (standard deviation over 5 × 5 px at the cut size, 8-bit) is at least this: the carpets
#: measure about 20, DTU's table 3 ...
TEXTURED_FLOOR = 6.0
#: ... and a pixel is as textured as that floor when its own spread is at least this share of the floor's (the
#: carpet between a calf's legs measures about the floor's, a smooth shaded flank a tenth of it).
TEXTURE_SHARE = 0.25
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


def overexposed(image: np.ndarray) -> np.ndarray:
    """``bool (H, W)``: the pixels of ``image`` ``(H, W, 3)`` clipped to white (channels averaging at least
    :data:`CLIPPED`), which have no colour to judge."""
    return np.asarray(image, np.float32)[..., :3].mean(-1) >= CLIPPED


def view_background(image: np.ndarray, surely_not: np.ndarray, background_uv: np.ndarray, edge: bool = False
                    ) -> np.ndarray:
    """The colour histogram (:func:`histogram`) of one view's background: the pixels ``surely_not``
    (``bool (H, W)``, beyond the object's reach) and where the background points land ``(P, 2)``, with the
    photo's edge when ``edge`` and these are few (an object is framed by its photos); uniform when none."""
    bins = colour_bins(image)
    bg_pixels = np.concatenate([bins[surely_not], bins[_marks(bins.shape, background_uv, 1.0)]])
    if edge and len(bg_pixels) < 0.05 * bins.size:  # little known background: the photo's edge is
        frame = np.ones(bins.shape, bool)
        w = max(2, round(0.02 * max(bins.shape)))
        frame[w:-w, w:-w] = False
        bg_pixels = np.concatenate([bg_pixels, bins[frame]])
    return histogram(bg_pixels) if len(bg_pixels) else np.full(BINS ** 3, 1.0 / BINS ** 3)


def background_like(image: np.ndarray, object_colours: np.ndarray, background: np.ndarray) -> np.ndarray:
    """``bool (H, W)``: the pixels of a colour common in the view's ``background`` (a histogram, above a uniform
    one's density) and at least :data:`BACKGROUND_ODDS` times likelier there than among the object points'
    ``object_colours``, and not overexposed (:data:`CLIPPED`: a clipped highlight has no colour). Within the
    hull's projection these are the floor the hull's chunk between a calf's legs holds in every view."""
    bins = colour_bins(image)
    return (BACKGROUND_ODDS * object_colours[bins] < background[bins]) & (background[bins] > 1.0 / BINS ** 3) \
        & ~overexposed(image)


def likely_object(image: np.ndarray, object_colours: np.ndarray, object_uv: np.ndarray, surely_not: np.ndarray,
                  background: np.ndarray, off_floor: np.ndarray | None = None) -> np.ndarray:
    """A generous first mask of one view: the pixels whose colour the object's points show more often than
    the view's background does, or that the background hardly shows (:data:`RARE`), connected to where the
    object's points land, with the points' outline.

    ``object_colours``: the histogram of the object points' colours over all the views (a smooth part without
    a point, a cranium, has the colour of the parts that have them); ``background``: the view's
    (:func:`view_background`); ``surely_not``: ``bool (H, W)``, the pixels that cannot be the object (beyond its
    reach). ``off_floor``: the pixels whose ray meets the support where the other views see something
    else (:mod:`.floor`), object by that alone (a dark leg on a dark carpet). The mask errs towards the object:
    the views' hull takes away what they disagree on."""
    import cv2

    bins = colour_bins(image)
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


def _spread(grey: np.ndarray, size: int = 5) -> np.ndarray:
    """``float32 (H, W)``: the standard deviation of ``grey`` over ``size`` × ``size`` px about each pixel."""
    mean = ndimage.uniform_filter(grey, size)
    return np.sqrt(np.maximum(ndimage.uniform_filter(grey * grey, size) - mean * mean, 0.0))


def textured_like_floor(image: np.ndarray, shadow: np.ndarray, near: np.ndarray) -> np.ndarray:
    """``bool (H, W)``: the pixels of the hull's projection ``shadow`` as textured as the floor round it (the band
    ``near`` less ``shadow``; see :data:`TEXTURE_SHARE`) when that floor is textured (:data:`TEXTURED_FLOOR`);
    none round a plain floor. A carpet seen through the hull's chunk between legs keeps its texture, while the
    object's smooth faces, however their colour matches the floor in shade, do not; round a plain floor, the
    colour models alone already tell the object from it."""
    spread = _spread(np.asarray(image, np.float32)[..., :3].mean(-1))
    ring = near & ~shadow
    typical = float(np.median(spread[ring])) if ring.any() else 0.0
    if typical < TEXTURED_FLOOR:
        return np.zeros(shadow.shape, bool)
    return shadow & (spread >= TEXTURE_SHARE * typical)


def fill_highlights(mask: np.ndarray, image: np.ndarray, floor: np.ndarray | None = None,
                    within: np.ndarray | None = None, around: np.ndarray | None = None) -> np.ndarray:
    """``mask`` with the overexposed regions it leaves out put back: its holes at least :data:`HIGHLIGHT_SHARE`
    overexposed (:data:`CLIPPED`), and with ``within`` (the hull's projection) its overexposed pixels that touch
    the mask, where the ``floor`` cue (:mod:`.floor`) sees no support. Those open to the outside are put back
    only while the background ``around`` ``within`` (a band round it) is hardly overexposed (under a tenth):
    before a white backdrop, white is the background's colour.

    A clipped highlight has no colour: GrabCut's colour models may give a polished cranium's white patch to the
    background (DTU's skull photos at 512 px: holes of a fifth of the skull in three views, and at the
    outline, where the highlight meets the silhouette, in others; either carves a notch into every view's
    hull), while a hole through an object (a mug's handle) shows the floor or what stands behind, in colour.
    ``image`` ``(H, W, 3)`` uint8 at the mask's size."""
    clipped = overexposed(image)

    def off_floor(labels: np.ndarray, index: np.ndarray) -> np.ndarray:
        """Which of the regions ``index`` the floor cue holds under half of."""
        return ndimage.mean(floor, labels, index) < 0.5 if floor is not None else np.ones(len(index), bool)

    labels, n = ndimage.label(~mask)
    if n == 0:
        return mask
    border = np.unique(np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]]))
    index = np.arange(1, n + 1)
    share = ndimage.mean(clipped, labels, index)
    fill = index[(share >= HIGHLIGHT_SHARE) & off_floor(labels, index) & ~np.isin(index, border)]
    out = mask | np.isin(labels, fill) if len(fill) else mask.copy()
    if within is not None and (around is None or not around.any() or clipped[around].mean() < 0.1):
        # the overexposed pixels of the hull's projection the mask left out, where they touch it
        labels, n = ndimage.label(within & clipped & ~out)
        if n:
            index = np.arange(1, n + 1)
            touching = ndimage.maximum(ndimage.binary_dilation(out), labels, index) > 0
            out |= np.isin(labels, index[touching & off_floor(labels, index)])
    return out


def hull_cut(image: np.ndarray, shadow: np.ndarray, object_uv: np.ndarray, background_uv: np.ndarray,
             band: float, floor: np.ndarray | None = None, off_floor: np.ndarray | None = None,
             unlike: np.ndarray | None = None) -> np.ndarray:
    """A view's cut seeded by the consistency hull's projection ``shadow`` (probably object, except where it is
    coloured like the background, ``unlike`` (:func:`background_like`), and textured like a textured floor
    round it, :func:`textured_like_floor`), a band of ``band`` px around it
    (probably background), beyond it and on the ``floor`` surely background, with the points' seeds; what
    stands off the floor within the hull's projection (``off_floor``, :mod:`.floor`) is surely object (a leg
    coloured like the floor boards). The result stays within the band, its overexposed holes filled
    (:func:`fill_highlights`)."""
    import cv2

    near = ndimage.binary_dilation(shadow, disc(band))
    seeds = np.where(near, cv2.GC_PR_BGD, cv2.GC_BGD).astype(np.uint8)
    seeds[shadow] = cv2.GC_PR_FGD
    if unlike is not None:
        seeds[shadow & unlike & textured_like_floor(image, shadow, near)] = cv2.GC_PR_BGD
    if floor is not None:
        # Within the projection, only where it is coloured like the background too: the object's own faces
        # just above the support agree with the floor under them (the other views see the same face there),
        # and the cue alone cut a box's lower face off (the carpet parcel's masks IoU 0.971 → 0.977).
        rim = floor & ~ndimage.binary_erosion(shadow, disc(band))
        if unlike is not None:
            rim &= ~shadow | unlike
        seeds[rim] = cv2.GC_BGD
    if off_floor is not None:
        seeds[off_floor & shadow] = cv2.GC_FGD
    cut = grabcut(image, point_seeds(seeds, object_uv, background_uv), ITERS) & near
    return fill_highlights(cut, image, floor, shadow, near & ~shadow)
