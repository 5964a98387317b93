"""The NeuS / IDR layout, in which DTU and BlendedMVS are shipped for neural surface reconstruction (NeuS,
VolSDF, IDR, NEF and EMAP report on DTU):

    SCENE/cameras_sphere.npz   world_mat_i (4×4: K·[R|t] into the images), scale_mat_i (4×4: the unit sphere
                               about the object → world), optionally camera_mat_i and the *_inv inverses
    SCENE/image/000000.png …   the photos, in view order (sorted by name)
    SCENE/mask/000.png …       their masks (white = object), in the same order; optional

A point ``x`` of the unit sphere's frame projects into view ``i`` by ``world_mat_i @ scale_mat_i @ [x, 1]``:
the product's first three rows are decomposed (RQ, as OpenCV's ``decomposeProjectionMatrix``) into the
intrinsics K and the pose R, t of an OpenCV camera in the sphere's frame, where the object fills the unit
sphere. Every matrix and file is checked; a bad one is a one-line :class:`~doodle.errors.SceneError` naming it.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..cameras import Camera
from ..errors import SceneError
from .images import image_size, read_image, read_mask
from .scene import MAX_COORD, Scene, estimate_frame

CAMERAS = "cameras_sphere.npz"
MAX_VIEWS = 10_000
_IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg")


def is_neus(root: Path) -> bool:
    return (root / CAMERAS).is_file() and (root / "image").is_dir()


def _files(folder: Path) -> list[Path]:
    return sorted(p for p in folder.iterdir() if p.is_file() and p.suffix.lower() in _IMAGE_SUFFIXES)


def _matrices(path: Path) -> dict[str, np.ndarray]:
    """The npz file's 4×4 float arrays by name (no pickled objects: ``allow_pickle=False``)."""
    if path.stat().st_size > 64 * 1024 * 1024:
        raise SceneError(f"{path}: larger than 64 MB; not a cameras file")
    try:
        # Opened here, not by np.load: numpy leaves its own handle open when the archive is corrupt.
        with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as npz:
            names = list(npz.files)
            if len(names) > 8 * MAX_VIEWS:
                raise SceneError(f"{path}: {len(names)} arrays; too many for a cameras file")
            out = {}
            for name in names:
                a = npz[name]
                if a.shape != (4, 4) or a.dtype.kind not in "fiu":
                    raise SceneError(f"{path}: {name} is not a 4x4 matrix of numbers (shape {a.shape}, {a.dtype})")
                out[name] = a.astype(np.float64)
    except SceneError:
        raise
    except Exception as exc:  # zipfile raises many kinds for a corrupt archive (NotImplementedError, RuntimeError …)
        why = str(exc).splitlines()[0][:80] if str(exc) else type(exc).__name__
        raise SceneError(f"{path}: not a readable .npz of camera matrices ({why})") from None
    return out


def _positive_scale(S: np.ndarray) -> bool:
    """Whether the 3×3 ``S`` keeps orientation and is far from singular (tested scaled, so tiny units pass)."""
    size = np.abs(S).max()
    return bool(size > 0 and np.linalg.det(S / size) > 1e-12)


def camera_from_projection(P: np.ndarray, width: int, height: int, name: str, where: str) -> Camera:
    """An OpenCV camera from a 3×4 projection matrix ``P = K [R | t]`` (up to scale), for ``width × height``
    images: RQ-decomposed, K's diagonal made positive and R a proper rotation."""
    import cv2

    if not np.isfinite(P).all() or np.abs(P).max() > MAX_COORD:
        raise SceneError(f"{where}: non-finite or huge projection matrix")
    M = P[:, :3]
    size = np.abs(M).max()
    if size == 0 or abs(np.linalg.det(M / size)) < 1e-12:  # scaled first: a tiny P is not singular
        raise SceneError(f"{where}: the projection matrix is singular")
    K, R, c, *_ = cv2.decomposeProjectionMatrix(P)
    c = c[:3, 0] / c[3, 0] if abs(c[3, 0]) > 1e-12 else None
    if c is None or not np.isfinite(c).all():
        raise SceneError(f"{where}: the projection matrix has no finite camera centre")
    K = K / K[2, 2]
    flip = np.diag(np.sign(np.diag(K)))  # K's diagonal positive; the flip moves into R
    K, R = K @ flip, flip @ R
    if np.linalg.det(R) < 0:  # P was given up to a negative scale
        R = -R
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    if not (fx > 0 and fy > 0 and np.isfinite([fx, fy, cx, cy]).all()) or abs(K[0, 1]) > 1e-3 * fx:
        raise SceneError(f"{where}: not a pinhole camera (intrinsics {fx:.3g}, {fy:.3g}, skew {K[0, 1]:.3g})")
    t = -R @ c
    return Camera(float(fx), float(fy), float(cx), float(cy), width, height, R, t, name=name)


def load_neus(root: str | Path, downscale: float = 1.0, size: int | None = None) -> Scene:
    """Load a NeuS/IDR folder (see the module doc): cameras in the unit sphere's frame, the photos, their masks
    when ``mask/`` holds one per photo. ``size``: downscale so the long side is about ``size`` px."""
    root = Path(root)
    cams_path = root / CAMERAS
    mats = _matrices(cams_path)
    n = 0
    while f"world_mat_{n}" in mats:
        n += 1
    if n == 0:
        raise SceneError(f"{cams_path}: no world_mat_0")
    extra = sorted(k for k in mats if re.fullmatch(r"world_mat_\d+", k) and int(k.split("_")[-1]) >= n)
    if extra:
        raise SceneError(f"{cams_path}: {extra[0]} but no world_mat_{n}")
    images = _files(root / "image")
    if len(images) != n:
        raise SceneError(f"{root / 'image'}: {len(images)} images for the {n} cameras of {cams_path.name}")
    mask_dir = root / "mask"
    masks_files = _files(mask_dir) if mask_dir.is_dir() else []
    if masks_files and len(masks_files) != n:
        raise SceneError(f"{mask_dir}: {len(masks_files)} masks for the {n} images")
    cameras, rgbs, masks = [], [], []
    full = None
    for i, path in enumerate(images):
        where = f"{cams_path}: view {i} ({path.name})"
        world = mats[f"world_mat_{i}"]
        scale = mats.get(f"scale_mat_{i}", np.eye(4))
        for key, m in ((f"world_mat_{i}", world), (f"scale_mat_{i}", scale)):
            if not (np.isfinite(m).all() and np.abs(m).max() <= MAX_COORD):
                raise SceneError(f"{where}: non-finite or huge {key}")
        if not np.allclose(scale[3], [0, 0, 0, 1]) or not _positive_scale(scale[:3, :3]):
            raise SceneError(f"{where}: scale_mat_{i} is not a similarity (its last row must be 0 0 0 1, its scale positive)")
        w0, h0 = image_size(path)
        full = full or (w0, h0)
        cam = camera_from_projection((world @ scale)[:3], w0, h0, path.stem, where)
        f = max(downscale, max(w0, h0) / size if size else 1.0, 1.0)
        w, h = max(1, round(w0 / f)), max(1, round(h0 / f))
        if (w, h) != (w0, h0):
            cam = cam.scaled(w / w0)
        rgb, alpha = read_image(path, (cam.width, cam.height))
        cameras.append(cam)
        rgbs.append(rgb)
        masks.append(read_mask(masks_files[i], (cam.width, cam.height)) if masks_files else alpha)
    given = masks if all(m is not None for m in masks) else None
    frame = estimate_frame(cameras, full_size=full, sphere=(np.zeros(3), 1.0))  # the layout's unit sphere
    return Scene(cameras, rgbs, frame, given, None, str(root), images)
