"""SfM points for posed scenes that have none (NeRF-synthetic, nerfstudio): SIFT features and exhaustive
matching with pycolmap, then triangulation with the known poses (no pose estimation)."""

from __future__ import annotations

import shutil
import sqlite3
import tempfile
from pathlib import Path
from typing import Callable

import numpy as np

from ..arrays import spread_indices
from ..errors import SceneError
from ..strokes.superquadric import matrix_to_quaternion
from .colmap import quiet_pycolmap
from .scene import Scene


def triangulate_scene_points(scene: Scene, max_views: int = 24, log: Callable[[str], None] = print) -> np.ndarray:
    """3D points ``(P, 3)`` triangulated from up to ``max_views`` evenly picked views of ``scene`` (see
    :func:`triangulate_with_views`)."""
    return triangulate_with_views(scene, max_views, log)[0]


def triangulate_with_views(scene: Scene, max_views: int = 24, log: Callable[[str], None] = print
                           ) -> tuple[np.ndarray, list[np.ndarray]]:
    """3D points ``(P, 3)`` triangulated from up to ``max_views`` evenly picked views of ``scene``, and per point
    the indices of the scene's views that observed it.

    The scene's (working-size) images are written to a temporary folder with a COLMAP text model of their
    known cameras; pycolmap extracts and matches SIFT features and triangulates with the poses held fixed.

    Raises:
        SceneError: when no point can be triangulated (textureless images, too few views).
    """
    import pycolmap
    from PIL import Image

    idx = spread_indices(len(scene), max_views)
    tmp = Path(tempfile.mkdtemp(prefix="doodle-triangulate-"))
    try:
        images, model, out = tmp / "images", tmp / "model", tmp / "out"
        for d in (images, model, out):
            d.mkdir()
        c0 = scene.cameras[idx[0]]
        if any(not np.allclose(scene.cameras[i].K, c0.K) or scene.cameras[i].width != c0.width for i in idx):
            raise SceneError(f"{scene.source}: triangulation needs one shared camera (the views' intrinsics differ)")
        by_name = {}
        for k, i in enumerate(idx, start=1):
            name = f"view_{k:04d}.png"
            Image.fromarray(scene.images[i]).save(images / name)
            by_name[name] = scene.cameras[i]
        names = list(by_name)
        params = f"{c0.fx!r},{c0.fy!r},{c0.cx!r},{c0.cy!r}"
        db = tmp / "database.db"
        log(f"triangulating SfM points with the known poses (pycolmap, {len(names)} views)")
        try:
            with quiet_pycolmap():
                reader = pycolmap.ImageReaderOptions()
                reader.camera_model = "PINHOLE"  # the database's camera must equal the model's
                reader.camera_params = params
                pycolmap.extract_features(db, images, image_names=names, camera_mode=pycolmap.CameraMode.SINGLE,
                                          reader_options=reader)
                pycolmap.match_exhaustive(db)
                # Feature extraction is threaded, so the database's image ids need not follow the name order:
                # write the model with the ids the database actually gave.
                with sqlite3.connect(db) as con:
                    rows = con.execute("SELECT image_id, camera_id, name FROM images").fetchall()
                lines = []
                for image_id, camera_id, name in sorted(rows):
                    cam = by_name[name]
                    q = matrix_to_quaternion(cam.R)
                    lines.append(f"{image_id} {' '.join(map(repr, q.tolist()))} {' '.join(map(repr, cam.t.tolist()))} "
                                 f"{camera_id} {name}\n\n")
                (model / "cameras.txt").write_text(f"{rows[0][1]} PINHOLE {c0.width} {c0.height} {params.replace(',', ' ')}\n")
                (model / "images.txt").write_text("".join(lines))
                (model / "points3D.txt").write_text("")
                rec = pycolmap.Reconstruction(str(model))
                rec = pycolmap.triangulate_points(rec, db, images, out)
        except Exception as exc:  # pycolmap raises bare runtime errors
            raise SceneError(f"{scene.source}: triangulation failed ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__})") from None
        pts = np.array([p.xyz for p in rec.points3D.values()], dtype=np.float64).reshape(-1, 3)
        view_of = {image_id: int(idx[names.index(name)]) for image_id, _, name in rows}
        views = [np.unique([view_of[e.image_id] for e in p.track.elements if e.image_id in view_of]).astype(np.int64)
                 for p in rec.points3D.values()]
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    if len(pts) == 0:
        raise SceneError(f"{scene.source}: triangulation found no points (images without texture?)")
    log(f"triangulated {len(pts)} points")
    return pts, views
