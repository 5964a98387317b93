"""A phone capture of a sample scene, with known truth: what a real capture brings, small enough for tests.

``write_capture("chair", out)`` writes a COLMAP project (``images/*.jpg``, ``sparse/0/*.txt``) of the scene
standing on a textured floor (wooden planks, or a busy red carpet: ``floor="carpet"``), in front of a textured wall that differs from photo to photo (as a room
behind an object does when one walks around it): landscape and portrait photos mixed, through a lens with
radial distortion (COLMAP ``SIMPLE_RADIAL``), some portrait photos stored as landscape pixels with an EXIF
rotation, SfM-like points on the object and on the floor, and no masks. ``true_masks/`` holds the exact
object masks of the photos, for measuring automatic masks; ``ground_truth.json`` the primitives.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np
from PIL import Image
from scipy import ndimage

from ..atomic import atomic_folder
from ..cameras import Camera, look_at
from ..strokes.superquadric import matrix_to_quaternion
from .raycast import cast, shade_rays
from .scenes import DISTANCE, FOV_DEG, SCENES, sample_target, visible_feature_edges

FLOOR_Z = -0.9  # the sample scenes stand on z ≈ -0.9
ROLL = np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]])  # camera roll by 90°: portrait from landscape
EXIF_ORIENTATION = 0x0112


def _floor_colour(xy: np.ndarray) -> np.ndarray:
    """A wood-like plank texture on the floor plane (world x, y → RGB in [0, 1])."""
    plank = np.floor(xy[:, 0] / 0.35)
    grain = 0.5 + 0.5 * np.sin(xy[:, 1] * 23.0 + 3.0 * np.sin(plank * 1.7) + 8 * xy[:, 0])
    base = np.stack([0.55 + 0.08 * np.sin(plank * 2.3), 0.42 + 0.05 * np.cos(plank), 0.30 * np.ones_like(plank)], 1)
    seam = (np.abs(xy[:, 0] / 0.35 - np.round(xy[:, 0] / 0.35)) < 0.04)[:, None]
    return np.where(seam, 0.2, base * (0.85 + 0.15 * grain[:, None]))


def _hash(i: np.ndarray, j: np.ndarray, salt: int) -> np.ndarray:
    """A deterministic pseudo-random value in [0, 1) per integer cell ``(i, j)`` (a texture's, the same in every
    photo)."""
    h = (i.astype(np.int64) * 73856093) ^ (j.astype(np.int64) * 19349663) ^ (salt * 83492791)
    h = (h ^ (h >> 13)) * 1274126177
    return ((h ^ (h >> 16)) & 0xFFFF) / 65536.0


def _carpet_colour(xy: np.ndarray) -> np.ndarray:
    """A red, strongly textured carpet on the floor plane (world x, y → RGB in [0, 1]): a woven grain of 1 cm
    tufts, each its own shade, under a pattern of medallions and borders; far more corners and blobs for a
    feature detector than the object has (the capture the blowtorch on the carpet was)."""
    tuft = np.floor(xy / 0.012)
    grain = _hash(tuft[:, 0], tuft[:, 1], 1)
    u, v = xy[:, 0] / 0.22, xy[:, 1] / 0.22
    cell = np.stack([np.floor(u), np.floor(v)], 1)
    fu, fv = u - cell[:, 0] - 0.5, v - cell[:, 1] - 0.5
    diamond = np.abs(fu) + np.abs(fv)
    motif = (np.abs(diamond - 0.32) < 0.06) | (diamond < 0.1) | (np.maximum(np.abs(fu), np.abs(fv)) > 0.46)
    palette = np.array([[0.62, 0.10, 0.12], [0.85, 0.72, 0.35], [0.12, 0.16, 0.38], [0.95, 0.90, 0.80]])
    accent = palette[1 + (_hash(cell[:, 0], cell[:, 1], 2) * 3).astype(int)]
    base = np.where(motif[:, None], accent, palette[0])
    return np.clip(base * (0.55 + 0.7 * grain[:, None]), 0, 1)


FLOORS = {"planks": _floor_colour, "carpet": _carpet_colour}
"""The floors a capture stands on: wooden planks, or a busy red carpet (more features than the object)."""


def _wall(shape: tuple[int, int], rng: np.random.Generator) -> np.ndarray:
    """A blotchy wall texture, different per photo: ``(H, W, 3)`` in [0, 1]."""
    noise = ndimage.gaussian_filter(rng.random((*shape, 3)), sigma=(6, 6, 0))
    noise = (noise - noise.min()) / max(np.ptp(noise), 1e-6)
    tint = rng.uniform(0.45, 0.8, 3)
    return np.clip(tint * (0.7 + 0.5 * noise), 0, 1)


def capture_cameras(n: int, size: int, portrait_every: int = 3) -> list[Camera]:
    """Cameras around the origin on a rising spiral; every ``portrait_every``-th is held upright (portrait)."""
    long, short = size, round(size * 0.75)
    f = 0.5 * long / math.tan(math.radians(FOV_DEG) / 2)
    cams = []
    for i in range(n):
        az, el = i * 137.50776405, 12.0 + 50.0 * (i + 0.5) / n
        a, e = math.radians(az), math.radians(el)
        eye = DISTANCE * np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])
        R, t = look_at(eye, np.zeros(3), np.array([0.0, 0, 1]))
        if portrait_every and i % portrait_every == portrait_every - 1:
            R, t, w, h = ROLL @ R, ROLL @ t, short, long
        else:
            w, h = long, short
        cams.append(Camera(f, f, w / 2, h / 2, w, h, R, t, name=f"photo_{i:03d}"))
    return cams


def _photo(prims, cam: Camera, k1: float, rng: np.random.Generator, ss: int = 2, floor: str = "planks"
           ) -> tuple[np.ndarray, np.ndarray]:
    """RGB ``uint8`` photo and object mask through a lens with radial distortion ``k1`` (COLMAP SIMPLE_RADIAL:
    distorted = undistorted · (1 + k1 r²) in normalised coordinates)."""
    H, W = cam.height * ss, cam.width * ss
    v, u = np.meshgrid((np.arange(H) + 0.5) / ss, (np.arange(W) + 0.5) / ss, indexing="ij")
    xd, yd = (u.ravel() - cam.cx) / cam.fx, (v.ravel() - cam.cy) / cam.fy
    x, y = xd.copy(), yd.copy()
    for _ in range(20):  # invert the distortion by fixed-point iteration (converges for |k1| r² ≪ 1)
        s = 1 + k1 * (x * x + y * y)
        x, y = xd / s, yd / s
    d = np.stack([x, y, np.ones_like(x)], -1) @ cam.R
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.broadcast_to(cam.center, d.shape)
    rgba = shade_rays(prims, o, d)[0]
    rgb = _wall((H, W), rng).reshape(-1, 3)
    t_floor = (FLOOR_Z - o[:, 2]) / np.where(np.abs(d[:, 2]) > 1e-9, d[:, 2], -1e-9)
    on_floor = t_floor > 0
    hit = o[on_floor] + t_floor[on_floor, None] * d[on_floor]
    rgb[on_floor] = FLOORS[floor](hit[:, :2])
    a = rgba[:, 3:4]
    rgb = rgba[:, :3] + (1 - a) * rgb  # rgba is premultiplied
    rgb = rgb.reshape(cam.height, ss, cam.width, ss, 3).mean(axis=(1, 3))
    mask = a.reshape(cam.height, ss, cam.width, ss).mean(axis=(1, 3)) > 0.5
    return (np.clip(rgb, 0, 1) * 255 + 0.5).astype(np.uint8), mask


def _surface_points(prims, cams: list[Camera], per_view: int, rng: np.random.Generator) -> np.ndarray:
    """Points where random rays of the photos meet the object or the floor near it (SfM-like points)."""
    out = []
    for cam in cams:
        u, v = rng.uniform(0, cam.width, per_view), rng.uniform(0, cam.height, per_view)
        o, d = cam.rays_at(u, v)
        t, _, idx = cast(prims, o, d)
        out.append(o[idx >= 0] + t[idx >= 0, None] * d[idx >= 0])
        t_floor = (FLOOR_Z - o[:, 2]) / np.where(np.abs(d[:, 2]) > 1e-9, d[:, 2], -1e-9)
        floor = (idx < 0) & (t_floor > 0)
        p = o[floor] + t_floor[floor, None] * d[floor]
        out.append(p[np.linalg.norm(p[:, :2], axis=1) < 1.6])
    return np.concatenate(out)


def write_capture(name: str, out_dir: str | os.PathLike, n: int = 30, size: int = 256, k1: float = -0.06,
                  portrait_every: int = 3, exif_every: int = 2, force: bool = False, seed: int = 0,
                  floor: str = "planks") -> Path:
    """Write the phone-capture version of sample ``name`` into ``out_dir`` (see the module docstring).

    ``size``: the long side of every photo; ``k1``: radial distortion; every ``portrait_every``-th photo is
    portrait, and every ``exif_every``-th of those is stored as landscape pixels with EXIF orientation 6 (as
    phones do; COLMAP poses the stored pixels, so its camera is landscape too). ``floor``: one of
    :data:`FLOORS`.

    Raises:
        DoodleError: unknown name or floor, or ``out_dir`` exists and is not empty without ``force``.
    """
    from ..errors import DoodleError

    if floor not in FLOORS:
        raise DoodleError(f"unknown floor {floor!r} (choose from {', '.join(FLOORS)})")
    out = sample_target(name, out_dir, force)
    prims = SCENES[name]()
    rng = np.random.default_rng(seed)
    cams = capture_cameras(n, size, portrait_every)
    with atomic_folder(out, keep_others=False) as tmp:
        for d in ("images", "true_masks", "sparse/0"):
            (tmp / d).mkdir(parents=True)
        cam_lines, image_lines, portraits = {}, [], 0
        for i, cam in enumerate(cams, start=1):
            rgb, mask = _photo(prims, cam, k1, rng, floor=floor)
            im, m = Image.fromarray(rgb), Image.fromarray(mask.astype(np.uint8) * 255)
            R, t, w, h = cam.R, cam.t, cam.width, cam.height
            exif = None
            if h > w:
                portraits += 1
                if exif_every and portraits % exif_every == 0:
                    # store the pixels turned 90° clockwise, as a phone held upright does, and tag them so
                    # viewers show them upright again (EXIF 6: rotate 90° CW to display)
                    im, m = im.transpose(Image.Transpose.ROTATE_90), m.transpose(Image.Transpose.ROTATE_90)
                    R, t, w, h = ROLL.T @ R, ROLL.T @ t, h, w
                    exif = Image.Exif()
                    exif[EXIF_ORIENTATION] = 6
            cam_id = 1 if w > h else 2
            cam_lines[cam_id] = f"{cam_id} SIMPLE_RADIAL {w} {h} {float(cam.fx)!r} {w / 2!r} {h / 2!r} {float(k1)!r}\n"
            q = matrix_to_quaternion(R)
            image_lines.append(f"{i} {' '.join(map(repr, q.tolist()))} {' '.join(map(repr, t.tolist()))} "
                               f"{cam_id} {cam.name}.jpg\n\n")
            im.save(tmp / "images" / f"{cam.name}.jpg", quality=92, **({"exif": exif} if exif else {}))
            m.save(tmp / "true_masks" / f"{cam.name}.png")
        pts = _surface_points(prims, cams, 40, rng)
        (tmp / "sparse/0/cameras.txt").write_text("".join(cam_lines[k] for k in sorted(cam_lines)))
        (tmp / "sparse/0/images.txt").write_text("".join(image_lines))
        (tmp / "sparse/0/points3D.txt").write_text(
            "".join(f"{k + 1} {float(p[0])!r} {float(p[1])!r} {float(p[2])!r} 128 128 128 0.5\n" for k, p in enumerate(pts)))
        gt = {"name": name, "up": [0, 0, 1], "primitives": [p.to_dict() for p in prims],
              "feature_edges": visible_feature_edges(prims).round(6).tolist()}
        (tmp / "ground_truth.json").write_text(json.dumps(gt))
    return out
