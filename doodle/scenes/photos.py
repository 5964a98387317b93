"""Plain photos: structure-from-motion with pycolmap (SIFT, exhaustive matching, incremental mapping),
then the COLMAP parser. The model is cached in ``PHOTOS/.doodle-sfm`` and reused.

Phone photos often store portrait shots as landscape pixels plus an EXIF orientation tag, which COLMAP
ignores. When any photo has such a tag, upright copies are written to ``PHOTOS/.doodle-sfm/images`` and
posed instead, so that cameras, images and sketches are all upright.
"""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Callable

from PIL import ImageOps

from ..errors import SceneError
from .colmap import load_colmap, quiet_pycolmap
from .images import open_image
from .scene import Scene

ORIENTATION = 0x0112  # the EXIF orientation tag
IMAGE_SUFFIXES = {".jpg", ".jpeg", ".png", ".tif", ".tiff", ".bmp", ".webp"}


def photo_files(root: Path) -> list[Path]:
    return sorted(p for p in root.iterdir() if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES)


def run_sfm(root: str | Path, log: Callable[[str], None] = print) -> Path:
    """Pose the photos in ``root``; returns the folder holding the COLMAP model (``cameras.bin`` …).

    Raises:
        SceneError: when fewer than 3 photos are given or no reconstruction registers at least 3 of them.
    """
    import pycolmap

    root = Path(root)
    photos = photo_files(root)
    if len(photos) < 3:
        raise SceneError(f"{root}: structure-from-motion needs at least 3 photos, found {len(photos)}")
    work = root / ".doodle-sfm"
    model = work / "model"
    if (model / "cameras.bin").exists():
        log(f"structure-from-motion: reusing {model}")
        return model
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    db = work / "database.db"
    # Photos of one size are taken to come from one camera: one shared set of intrinsics is far better
    # constrained (on 34 Lego photos, camera centres 1 % off instead of 3–6 % with a camera per photo).
    sizes, rotated = set(), []
    for p in photos:
        try:
            with open_image(p) as im:
                if im.getexif().get(ORIENTATION, 1) not in (0, 1):
                    rotated.append(p)
                    sizes.add(ImageOps.exif_transpose(im).size)
                else:
                    sizes.add(im.size)
        except (OSError, SyntaxError):
            raise SceneError(f"{p}: not a readable image") from None
    image_dir = root
    if rotated:
        image_dir = work / "images"
        image_dir.mkdir()
        log(f"structure-from-motion: {len(rotated)} photos carry an EXIF rotation; posing upright copies")
        for p in photos:
            if p in rotated:
                with open_image(p) as im:
                    ImageOps.exif_transpose(im).convert("RGB").save(image_dir / p.name, quality=95)
            else:
                shutil.copyfile(p, image_dir / p.name)
    shared = len(sizes) == 1
    log(f"structure-from-motion (pycolmap): {len(photos)} photos, {'one shared camera' if shared else 'a camera per photo'}; "
        "extracting and matching SIFT features")
    try:
        with quiet_pycolmap():
            mode = pycolmap.CameraMode.SINGLE if shared else pycolmap.CameraMode.AUTO
            pycolmap.extract_features(db, image_dir, image_names=[p.name for p in photos], camera_mode=mode)
            pycolmap.match_exhaustive(db)
            recs = pycolmap.incremental_mapping(db, image_dir, work / "sparse")
    except Exception as exc:  # pycolmap reports failures as RuntimeError/ValueError with long texts
        raise SceneError(f"{root}: structure-from-motion failed ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__})") from None
    best = max(recs.values(), key=lambda r: r.num_reg_images(), default=None)
    if best is None or best.num_reg_images() < 3:
        n = 0 if best is None else best.num_reg_images()
        raise SceneError(f"{root}: structure-from-motion failed: registered {n} of {len(photos)} photos "
                         f"(photos need overlap and texture; or give poses as a COLMAP model)")
    model.mkdir(parents=True, exist_ok=True)
    best.write(str(model))
    log(f"structure-from-motion: registered {best.num_reg_images()} of {len(photos)} photos, "
        f"{best.num_points3D()} points")
    return model


def load_photos(root: str | Path, downscale: float = 1.0, log: Callable[[str], None] = print,
                size: int | None = None) -> Scene:
    """Run (or reuse) SfM on a folder of photos and load the result; ``root/masks`` is used when present."""
    root = Path(root)
    model = run_sfm(root, log)
    upright = root / ".doodle-sfm" / "images"
    scene = load_colmap(model, images_dir=upright if upright.is_dir() else root,
                        masks_dir=root / "masks" if (root / "masks").is_dir() else None, downscale=downscale, size=size)
    return scene
