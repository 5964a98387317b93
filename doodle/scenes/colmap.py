"""COLMAP models through pycolmap: ``sparse/0`` (binary or text) + image folder, optional ``masks/``.

COLMAP poses are already world-to-camera in the OpenCV convention, so no axis conversion happens here.
Lens distortion (SIMPLE_RADIAL, RADIAL, OPENCV, FULL_OPENCV, …) is removed on load: every image is resampled
to the pinhole camera with the model's focal lengths and principal point, through pycolmap's own model, so
that projections are exact. Fisheye models are refused. Images are read as COLMAP read them: raw pixels,
EXIF orientation not applied (an image whose size only matches its camera once EXIF-rotated is rotated).
"""

from __future__ import annotations

import os
import re
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from functools import partial
from pathlib import Path

import numpy as np

from ..cameras import Camera
from ..errors import SceneError
from .colmap_binary import check_binary_model
from .images import read_image, read_mask, scene_path
from .scene import MAX_COORD, Scene, estimate_frame

MODEL_FILES = ("cameras.bin", "cameras.txt")
PINHOLE_MODELS = ("SIMPLE_PINHOLE", "PINHOLE")
MAX_IMAGE_SIDE = 1 << 17  # px: larger than any camera made
MIN_FOCAL_PX = 1e-3
MIN_POINTS = 200  # SfM points seen in 3+ photos needed before those seen in 2 are left out


#: A glog line of COLMAP's below ERROR (``I1123 12:00:00.000 123 file.cc:46] …``, date with or without the year).
_GLOG_CHATTER = re.compile(r"^[IW]\d{4}(\d{4})? \d\d:\d\d:\d\d")


@contextmanager
def quiet_pycolmap() -> Iterator[None]:
    """Keep COLMAP's own log (thousands of INFO lines per reconstruction, and a warning about threads on
    every run) off the terminal; errors still show. doodle prints its own one-line summaries, and failures
    become one-line errors.

    Raising glog's level silences most of it, but some calls (pycolmap's bundle adjustment) log whatever the
    level, so the process's stderr is also caught while pycolmap runs, and all but glog's INFO and WARNING
    lines are passed on afterwards."""
    import pycolmap

    before = pycolmap.logging.minloglevel
    pycolmap.logging.minloglevel = int(pycolmap.logging.ERROR)
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with tempfile.TemporaryFile() as sink:
            os.dup2(sink.fileno(), 2)
            try:
                yield
            finally:
                sys.stderr.flush()
                os.dup2(saved, 2)
                sink.seek(0)
                kept = [ln for ln in sink.read().decode(errors="replace").splitlines() if not _GLOG_CHATTER.match(ln)]
                if kept:
                    sys.stderr.write("\n".join(kept) + "\n")
    finally:
        os.close(saved)
        pycolmap.logging.minloglevel = before


def find_model_dir(root: Path) -> Path | None:
    """The folder holding ``cameras.{bin,txt}``: ``root``, ``root/sparse/0`` or ``root/sparse``."""
    for cand in (root, root / "sparse" / "0", root / "sparse"):
        if any((cand / f).exists() for f in MODEL_FILES):
            return cand
    return None


def load_colmap(root: str | Path, images_dir: str | Path | None = None, masks_dir: str | Path | None = None,
                downscale: float = 1.0, size: int | None = None) -> Scene:
    """Load a COLMAP reconstruction.

    Args:
        root: the project folder (with ``sparse/0`` and ``images/``) or the model folder itself.
        images_dir: image folder; default ``root/images``.
        masks_dir: optional masks (``NAME.png`` or ``NAME`` + ``.png``, COLMAP's convention); default
            ``root/masks`` when it exists.
        downscale: divide the image size by this factor.
        size: instead, downscale each image so its larger side is about ``size`` px (never enlarged);
            views of different sizes get their own factors.
    """
    root = Path(root)
    model_dir = find_model_dir(root)
    if model_dir is None:
        raise SceneError(f"{root}: no COLMAP model (cameras.bin/.txt) in it or in sparse/0")
    check_binary_model(model_dir)
    rec, ids, pts, views = _read_model(model_dir)
    images_dir = Path(images_dir) if images_dir else root / "images"
    if masks_dir is None and (root / "masks").is_dir():
        masks_dir = root / "masks"
    cameras, images, masks, paths, lens = [], [], [], [], []
    for image_id in ids:
        im = rec.image(image_id)
        cam = rec.camera(im.camera_id)
        pose = im.cam_from_world()
        R = np.asarray(pose.rotation.matrix(), dtype=np.float64)
        t = np.asarray(pose.translation, dtype=np.float64)
        _check_model(cam, model_dir)
        _check_pose(R, t, im.name, model_dir)
        if size is not None:
            downscale = max(1.0, max(cam.width, cam.height) / size)
        w, h = max(1, round(cam.width / downscale)), max(1, round(cam.height / downscale))
        sx, sy = w / cam.width, h / cam.height
        path = scene_path(images_dir, im.name, f"{model_dir}: image name")
        rgb, mask = read_image(path, (w, h), expect=(cam.width, cam.height))
        if cam.model.name not in PINHOLE_MODELS:
            rgb, mask = undistort(rgb, mask, cam, (w, h))
        if masks_dir is not None:
            cands = [Path(masks_dir) / (im.name + ".png"), Path(masks_dir) / im.name,
                     Path(masks_dir) / (Path(im.name).stem + ".png")]
            found = next((c for c in cands if c.exists()), None)
            if found is None:
                raise SceneError(f"{masks_dir}: no mask for image {im.name}")
            mask = read_mask(found, (w, h))
            if cam.model.name not in PINHOLE_MODELS:
                mask = undistort(None, mask, cam, (w, h))[1]
        cameras.append(Camera(cam.focal_length_x * sx, cam.focal_length_y * sy, cam.principal_point_x * sx,
                              cam.principal_point_y * sy, w, h, R, t, name=Path(im.name).stem))
        images.append(rgb)
        masks.append(mask)
        paths.append(path)
        lens.append(None if cam.model.name in PINHOLE_MODELS else partial(undistort_mask, cam))
    has_masks = all(m is not None for m in masks)
    c0 = rec.camera(rec.image(ids[0]).camera_id)
    frame = estimate_frame(cameras, points=pts if len(pts) else None, full_size=(c0.width, c0.height))
    return Scene(cameras, images, frame, masks if has_masks else None, pts if len(pts) else None, str(root), paths,
                 point_views=views if len(pts) and views is not None else None,
                 lens=lens if any(f is not None for f in lens) else None)


def _read_model(model_dir: Path):
    """``(reconstruction, registered image ids sorted by name, points (P, 3), each point's views)``, or a
    one-line error. A point's views are the indices (in that order) of the images that observed it; ``None``
    for a model without tracks (a text model may list none).

    pycolmap raises bare RuntimeErrors/ValueErrors for unreadable models, and for inconsistent ones (a frame
    naming a missing image) only when they are first touched, so everything is touched here once."""
    import pycolmap

    try:
        rec = pycolmap.Reconstruction(str(model_dir))
        ids = sorted(rec.reg_image_ids(), key=lambda i: rec.image(i).name)
        for i in ids:
            rec.camera(rec.image(i).camera_id)
        pts = np.array([p.xyz for p in rec.points3D.values()], dtype=np.float64).reshape(-1, 3)
        tracks = np.array([p.track.length() for p in rec.points3D.values()], dtype=np.int64)
        index = {image_id: k for k, image_id in enumerate(ids)}
        views = [np.unique([index[e.image_id] for e in p.track.elements if e.image_id in index]).astype(np.int64)
                 for p in rec.points3D.values()]
    except Exception as exc:  # pycolmap raises bare RuntimeErrors/ValueErrors (and may raise others)
        why = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise SceneError(f"{model_dir}: cannot read COLMAP model ({why})") from None
    if not ids:
        raise SceneError(f"{model_dir}: the COLMAP model has no registered images")
    if not (np.isfinite(pts).all() and np.abs(pts).max(initial=0) <= MAX_COORD):
        raise SceneError(f"{model_dir}: the COLMAP model has non-finite or huge 3D points")
    keep = reliable_points(tracks)
    return rec, ids, pts[keep], ([views[k] for k in np.flatnonzero(keep)] if tracks.any() else None)


def reliable_points(track_lengths: np.ndarray, min_points: int = MIN_POINTS) -> np.ndarray:
    """Which SfM points to keep ``(P,)``: not those seen in fewer than 3 photos, when at least ``min_points``
    remain.

    Two-photo points are the ones a chance match makes (on the composited Lego photos, 165 of the 234 points
    floating off the object); a model without tracks (``track_lengths`` 0) keeps all its points."""
    sure = track_lengths >= 3
    return sure if sure.sum() >= min_points else np.ones(len(track_lengths), bool)


def _check_model(cam, model_dir: Path) -> None:
    """Refuse cameras doodle cannot turn into a pinhole view: fisheye or unknown models, and sizes or
    parameters no camera has, for binary and text models alike (the binary walk checks only the layout)."""
    if cam.is_perspective_fisheye() if hasattr(cam, "is_perspective_fisheye") else "FISHEYE" in cam.model.name:
        raise SceneError(f"{model_dir}: camera model {cam.model.name} (fisheye) is not supported; "
                         "undistort the images first (colmap image_undistorter) and give that model")
    if cam.model.name not in PINHOLE_MODELS and not cam.is_perspective():
        raise SceneError(f"{model_dir}: camera model {cam.model.name} is not supported")
    if not (1 <= cam.width <= MAX_IMAGE_SIDE and 1 <= cam.height <= MAX_IMAGE_SIDE):
        raise SceneError(f"{model_dir}: camera {cam.camera_id} has image size {cam.width} x {cam.height}")
    params = np.asarray(cam.params, dtype=np.float64)
    if not (np.isfinite(params).all() and np.abs(params).max(initial=0) <= MAX_COORD):
        raise SceneError(f"{model_dir}: camera {cam.camera_id} has non-finite or huge parameters")
    # a focal length far below a pixel is no camera; it would overflow the undistortion's ray directions
    if not (cam.focal_length_x >= MIN_FOCAL_PX and cam.focal_length_y >= MIN_FOCAL_PX):
        focal = min(cam.focal_length_x, cam.focal_length_y)
        raise SceneError(f"{model_dir}: camera {cam.camera_id} has focal length {focal} px (below {MIN_FOCAL_PX} px)")


def _check_pose(R: np.ndarray, t: np.ndarray, name: str, model_dir: Path) -> None:
    """A pose must be a finite rotation and a translation within the scene's reach."""
    if not (np.isfinite(R).all() and np.isfinite(t).all() and np.abs(t).max() <= MAX_COORD
            and np.abs(R).max() <= 1 + 1e-3 and abs(np.linalg.det(R) - 1) < 1e-3):  # (entries first: no det overflow)
        raise SceneError(f"{model_dir}: image {name} has an invalid pose (rotation or translation)")


def undistort_mask(cam, mask: np.ndarray) -> np.ndarray:
    """A mask drawn on a photo taken through COLMAP camera ``cam`` (resized to any size), resampled to the
    pinhole view :func:`undistort` makes of that photo at the mask's size."""
    return undistort(None, mask, cam, (mask.shape[1], mask.shape[0]))[1]


def undistort(rgb: np.ndarray | None, mask: np.ndarray | None, cam, size: tuple[int, int]
              ) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Resample an image (and mask) taken through COLMAP camera ``cam`` to its pinhole part.

    ``rgb (h, w, 3)`` and ``mask (h, w)`` are the distorted image already resized to ``size = (w, h)``; the
    result has the same size and shows what a pinhole camera with ``cam``'s focal lengths and principal point
    (scaled to ``size``) sees. Pixels that come from outside the photo are white in the image; the mask there
    continues the photo's edge: an object that runs out of the photo runs out of the pinhole view too, instead
    of ending a pixel short of its frame — where the hull would carve it away (the frame is no outline; DTU's
    skull, cut by the frame in 35 of its 49 photos) and the metrics would count an outline no view shows.
    """
    from scipy import ndimage

    w, h = size
    sx, sy = w / cam.width, h / cam.height
    fx, fy = cam.focal_length_x * sx, cam.focal_length_y * sy
    cx, cy = cam.principal_point_x * sx, cam.principal_point_y * sy
    uu, vv = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    rays = np.stack([(uu.ravel() - cx) / fx, (vv.ravel() - cy) / fy, np.ones(uu.size)], 1)
    src = np.asarray(cam.img_from_cam(rays, False), dtype=np.float64).reshape(h, w, 2)
    coords = [src[..., 1] * sy - 0.5, src[..., 0] * sx - 0.5]  # (row, col) in the resized distorted image
    out_rgb = out_mask = None
    if rgb is not None:
        out_rgb = np.stack([ndimage.map_coordinates(rgb[..., c].astype(np.float32), coords, order=1, cval=255.0)
                            for c in range(rgb.shape[2])], -1)
        out_rgb = np.clip(out_rgb + 0.5, 0, 255).astype(np.uint8)
    if mask is not None:
        out_mask = ndimage.map_coordinates(mask.astype(np.float32), coords, order=1, mode="nearest") > 0.5
    return out_rgb, out_mask
