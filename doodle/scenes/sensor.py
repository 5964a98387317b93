"""One lens for portrait and landscape photos: pose them all the way the camera's sensor lies, then turn the
portrait views back.

A phone capture mixes portrait and landscape photos of one lens. COLMAP gives a camera to each image size, so a
mixed capture gets two focal lengths (or, where the photos carry no EXIF focal length, one per photo), each
fixed by fewer photos: on a 40-photo carpet capture of 400 px the per-photo focal lengths spread over ±8 %,
the true lens distortion (k = −0.06) went unnoticed and the camera centres were 1.2–4.4 % of the capture's radius
off, which erodes a visual hull's thin parts by pixels. A portrait photo is the sensor's landscape image
turned by a quarter: turned back, every photo is one image size and shares one camera, whose focal length and
radial distortion do not change with the turn (the principal point moves with it).

Convention: a portrait photo ``P`` (``w × h``, h > w) is turned a quarter counter-clockwise into the sensor
image ``S`` (``h × w``), so a point ``(x, y)`` of ``P`` lies at ``(y, w − x)`` in ``S``. A camera posing ``S``
(rotation ``R_s``, translation ``t_s``, principal point ``(cx, cy)``) poses ``P`` with ``R = M R_s``,
``t = M t_s`` (``M`` a quarter turn about the optical axis) and principal point ``(w − cy, cx)``.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np
from PIL import Image

from .images import open_image, save_turned

QUARTER = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
"""``M``: camera coordinates of the sensor image ``S`` → those of the upright portrait photo ``P``."""
RADIAL_MODELS = ("SIMPLE_PINHOLE", "SIMPLE_RADIAL", "RADIAL")
"""Camera models whose parameters are ``f, cx, cy`` and radial terms: unchanged by a quarter turn but for the
principal point (a model with two focal lengths or tangential terms would need them swapped and turned)."""


def one_lens(sizes: list[tuple[int, int]]) -> bool:
    """Whether upright photo ``sizes`` ``(w, h)`` are one image size in both orientations (a phone's portrait and
    landscape photos), so that turning the portrait ones gives every photo one size.

    >>> one_lens([(400, 300), (300, 400), (400, 300)]), one_lens([(400, 300)] * 2), one_lens([(400, 300), (300, 200)])
    (True, False, False)
    """
    return len(set(sizes)) == 2 and len({tuple(sorted(s)) for s in sizes}) == 1


def portrait_from_sensor(xy: np.ndarray, width: float) -> np.ndarray:
    """Pixel positions ``(N, 2)`` in the sensor image ``S`` → in the upright portrait photo of ``width`` px:
    ``(x, y) = (w − y_s, x_s)`` (continuous coordinates, pixel centres at +0.5 in both)."""
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    return np.stack([width - xy[:, 1], xy[:, 0]], axis=1)


def portrait_pose(R: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World-to-camera pose of the upright portrait photo from that of its sensor image: ``(M R, M t)``."""
    return QUARTER @ R, QUARTER @ t


def portrait_params(model: str, params: np.ndarray, sensor_size: tuple[int, int]) -> np.ndarray:
    """Camera parameters of the upright portrait photo from those of its sensor image (``W × H``): the
    principal point ``(cx, cy)`` becomes ``(H − cy, cx)``; focal length and radial terms stay."""
    if model not in RADIAL_MODELS:
        raise ValueError(f"a quarter turn of a {model} camera is not supported")
    out = np.array(params, dtype=np.float64)
    cx, cy = out[1], out[2]
    out[1], out[2] = sensor_size[1] - cy, cx
    return out


def sensor_copies(src: Path, names: list[str], turned: set[str], out: Path) -> Path:
    """Write the photos ``names`` of folder ``src`` into ``out`` the way the sensor lies: those in ``turned``
    (upright portrait photos) turned a quarter counter-clockwise, the others linked (or copied). Returns
    ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    for name in names:
        if name in turned:
            with open_image(src / name) as im:
                save_turned(im.transpose(Image.Transpose.ROTATE_90), im, out / name)
            continue
        try:
            os.link(src / name, out / name)
        except OSError:  # another file system, or one without hard links
            shutil.copyfile(src / name, out / name)
    return out


def _num(*values) -> str:
    """Numbers as COLMAP's text model holds them: exact (17 significant digits), space-separated."""
    return " ".join(f"{float(v):.17g}" for v in values)


def write_upright_model(rec, turned: set[str], out: Path) -> None:
    """Write the registered images and 3D points of ``rec`` (a ``pycolmap.Reconstruction`` posing sensor
    images) as a COLMAP text model of the upright photos in ``out``: each image named in ``turned`` gets a
    portrait camera (one per sensor camera), its pose and its features' positions turned; the 3D points and
    every other image stay as they are."""
    import pycolmap

    cameras, portrait_id = {}, {}
    next_id = max(rec.cameras) + 1
    for cid, cam in rec.cameras.items():
        params = np.asarray(cam.params, dtype=np.float64)
        cameras[cid] = (cam.model.name, cam.width, cam.height, params)
        if any(rec.image(i).name in turned and rec.image(i).camera_id == cid for i in rec.reg_image_ids()):
            cameras[next_id] = (cam.model.name, cam.height, cam.width,
                                portrait_params(cam.model.name, params, (cam.width, cam.height)))
            portrait_id[cid], next_id = next_id, next_id + 1
    out.mkdir(parents=True, exist_ok=True)
    lines = [f"{cid} {m} {w} {h} {_num(*p)}" for cid, (m, w, h, p) in cameras.items()]
    (out / "cameras.txt").write_text("# CAMERA_ID MODEL WIDTH HEIGHT PARAMS\n" + "\n".join(lines) + "\n")
    lines = []
    for i in sorted(rec.reg_image_ids()):
        im = rec.image(i)
        pose = im.cam_from_world()
        R, t = np.asarray(pose.rotation.matrix()), np.asarray(pose.translation)
        xy = np.array([p.xy for p in im.points2D], dtype=np.float64).reshape(-1, 2)
        cid = im.camera_id
        if im.name in turned:
            R, t = portrait_pose(R, t)
            xy = portrait_from_sensor(xy, rec.camera(cid).height)
            cid = portrait_id[cid]
        qx, qy, qz, qw = np.asarray(pycolmap.Rotation3d(R).quat, dtype=np.float64)  # pycolmap: x, y, z, w
        ids = [p.point3D_id if p.has_point3D() else -1 for p in im.points2D]
        lines.append(f"{i} {_num(qw, qx, qy, qz, *t)} {cid} {im.name}")
        lines.append(" ".join(f"{_num(x, y)} {pid}" for (x, y), pid in zip(xy.tolist(), ids)))
    (out / "images.txt").write_text("# IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME / POINTS2D[] as (X, Y, POINT3D_ID)\n"
                                    + "\n".join(lines) + "\n")
    lines, registered = [], set(rec.reg_image_ids())
    for pid, p in rec.points3D.items():
        track = " ".join(f"{e.image_id} {e.point2D_idx}" for e in p.track.elements if e.image_id in registered)
        if not track:
            continue
        r, g, b = (int(c) for c in p.color)
        lines.append(f"{pid} {_num(*p.xyz)} {r} {g} {b} {_num(p.error)} {track}")
    (out / "points3D.txt").write_text("# POINT3D_ID X Y Z R G B ERROR TRACK[] as (IMAGE_ID, POINT2D_IDX)\n"
                                      + "\n".join(lines) + "\n")
