"""Dataset parsers. Each format has one parser returning a :class:`Scene`; :func:`load_scene` picks one."""

from __future__ import annotations

from pathlib import Path

from ..errors import SceneError
from .colmap import find_model_dir, load_colmap
from .scene import Scene, estimate_frame, working_scene
from .transforms import load_nerf_synthetic, load_nerfstudio


def detect_format(root: str | Path) -> str:
    """``"nerf-synthetic"``, ``"neus"`` (NeuS/IDR: ``cameras_sphere.npz``), ``"nerfstudio"``, ``"colmap"`` or
    ``"photos"`` for a scene folder.

    Raises:
        SceneError: if the folder does not exist or holds none of them.
    """
    root = Path(root)
    if not root.is_dir():
        raise SceneError(f"{root}: not a folder")
    if any((root / f"transforms_{s}.json").exists() for s in ("train", "val", "test")):
        return "nerf-synthetic"
    from .neus import is_neus

    if is_neus(root):
        return "neus"
    if (root / "transforms.json").exists():
        return "nerfstudio"
    if find_model_dir(root) is not None:
        return "colmap"
    from .photos import photo_files

    photos = photo_files(root)
    if len(photos) >= 3:
        return "photos"
    if photos:
        raise SceneError(f"{root}: structure-from-motion needs at least 3 photos, found {len(photos)}")
    raise SceneError(f"{root}: no transforms_train.json, cameras_sphere.npz, transforms.json, COLMAP model or photos "
                     "found")


def load_scene(root: str | Path, split: str = "train", downscale: float = 1.0) -> Scene:
    """Load any supported scene folder; ``split`` applies to NeRF-synthetic folders."""
    fmt = detect_format(root)
    if fmt == "nerf-synthetic":
        return load_nerf_synthetic(root, split, downscale)
    if fmt == "nerfstudio":
        return load_nerfstudio(root, downscale)
    if fmt == "photos":
        from .photos import load_photos

        return load_photos(root, downscale)
    if fmt == "neus":
        from .neus import load_neus

        return load_neus(root, downscale)
    return load_colmap(root, downscale=downscale)


def load_scene_at_size(root: str | Path, split: str = "train", size: int | None = None) -> Scene:
    """Load a scene with images downscaled so the larger side is about ``size`` px (never enlarged);
    saves memory and time for large photos (Lego: 100 × 800² → 256²)."""
    if size is None:
        return load_scene(root, split)
    fmt = detect_format(root)
    if fmt == "photos":
        from .photos import load_photos

        return load_photos(root, size=size)
    if fmt == "colmap":
        return load_colmap(root, size=size)
    if fmt == "neus":
        from .neus import load_neus

        return load_neus(root, size=size)
    cams = load_cameras(root, split)
    largest = max(max(c.width, c.height) for c in cams)
    return load_scene(root, split, downscale=max(1.0, largest / size))


def load_cameras(root: str | Path, split: str = "test") -> list:
    """Only the cameras of a scene folder (NeRF-synthetic: without decoding any image but the first's size)."""
    fmt = detect_format(root)
    if fmt == "nerf-synthetic":
        return load_nerf_synthetic(root, split, with_images=False).cameras
    return load_scene(root, split).cameras


__all__ = ["load_cameras", "load_scene_at_size", "Scene", "SceneError", "detect_format", "estimate_frame", "load_colmap", "load_nerf_synthetic",
           "load_nerfstudio", "load_scene", "working_scene"]
