"""Object masks for captures that have none, without learned weights, on any background.

The published line of automatic multi-view object segmentation under the fixation assumption (Campbell et
al., *Automatic object segmentation from calibrated images*, CVMP 2011): what the capture guarantees seeds
per-view colour models, and the views are made to agree on one object.

1. **Where the object is** (:mod:`.region`): the cameras converge on it; it stands on a support, the dominant
   plane among the 3D points (RANSAC), whose points are background; its points are the cluster above the
   support that holds the fixation point. Posed scenes without SfM points get points triangulated with their
   known poses.
2. **First cuts** (:mod:`.cut`): per view, GrabCut seeded by the projected object points (object), the
   projected background points (background) and the object points' outline (probably object).
3. **One object** (:mod:`.hull`): the first cuts vote on a voxel hull above the support; every view is cut again
   seeded by the hull's projection, so a view that disagrees with the others is segmented again with what
   they see, and what only one view took (a patch of floor) goes. What every view took, the hull keeps: the
   carpet seen between legs, coloured and textured like the floor round it, is seeded background in the
   projection (:func:`.cut.background_like`, :func:`.cut.textured_like_floor`), and the overexposed highlights
   a cut gave away are put back (:func:`.cut.fill_highlights`). Thin parts the cuts lose (ears, a tail)
   are put back where the first masks agree on them, and parts standing on the support (a tripod's legs on a
   busy carpet) where every view's floor cue sees them off the floor (:mod:`.thin`).
4. **Plausibility**: masks that cover most of every photo, or that still disagree between views, stop here with
   one line saying to give masks (``--masks DIR``), instead of drawing the floor.

A scene with such masks says so (``Scene.masks_automatic``), and so does a folder they were saved to (its
:data:`MARKER` file): the fit then carves its hull allowing a few views to disagree
(:data:`doodle.scenes.scene.HULL_DISAGREE`), since each of these boundaries may be a pixel or two off. The
marker also holds the views' :func:`fingerprint`: a later fit of the same photos at the same size reads the
saved masks instead of making them again (minutes on a real capture), and masks fixed by hand (no marker, or
saved after it) are used as they are, never made again over.
"""

from __future__ import annotations

import hashlib
import json
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace
from pathlib import Path
from typing import Callable

import numpy as np
from PIL import Image

from ...errors import SceneError
from ..scene import Scene
from .cut import (
    background_like,
    colour_bins,
    histogram,
    hull_cut,
    likely_object,
    view_background,
)
from .floor import blurred, floor_error, floor_pixels
from .hull import FIRST_AGREE, agreement, carve, reach_mask, shadow
from .region import PLANE_TOL, ObjectRegion, in_view, object_region
from .thin import restore_thin_parts, standing_parts

CUT_SIZE = 384
"""px, the long side at which the views are cut (GrabCut's cost grows with the pixel count)."""
MAX_COVER = 0.75
"""Masks covering more than this share of the photos (the median view) did not tell the object from its
surroundings."""
MIN_AGREEMENT = 0.7
"""Masks whose median IoU with the hull's projection is under this disagree between views: no one object."""
REVISION = 6
"""Of how masks are made: part of every saved folder's :func:`fingerprint`, raised when a change makes other
masks from the same photos (2: overexposed holes filled, a textured floor's colours cut from the hull's chunk;
3: the floor cue cuts into the hull's projection only where the colour is the background's; 4: a thin part
joins the body at a base; 5: a support that gave few of the points is found; 6: parts standing on the support
that the cuts lost put back from the floor cue), so a fit after an upgrade makes
them anew instead of reading the last release's."""
MARKER = "doodle-masks.json"
"""In a folder of automatic masks: they are automatic (delete it once fixed by hand)."""

__all__ = ["MARKER", "ObjectRegion", "agreement", "auto_masks", "check_masks", "fingerprint", "fixed_by_hand",
           "object_region", "saved_masks", "with_masks", "write_masks"]


def _resize(a: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """An image (area average) or a mask (bilinear, then thresholded) at ``size = (width, height)``."""
    if a.dtype == bool:
        return np.asarray(Image.fromarray(a.astype(np.uint8) * 255).resize(size, Image.Resampling.BILINEAR)) > 127
    return np.asarray(Image.fromarray(a).resize(size, Image.Resampling.BOX))


def _points(scene: Scene, log: Callable[[str], None]) -> Scene:
    """The scene with 3D points: its own (SfM), or triangulated with its known poses."""
    if scene.points is not None and len(scene.points) >= 10:
        return scene
    from .. import triangulate

    try:
        points, views = triangulate.triangulate_with_views(scene, log=log)
    except SceneError as exc:  # textureless photos: the cameras' fixation alone seeds the object
        log(f"automatic masks: no points ({str(exc).split(': ', 1)[-1]}); seeded where the cameras aim")
        return scene
    return replace(scene, points=points, point_views=views)


def _seeds(k: int, cam, region: ObjectRegion, hidden: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """View ``k``'s seeds: the pixels ``(P, 2)`` of the object points and of the background points it shows.
    A background point shows where its track says the view saw it; without tracks, where it lands off the
    object: outside ``hidden`` (``bool (H, W)``, the hull's projection), or before there is a hull, outside the
    object points' outline grown by a tenth."""
    import cv2

    ouv, ook = in_view(cam, region.object_points)
    ouv = ouv[ook]
    buv, bok = in_view(cam, region.background_points)
    if region.background_views is not None:
        bok &= np.array([k in v for v in region.background_views], bool) if len(bok) else bok
        return ouv, buv[bok]
    buv = buv[bok]
    if hidden is None:
        hidden = np.zeros((cam.height, cam.width), np.uint8)
        if len(ouv) >= 3:
            hull = cv2.convexHull(ouv.astype(np.float32))
            centre = hull.reshape(-1, 2).mean(axis=0)
            cv2.fillConvexPoly(hidden, (centre + 1.1 * (hull.reshape(-1, 2) - centre)).astype(np.int32), 1)
        hidden = hidden.astype(bool)
    H, W = hidden.shape
    u, v = np.clip(buv.astype(int), 0, [W - 1, H - 1]).T
    return ouv, buv[~hidden[v, u]]


def _floor(k: int, cams: list, colours: list[np.ndarray], region: ObjectRegion) -> tuple[np.ndarray, np.ndarray]:
    """View ``k``'s ``(floor, off_floor)`` pixels (:mod:`.floor`): those that show the support, and those whose ray
    meets it where the other views see something else. ``colours``: every view's image blurred
    (:func:`~.floor.blurred`)."""
    error = floor_error(k, cams, colours, region)
    on = np.abs(region.height(region.background_points)) <= PLANE_TOL * region.radius
    uv, ok = in_view(cams[k], region.background_points[on])
    return floor_pixels(error, uv[ok])


def check_masks(masks: list[np.ndarray], agree: np.ndarray, source: str) -> None:
    """Refuse masks that did not find one object (see :data:`MAX_COVER`, :data:`MIN_AGREEMENT`)."""
    cover = float(np.median([m.mean() for m in masks]))
    if cover > MAX_COVER:
        raise SceneError(f"{source}: the automatic masks cover {cover:.0%} of the photos, so the object was not "
                         "told from its surroundings; give masks with --masks DIR (white = object)")
    if float(np.median(agree)) < MIN_AGREEMENT:
        raise SceneError(f"{source}: the automatic masks disagree between views (median IoU "
                         f"{float(np.median(agree)):.2f} with the object the others see); give masks with --masks DIR "
                         "(white = object)")


def auto_masks(scene: Scene, log: Callable[[str], None] = print, rounds: int = 2) -> list[np.ndarray]:
    """Object masks ``bool (H, W)`` for every view of ``scene`` (at its images' sizes); see the module doc.

    Raises:
        SceneError: when no object is found, or the masks fail the plausibility check.
    """
    from ...workers import cpu_count

    region = object_region(_points(scene, log))
    cams, images = [], []
    for cam, img in zip(scene.cameras, scene.images):
        f = min(1.0, CUT_SIZE / max(cam.width, cam.height))
        c = cam.scaled(f) if f < 1 else cam
        cams.append(c)
        images.append(_resize(img, (c.width, c.height)) if f < 1 else img)
    seeds = [_seeds(k, c, region) for k, c in enumerate(cams)]
    colours = histogram(np.concatenate([colour_bins(img)[np.clip(uv[:, 1].astype(int), 0, img.shape[0] - 1),
                                                             np.clip(uv[:, 0].astype(int), 0, img.shape[1] - 1)]
                                        for img, (uv, _) in zip(images, seeds)]))
    reach = [~reach_mask(c, region, img.shape[:2]) for c, img in zip(cams, images)]
    # no support and hardly a background point: the photos' edges are the background's best sample
    edge = region.plane is None and len(region.background_points) < 20
    backgrounds = [view_background(img, r, s[1], edge) for img, r, s in zip(images, reach, seeds)]
    unlike = [background_like(img, colours, b) for img, b in zip(images, backgrounds)]
    with ThreadPoolExecutor(min(cpu_count(), 8)) as pool:  # GrabCut releases the GIL
        blurs = list(pool.map(blurred, images))
        floors = list(pool.map(lambda k: _floor(k, cams, blurs, region), range(len(cams))))
        masks = list(pool.map(lambda k: likely_object(images[k], colours, seeds[k][0], reach[k], backgrounds[k],
                                                      floors[k][1]), range(len(cams))))
        first = masks
        for _ in range(rounds):
            hull = carve(cams, masks, region, agree=FIRST_AGREE)
            if not hull.occupied.any():
                raise SceneError(f"{scene.source}: the automatic masks disagree between views (no object all of "
                                 "them see); give masks with --masks DIR (white = object)")
            shadows = [shadow(c, hull, m.shape) for c, m in zip(cams, masks)]
            if region.background_views is None:  # background points the hull hides in a view seed nothing there
                seeds = [_seeds(k, c, region, s) for k, (c, s) in enumerate(zip(cams, shadows))]
            band = max(2.0, 0.03 * CUT_SIZE)
            masks = list(pool.map(lambda k: hull_cut(images[k], shadows[k], *seeds[k], band, floors[k][0],
                                                     unlike=unlike[k]), range(len(cams))))
    final = carve(cams, masks, region)
    agree = agreement(masks, [shadow(c, final, m.shape) for c, m in zip(cams, masks)])
    log(f"automatic masks: {len(region.object_points)} object points, "
        f"{'a support plane and ' if region.plane is not None else ''}{len(region.background_points)} background "
        f"points; object covers {100 * np.mean([m.mean() for m in masks]):.0f}% of the image on average, views "
        f"agree (IoU with the hull) {np.median(agree):.2f} in the median")
    check_masks(masks, agree, scene.source)  # before more is spent on masks that found no object
    masks, thin = restore_thin_parts(cams, first, masks, region, final)
    if thin:
        log(f"automatic masks: thin parts the cuts lost put back ({thin} voxels)")
    if region.plane is not None:
        masks, stood = standing_parts(cams, first, masks, region, [off for _, off in floors])
        if stood:
            log(f"automatic masks: parts standing on the support that the cuts lost put back ({stood} voxels)")
    return [_resize(m, (full.shape[1], full.shape[0])) if m.shape != full.shape[:2] else m
            for m, full in zip(masks, scene.images)]


def fingerprint(scene: Scene) -> str:
    """A digest of what automatic masks are made from: each view's name, pose, intrinsics and pixels as loaded
    (another photo, another ``--size``, a new SfM run each change it), and the doodle release and mask
    :data:`REVISION` that made them."""
    from ... import __version__

    h = hashlib.blake2b(digest_size=16)
    h.update(f"{__version__} masks {REVISION}".encode())
    for cam, img in zip(scene.cameras, scene.images):
        h.update(f"{cam.name}|{cam.fx},{cam.fy},{cam.cx},{cam.cy},{cam.width},{cam.height}|{img.shape}|{img.dtype}"
                 .encode())
        h.update(np.asarray(cam.R, np.float64).tobytes() + np.asarray(cam.t, np.float64).tobytes())
        h.update(np.ascontiguousarray(img).tobytes())
    return h.hexdigest()


def write_masks(scene: Scene, masks: list[np.ndarray], folder: Path) -> Path:
    """Save masks as ``FOLDER/NAME.png`` (white = object), one per view, named after the view's image, each
    written atomically, and the :data:`MARKER` that says they are automatic and what they were made from."""
    from ...atomic import atomic_path, write_text

    folder.mkdir(parents=True, exist_ok=True)
    for cam, m in zip(scene.cameras, masks):
        with atomic_path(folder / f"{cam.name}.png") as tmp:
            Image.fromarray(m.astype(np.uint8) * 255).save(tmp, format="PNG")
    write_text(folder / MARKER, json.dumps({"masks": "automatic", "made_by": "doodle", "views": fingerprint(scene),
                                            "note": "delete this file once the masks are fixed by hand"}, indent=1) + "\n")
    return folder


def _mask_files(folder: Path) -> list[Path]:
    return [p for p in folder.iterdir() if p.suffix.lower() in (".png", ".jpg", ".jpeg")] if folder.is_dir() else []


def fixed_by_hand(folder: Path) -> bool:
    """Whether ``folder`` holds masks fixed by hand: masks without the :data:`MARKER`, or one saved after it
    (the marker left in place). Such masks are read as they are and never made again over."""
    files = _mask_files(folder)
    marker = folder / MARKER
    return bool(files) and (not marker.is_file() or max(p.stat().st_mtime for p in files) > marker.stat().st_mtime + 1.0)


def saved_masks(scene: Scene, folder: Path) -> tuple[list[np.ndarray], bool] | None:
    """The masks saved in ``folder`` for ``scene``, and whether they are automatic; ``None`` when there are none
    to use: no folder, a mask missing, or automatic masks made from other views (:func:`fingerprint`). Masks
    fixed by hand (no :data:`MARKER`, or a mask saved after it) are used whatever they were made from.

    Raises:
        SceneError: masks fixed by hand that lack a view's mask.
    """
    from ..images import read_mask_folder

    if not _mask_files(folder):
        return None
    automatic = not fixed_by_hand(folder)
    if automatic:
        try:
            made_from = json.loads((folder / MARKER).read_text()).get("views")
        except (OSError, ValueError, AttributeError):
            return None
        if made_from != fingerprint(scene):
            return None
    try:
        masks = read_mask_folder(folder, [c.name for c in scene.cameras], [(c.width, c.height) for c in scene.cameras])
    except SceneError as exc:
        if automatic:  # one deleted: all are made again
            return None
        raise SceneError(f"{str(exc).splitlines()[0]}; these masks were fixed by hand: add the missing ones, or "
                         "delete the folder to make automatic masks again") from None
    return masks, automatic


def with_masks(scene: Scene, how: str | Path = "auto", auto_dir: Path | None = None,
               log: Callable[[str], None] = print) -> Scene:
    """The scene with the masks ``how`` asks for: ``"auto"`` keeps the scene's own masks (alpha, a masks
    folder), else reads those saved in ``auto_dir`` (:func:`saved_masks`: made for these views, or fixed by
    hand), else makes them (:func:`auto_masks`) and saves them there for inspection; ``"none"`` drops them;
    anything else is a folder of masks, one ``NAME.png`` per view (automatic if it holds the :data:`MARKER`
    file)."""
    from ..images import read_mask_folder

    if str(how) == "none":
        return replace(scene, masks=None, masks_automatic=False)
    if str(how) != "auto":
        masks = read_mask_folder(Path(how), [c.name for c in scene.cameras], [(c.width, c.height) for c in scene.cameras])
        automatic = (Path(how) / MARKER).is_file()
        if scene.lens is not None and not automatic:  # drawn on the photos: into the undistorted views
            masks = [m if f is None else f(m) for m, f in zip(masks, scene.lens)]
        log(f"masks from {how}{' (automatic)' if automatic else ''}: object covers "
            f"{100 * np.mean([m.mean() for m in masks]):.0f}% of the image on average")
        return replace(scene, masks=masks, masks_automatic=automatic)
    if scene.masks is not None:
        return scene
    saved = saved_masks(scene, auto_dir) if auto_dir is not None else None
    if saved is not None:
        masks, automatic = saved
        made = "automatic, made before from these views; delete it to make them again" if automatic else "fixed by hand"
        log(f"masks from {auto_dir} ({made})")
        return replace(scene, masks=masks, masks_automatic=automatic)
    masks = auto_masks(scene, log)
    if auto_dir is not None:
        try:
            write_masks(scene, masks, auto_dir)
            log(f"automatic masks written to {auto_dir} (later fits read them; `doodle masks --sheet` draws them "
                "over the photos; fix any by hand)")
        except OSError as exc:
            log(f"warning: cannot write the automatic masks to {auto_dir} ({exc.strerror or exc})")
    return replace(scene, masks=masks, masks_automatic=True)
