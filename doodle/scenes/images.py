"""Image file reading shared by the parsers: RGBA → (RGB over white, mask), optional downscale."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image, ImageOps, UnidentifiedImageError

from ..errors import SceneError

#: Formats doodle decodes; everything else (EPS through Ghostscript, …) is refused even when named .png.
FORMATS = ("PNG", "JPEG", "TIFF", "BMP", "WEBP")
#: Largest image accepted, checked from the header before decoding: 100 megapixels (a 12000² PNG of a few
#: hundred KB would otherwise cost gigabytes).
MAX_PIXELS = 100_000_000


def scene_path(root: Path, rel: str, where: str) -> Path:
    """``root / rel`` for a path written in a scene file, which must stay inside the scene folder.

    Policy: absolute paths and paths climbing out with ``..`` are refused, so that a downloaded scene cannot
    make doodle read arbitrary files (symbolic links inside the folder are followed: linking a dataset in is
    the way to use images stored elsewhere).
    """
    p = Path(rel)
    if p.is_absolute() or ".." in p.parts or "\0" in rel:
        raise SceneError(f"{where}: {rel[:80]!r} points outside the scene folder (use a relative path inside it; "
                         "link or copy images stored elsewhere)")
    if len(rel) > 1024 or any(len(part) > 255 for part in p.parts):
        raise SceneError(f"{where}: path too long")
    if any(ord(ch) < 32 or ord(ch) == 127 for ch in rel):  # would break the one-line messages that name it
        raise SceneError(f"{where}: {rel[:80]!r} has control characters")
    return root / p


def open_image(path: Path) -> Image.Image:
    """Open an image lazily after checking that it is a regular file of an allowed format and size.

    Raises:
        SceneError: naming the file and the problem.
    """
    path = Path(path)
    try:
        if not path.is_file():  # FIFOs and devices would block, folders are not images
            raise SceneError(f"{path}: image not found" if not path.exists() else f"{path}: not a regular file")
        im = Image.open(path, formats=FORMATS)
    except SceneError:
        raise
    except Image.DecompressionBombError:
        raise SceneError(f"{path}: image header claims more than {MAX_PIXELS // 1_000_000} megapixels") from None
    except UnidentifiedImageError:
        raise SceneError(f"{path}: not an image doodle reads ({', '.join(FORMATS)})") from None
    except (OSError, ValueError) as exc:
        raise SceneError(f"{path}: cannot read image ({getattr(exc, 'strerror', None) or exc})") from None
    w, h = im.size
    if w * h > MAX_PIXELS or w < 1 or h < 1:
        im.close()
        raise SceneError(f"{path}: image is {w}x{h} pixels, beyond the limit of {MAX_PIXELS // 1_000_000} megapixels")
    return im


def save_turned(image: Image.Image, source: Image.Image, path: Path) -> None:
    """Save ``image``, a turned copy of the photo ``source``, with the photo's EXIF but for its orientation
    tag (the copy is already turned): the focal length a phone records there is COLMAP's prior for the
    camera, and a copy without it starts SfM from a guess (1.2 × the long side)."""
    exif = source.getexif()
    exif.get_ifd(0x8769)  # the Exif sub-IFD (focal lengths) is written back only once read
    exif[0x0112] = 1
    try:
        image.convert("RGB").save(path, quality=95, exif=exif.tobytes())
    except (ValueError, TypeError, OSError):  # an EXIF block Pillow cannot write back: the pixels still count
        image.convert("RGB").save(path, quality=95)


def image_size(path: Path) -> tuple[int, int]:
    """``(width, height)`` from the header, without decoding."""
    with open_image(path) as im:
        return im.size


def read_image(path: Path, size: tuple[int, int] | None = None, expect: tuple[int, int] | None = None
               ) -> tuple[np.ndarray, np.ndarray | None]:
    """Read an image; returns ``(rgb uint8 (H, W, 3), mask bool (H, W) or None)``.

    Alpha, when present, is the mask (``alpha > 0.5``) and the colour is composited over white, the NeRF
    convention. ``size = (width, height)`` resizes with area averaging (box filter). ``expect = (width,
    height)``: the size the camera was calibrated at. Raw pixels are used when they have that size (COLMAP
    ignores EXIF orientation); an image that has it only once EXIF-rotated is rotated; any other size is an
    error (the image does not belong to that camera).
    """
    try:
        with open_image(path) as im:
            if expect is not None and im.size != tuple(expect):
                upright = ImageOps.exif_transpose(im)
                if upright.size != tuple(expect):
                    raise SceneError(f"{path}: image is {im.size[0]}x{im.size[1]} but its camera is "
                                     f"{expect[0]}x{expect[1]}")
                im = upright
            im.load()
            has_alpha = im.mode in ("RGBA", "LA") or (im.mode == "P" and "transparency" in im.info)
            im = im.convert("RGBA" if has_alpha else "RGB")
            if size is not None and im.size != size:
                im = im.resize(size, Image.Resampling.BOX)
            arr = np.asarray(im)
    except FileNotFoundError:
        raise SceneError(f"{path}: image not found") from None
    except (OSError, ValueError, SyntaxError, Image.DecompressionBombError) as exc:  # Pillow: SyntaxError for broken PNGs
        raise SceneError(f"{path}: cannot read image ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__})") from None
    if not has_alpha:
        return arr.copy(), None
    alpha = arr[..., 3:4].astype(np.float32) / 255.0
    rgb = arr[..., :3].astype(np.float32) * alpha + 255.0 * (1.0 - alpha)
    return np.clip(rgb + 0.5, 0, 255).astype(np.uint8), alpha[..., 0] > 0.5


def read_mask(path: Path, size: tuple[int, int]) -> np.ndarray:
    """Read a mask image (any mode; non-zero = object) at ``size = (width, height)``.

    Raises:
        SceneError: unreadable, or its shape is the view's turned a quarter (portrait for a landscape view or
            the reverse): a mask saved in another orientation than its photo would be squashed, not aligned.
    """
    try:
        with open_image(path) as im:
            w, h = im.size
            if (w - h) * (size[0] - size[1]) < 0 and abs(w / h - size[0] / size[1]) > 0.05 * size[0] / size[1]:
                raise SceneError(f"{path}: mask is {w}x{h} but its view is {size[0]}x{size[1]}; save it in the "
                                 "photo's orientation (upright, as the photo is shown)")
            im = im.convert("L")
            if im.size != size:
                im = im.resize(size, Image.Resampling.BOX)
            return np.asarray(im) > 127
    except (OSError, ValueError, SyntaxError, Image.DecompressionBombError) as exc:
        raise SceneError(f"{path}: cannot read mask ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__})") from None


def read_mask_folder(folder: Path, names: list[str], sizes: list[tuple[int, int]]) -> list[np.ndarray]:
    """Masks ``FOLDER/NAME.png`` (or ``NAME.*.png``, ``NAME.jpg``…) for views ``names``, each read at its view's
    ``(width, height)``: the views' own geometry as loaded (for COLMAP models with distortion, undistorted).

    Raises:
        SceneError: when the folder is missing or lacks a view's mask.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise SceneError(f"{folder}: mask folder not found")
    files = {p.stem: p for p in folder.iterdir() if p.is_file()}
    out = []
    for name, size in zip(names, sizes):
        path = files.get(name) or next((p for stem, p in files.items() if stem.split(".")[0] == name), None)
        if path is None:
            raise SceneError(f"{folder}: no mask for view {name} (expected {name}.png)")
        out.append(read_mask(path, size))
    return out
