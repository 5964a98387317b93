"""Parsers for ``transforms*.json`` folders: NeRF-synthetic (Blender) and nerfstudio.

Both store camera-to-world matrices in the Blender/OpenGL convention (x right, y up, z backward). The one
conversion to doodle's OpenCV convention happens here: ``c2w_cv = c2w_gl @ diag(1, −1, −1, 1)``.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from ..cameras import Camera
from ..errors import SceneError
from .images import image_size, read_image, read_mask, scene_path
from .scene import MAX_COORD, Scene, estimate_frame

GL_TO_CV = np.diag([1.0, -1.0, -1.0, 1.0])
SPLITS = ("train", "val", "test")


def _read_json(path: Path) -> dict:
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise SceneError(f"{path}: not found") from None
    except (ValueError, OSError) as exc:
        raise SceneError(f"{path}: not valid JSON ({str(exc).splitlines()[0]})") from None
    except RecursionError:
        raise SceneError(f"{path}: not valid JSON (nested too deeply)") from None
    if not isinstance(data, dict) or not isinstance(data.get("frames"), list) or not data["frames"]:
        raise SceneError(f"{path}: expected an object with a non-empty 'frames' list")
    return data


def _pose(frame: Any, path: Path, i: int) -> tuple[np.ndarray, np.ndarray]:
    """World-to-camera (R, t) from a frame's Blender ``transform_matrix``."""
    try:
        c2w = np.asarray(frame["transform_matrix"], dtype=np.float64)
    except (KeyError, TypeError, ValueError, OverflowError, RecursionError):
        raise SceneError(f"{path}: frames[{i}].transform_matrix missing or not a 4x4 matrix") from None
    if c2w.shape not in ((4, 4), (3, 4)) or not np.isfinite(c2w).all() or np.abs(c2w).max() > MAX_COORD:
        raise SceneError(f"{path}: frames[{i}].transform_matrix must be a finite 4x4 matrix (entries within ±1e9)")
    if c2w.shape == (3, 4):
        c2w = np.vstack([c2w, [0, 0, 0, 1]])
    c2w_cv = c2w @ GL_TO_CV
    R_c2w = c2w_cv[:3, :3]
    # Orthonormalise: Blender exports carry float32 round-off; nerfstudio may carry a scale.
    U, _, Vt = np.linalg.svd(R_c2w)
    R = (U @ Vt).T
    return R, -R @ c2w_cv[:3, 3]


def _image_path(root: Path, file_path: str, where: str = "") -> Path:
    p = scene_path(root, file_path, where or str(root))
    if p.suffix.lower() in (".png", ".jpg", ".jpeg", ".exr", ".webp"):
        return p
    for ext in (".png", ".jpg", ".jpeg"):  # NeRF-synthetic omits the extension
        if p.with_name(p.name + ext).exists():
            return p.with_name(p.name + ext)
    return p.with_name(p.name + ".png")


def load_nerf_synthetic(root: str | Path, split: str = "train", downscale: float = 1.0,
                        with_images: bool = True) -> Scene:
    """Load a NeRF-synthetic folder (``transforms_{split}.json``; the images' alpha is the mask, and RGB images
    have none: ``masks`` is ``None`` and automatic masks are made for them).

    ``fx = 0.5 · width / tan(0.5 · camera_angle_x)``; world up is +z. ``with_images=False`` reads only the
    first image's size (for drawing the dataset's cameras).
    """
    root = Path(root)
    if split not in SPLITS:
        raise SceneError(f"{root}: unknown split {split!r} (choose from {', '.join(SPLITS)})")
    path = root / f"transforms_{split}.json"
    data = _read_json(path)
    angle = data.get("camera_angle_x")
    if isinstance(angle, bool) or not isinstance(angle, (int, float)) or not 1e-3 <= angle <= math.pi - 1e-3:
        raise SceneError(f"{path}: camera_angle_x missing or not an angle in (0, pi) radians")
    cameras, images, masks, paths = [], [], [], []
    for i, fr in enumerate(data["frames"]):
        if not isinstance(fr, dict) or not isinstance(fr.get("file_path"), str):
            raise SceneError(f"{path}: frames[{i}].file_path missing")
        img_path = _image_path(root, fr["file_path"], f"{path}: frames[{i}].file_path")
        R, t = _pose(fr, path, i)
        if i == 0 and not with_images:
            w0, h0 = image_size(img_path)
            size = (max(1, round(w0 / downscale)), max(1, round(h0 / downscale)))
        if not with_images:
            w, h = size
            cameras.append(Camera(0.5 * w / math.tan(0.5 * angle), 0.5 * w / math.tan(0.5 * angle), w / 2, h / 2,
                                  w, h, R, t, name=img_path.stem))
            paths.append(img_path)
            continue
        if i == 0:  # the first image fixes the working size of all of them (read from its header)
            w0, h0 = image_size(img_path)
            size = (max(1, round(w0 / downscale)), max(1, round(h0 / downscale)))
            rgb, mask = read_image(img_path, size)
        else:
            rgb, mask = read_image(img_path, size)
        w, h = size
        fx = 0.5 * w / math.tan(0.5 * angle)
        cameras.append(Camera(fx, fx, w / 2, h / 2, w, h, R, t, name=img_path.stem))
        images.append(rgb)
        masks.append(mask)
        paths.append(img_path)
    frame = estimate_frame(cameras, up=np.array([0.0, 0.0, 1.0]), full_size=(w0, h0))
    return Scene(cameras, images, frame, _masks_or_none(masks, paths, path) if with_images else None, None,
                 str(root), paths)


def _masks_or_none(masks: list[np.ndarray | None], paths: list[Path], source: Path) -> list[np.ndarray] | None:
    """The views' masks (alpha or mask files), or ``None`` when no view has one (RGB photos: automatic masks are
    made for them, never an all-object mask). Some with and some without is an error naming the first without."""
    missing = [p for p, m in zip(paths, masks) if m is None]
    if not missing:
        return masks  # type: ignore[return-value]
    if len(missing) == len(masks):
        return None
    raise SceneError(f"{source}: {missing[0].name} has no alpha or mask while other views have one (give every "
                     "view a mask, or none)")


def load_nerfstudio(root: str | Path, downscale: float = 1.0) -> Scene:
    """Load a nerfstudio ``transforms.json`` (intrinsics ``fl_x, fl_y, cx, cy, w, h`` shared or per frame;
    optional ``mask_path`` per frame; RGBA alpha used as the mask when there is no mask file)."""
    root = Path(root)
    path = root / "transforms.json"
    data = _read_json(path)
    cameras, images, masks, paths = [], [], [], []
    for i, fr in enumerate(data["frames"]):
        if not isinstance(fr, dict) or not isinstance(fr.get("file_path"), str):
            raise SceneError(f"{path}: frames[{i}].file_path missing")
        intr = {}
        for key in ("fl_x", "fl_y", "cx", "cy", "w", "h"):
            v = fr.get(key, data.get(key))
            if key == "fl_y" and v is None:
                v = fr.get("fl_x", data.get("fl_x"))
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not (0 < v <= MAX_COORD and math.isfinite(v)):
                raise SceneError(f"{path}: frames[{i}]: intrinsic {key!r} missing or invalid (shared or per frame)")
            intr[key] = float(v)
        if fr.get("camera_model", data.get("camera_model", "OPENCV")) not in ("OPENCV", "PINHOLE", "SIMPLE_PINHOLE"):
            raise SceneError(f"{path}: frames[{i}]: only pinhole camera models are supported")
        img_path = _image_path(root, fr["file_path"], f"{path}: frames[{i}].file_path")
        R, t = _pose(fr, path, i)
        # The intrinsics describe the image at (w, h); the file may be a scaled copy of it (nerfstudio's
        # images_2 …), so the working size comes from the file and the intrinsics follow.
        iw, ih = image_size(img_path)
        if abs(iw / ih - intr["w"] / intr["h"]) > 0.01 * iw / ih:
            raise SceneError(f"{path}: frames[{i}]: image {img_path.name} is {iw}x{ih} but the intrinsics are for "
                             f"{intr['w']:g}x{intr['h']:g}")
        if i == 0:
            full = (float(iw), float(ih))
        w, h = max(1, round(iw / downscale)), max(1, round(ih / downscale))
        sx, sy = w / intr["w"], h / intr["h"]
        rgb, mask = read_image(img_path, (w, h))
        if isinstance(fr.get("mask_path"), str):
            mask = read_mask(scene_path(root, fr["mask_path"], f"{path}: frames[{i}].mask_path"), (w, h))
        cameras.append(Camera(intr["fl_x"] * sx, intr["fl_y"] * sy, intr["cx"] * sx, intr["cy"] * sy, w, h, R, t,
                              name=img_path.stem))
        images.append(rgb)
        masks.append(mask)
        paths.append(img_path)
    return Scene(cameras, images, estimate_frame(cameras, full_size=full), _masks_or_none(masks, paths, path), None,
                 str(root), paths)
