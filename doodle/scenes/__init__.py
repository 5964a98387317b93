"""Dataset parsers. Each format has one parser returning a :class:`Scene`; :func:`load_scene` picks one."""

from __future__ import annotations

from pathlib import Path

from ..errors import SceneError
from .colmap import find_model_dir, load_colmap
from .scene import Scene, estimate_frame
from .transforms import load_nerf_synthetic, load_nerfstudio


def detect_format(root: str | Path) -> str:
    """``"nerf-synthetic"``, ``"nerfstudio"`` or ``"colmap"`` for a scene folder.

    Raises:
        SceneError: if the folder does not exist or holds none of them.
    """
    root = Path(root)
    if not root.is_dir():
        raise SceneError(f"{root}: not a folder")
    if any((root / f"transforms_{s}.json").exists() for s in ("train", "val", "test")):
        return "nerf-synthetic"
    if (root / "transforms.json").exists():
        return "nerfstudio"
    if find_model_dir(root) is not None:
        return "colmap"
    raise SceneError(f"{root}: no transforms_train.json, transforms.json or COLMAP model found")


def load_scene(root: str | Path, split: str = "train", downscale: float = 1.0) -> Scene:
    """Load any supported scene folder; ``split`` applies to NeRF-synthetic folders."""
    fmt = detect_format(root)
    if fmt == "nerf-synthetic":
        return load_nerf_synthetic(root, split, downscale)
    if fmt == "nerfstudio":
        return load_nerfstudio(root, downscale)
    return load_colmap(root, downscale=downscale)


def load_cameras(root: str | Path, split: str = "test") -> list:
    """Only the cameras of a scene folder (NeRF-synthetic: without decoding any image but the first's size)."""
    fmt = detect_format(root)
    if fmt == "nerf-synthetic":
        return load_nerf_synthetic(root, split, with_images=False).cameras
    return load_scene(root, split).cameras


__all__ = ["load_cameras", "Scene", "SceneError", "detect_format", "estimate_frame", "load_colmap", "load_nerf_synthetic",
           "load_nerfstudio", "load_scene"]
