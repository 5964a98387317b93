"""Image file reading shared by the parsers: RGBA → (RGB over white, mask), optional downscale."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image, UnidentifiedImageError

from ..errors import SceneError


def read_image(path: Path, size: tuple[int, int] | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """Read an image; returns ``(rgb uint8 (H, W, 3), mask bool (H, W) or None)``.

    Alpha, when present, is the mask (``alpha > 0.5``) and the colour is composited over white, the NeRF
    convention. ``size = (width, height)`` resizes with area averaging (box filter).
    """
    try:
        with Image.open(path) as im:
            im.load()
            has_alpha = im.mode in ("RGBA", "LA") or (im.mode == "P" and "transparency" in im.info)
            im = im.convert("RGBA" if has_alpha else "RGB")
            if size is not None and im.size != size:
                im = im.resize(size, Image.Resampling.BOX)
            arr = np.asarray(im)
    except FileNotFoundError:
        raise SceneError(f"{path}: image not found") from None
    except (UnidentifiedImageError, OSError, ValueError) as exc:
        raise SceneError(f"{path}: cannot read image ({exc})") from None
    if not has_alpha:
        return arr.copy(), None
    alpha = arr[..., 3:4].astype(np.float32) / 255.0
    rgb = arr[..., :3].astype(np.float32) * alpha + 255.0 * (1.0 - alpha)
    return np.clip(rgb + 0.5, 0, 255).astype(np.uint8), alpha[..., 0] > 0.5


def read_mask(path: Path, size: tuple[int, int]) -> np.ndarray:
    """Read a mask image (any mode; non-zero = object) at ``size = (width, height)``."""
    try:
        with Image.open(path) as im:
            im = im.convert("L")
            if im.size != size:
                im = im.resize(size, Image.Resampling.BOX)
            return np.asarray(im) > 127
    except (FileNotFoundError, UnidentifiedImageError, OSError, ValueError) as exc:
        raise SceneError(f"{path}: cannot read mask ({exc})") from None
