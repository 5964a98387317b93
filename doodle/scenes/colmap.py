"""COLMAP models through pycolmap: ``sparse/0`` (binary or text) + image folder, optional ``masks/``.

COLMAP poses are already world-to-camera in the OpenCV convention, so no axis conversion happens here.
Lens distortion is ignored (the pinhole part of the model is used): doodle's strokes are far coarser
than the distortion of the cameras COLMAP estimates for ordinary photos.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from ..cameras import Camera
from ..errors import SceneError
from .images import read_image, read_mask
from .scene import Scene, estimate_frame

MODEL_FILES = ("cameras.bin", "cameras.txt")


@contextmanager
def quiet_pycolmap() -> Iterator[None]:
    """Keep COLMAP's own log (thousands of INFO lines per reconstruction, and a warning about threads on
    every run) off the terminal; errors still show. doodle prints its own one-line summaries, and failures
    become one-line errors."""
    import pycolmap

    before = pycolmap.logging.minloglevel
    pycolmap.logging.minloglevel = int(pycolmap.logging.ERROR)
    try:
        yield
    finally:
        pycolmap.logging.minloglevel = before


def find_model_dir(root: Path) -> Path | None:
    """The folder holding ``cameras.{bin,txt}``: ``root``, ``root/sparse/0`` or ``root/sparse``."""
    for cand in (root, root / "sparse" / "0", root / "sparse"):
        if any((cand / f).exists() for f in MODEL_FILES):
            return cand
    return None


def load_colmap(root: str | Path, images_dir: str | Path | None = None, masks_dir: str | Path | None = None,
                downscale: float = 1.0) -> Scene:
    """Load a COLMAP reconstruction.

    Args:
        root: the project folder (with ``sparse/0`` and ``images/``) or the model folder itself.
        images_dir: image folder; default ``root/images``.
        masks_dir: optional masks (``NAME.png`` or ``NAME`` + ``.png``, COLMAP's convention); default
            ``root/masks`` when it exists.
        downscale: divide the image size by this factor.
    """
    import pycolmap

    root = Path(root)
    model_dir = find_model_dir(root)
    if model_dir is None:
        raise SceneError(f"{root}: no COLMAP model (cameras.bin/.txt) in it or in sparse/0")
    try:
        rec = pycolmap.Reconstruction(str(model_dir))
    except Exception as exc:  # pycolmap raises bare RuntimeErrors/ValueErrors for unreadable models
        raise SceneError(f"{model_dir}: cannot read COLMAP model ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__})") from None
    project = root if model_dir == root else root
    images_dir = Path(images_dir) if images_dir else project / "images"
    if masks_dir is None and (project / "masks").is_dir():
        masks_dir = project / "masks"
    ids = sorted(rec.reg_image_ids(), key=lambda i: rec.image(i).name)
    if not ids:
        raise SceneError(f"{model_dir}: the COLMAP model has no registered images")
    cameras, images, masks, paths = [], [], [], []
    for image_id in ids:
        im = rec.image(image_id)
        cam = rec.camera(im.camera_id)
        pose = im.cam_from_world()
        R = np.asarray(pose.rotation.matrix(), dtype=np.float64)
        t = np.asarray(pose.translation, dtype=np.float64)
        w, h = max(1, round(cam.width / downscale)), max(1, round(cam.height / downscale))
        sx, sy = w / cam.width, h / cam.height
        path = images_dir / im.name
        rgb, mask = read_image(path, (w, h))
        if masks_dir is not None:
            cands = [Path(masks_dir) / (im.name + ".png"), Path(masks_dir) / im.name,
                     Path(masks_dir) / (Path(im.name).stem + ".png")]
            found = next((c for c in cands if c.exists()), None)
            if found is None:
                raise SceneError(f"{masks_dir}: no mask for image {im.name}")
            mask = read_mask(found, (w, h))
        cameras.append(Camera(cam.focal_length_x * sx, cam.focal_length_y * sy, cam.principal_point_x * sx,
                              cam.principal_point_y * sy, w, h, R, t, name=Path(im.name).stem))
        images.append(rgb)
        masks.append(mask)
        paths.append(path)
    pts = np.array([p.xyz for p in rec.points3D.values()], dtype=np.float64).reshape(-1, 3)
    has_masks = all(m is not None for m in masks)
    return Scene(cameras, images, estimate_frame(cameras, points=pts if len(pts) else None),
                 masks if has_masks else None, pts if len(pts) else None, str(root), paths)
