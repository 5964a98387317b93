"""Test helpers importable from every test module (pytest puts tests/ on sys.path)."""

from __future__ import annotations

import numpy as np

from doodle.strokes import CurveSet, SceneFrame, StrokeSet, SuperquadricSet
from doodle.strokes.model import Voxels
from doodle.strokes.superquadric import matrix_to_quaternion


def random_strokes(seed: int = 0, n_curves: int = 32, n_sq: int = 8, radius: float = 1.5,
                   extras: bool = False) -> StrokeSet:
    """A valid stroke set with random geometry inside the bounding sphere; with ``extras`` also curve normals,
    contour gates, an occluder volume and a hull (every optional field a fit writes)."""
    rng = np.random.default_rng(seed)
    rot = np.stack([matrix_to_quaternion(_proper(r)) for r in np.linalg.qr(rng.normal(size=(n_sq, 3, 3)))[0]]) if n_sq else np.zeros((0, 4))
    curves = CurveSet(rng.uniform(-radius * 0.7, radius * 0.7, (n_curves, 4, 3)))
    occluder = hull = None
    if extras:
        n = rng.normal(size=(n_curves, 2, 2, 3))
        curves = CurveSet(curves.control_points, 1.5, n / np.linalg.norm(n, axis=-1, keepdims=True),
                          rng.choice([0.0, 0.15, 0.3], n_curves))
        axes = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        occluder = Voxels(rng.uniform(-radius, 0, 3), radius / 8, axes, rng.random((6, 5, 4)) > 0.4)
        hull = Voxels(rng.uniform(-radius, 0, 3), radius / 16, axes, rng.random((12, 10, 8)) > 0.3)
    return StrokeSet(
        SceneFrame(radius=radius),
        curves,
        SuperquadricSet(rng.uniform(0.1, 0.5, (n_sq, 3)) * radius, rng.uniform(0.1, 1.9, (n_sq, 2)), rot,
                        rng.uniform(-0.5, 0.5, (n_sq, 3)) * radius),
        provenance={"tool": "doodle test", "source": "random", "iterations": 0, "seconds": 0.0},
        occluder=occluder,
        hull=hull,
    )


def _proper(r: np.ndarray) -> np.ndarray:
    return r if np.linalg.det(r) > 0 else -r


def render_scene(primitives, n: int = 12, size: int = 96, radius: float = 1.3):
    """An in-memory scene of procedural ``primitives`` (the samples' training cameras, RGB over white, alpha
    masks): for tests of one part of the fit without writing a sample folder."""
    from doodle.samples.raycast import render_rgba
    from doodle.samples.scenes import sample_cameras
    from doodle.scenes.scene import Scene

    cams = sample_cameras("train", n, size)
    rgba = [render_rgba(list(primitives), c, 1) for c in cams]
    alpha = [r[..., 3:].astype(float) / 255 for r in rgba]
    images = [(r[..., :3] * a + 255 * (1 - a)).astype(np.uint8) for r, a in zip(rgba, alpha)]
    return Scene(cams, images, SceneFrame(radius=radius), [r[..., 3] > 127 for r in rgba], source="rendered")


def in_a_fresh_process(code: str) -> bytes:
    """Run Python ``code`` in a new interpreter (a random hash seed, nothing imported before it, tests/ on its
    path) and return what it wrote to stdout: for checking that a result does not depend on the process."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    here = str(Path(__file__).resolve().parent)
    env = {**os.environ, "PYTHONHASHSEED": "random",
           "PYTHONPATH": os.pathsep.join([here, os.environ.get("PYTHONPATH", "")])}
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, env=env, timeout=240)
    assert r.returncode == 0, r.stderr.decode(errors="replace")[-2000:]
    return r.stdout


NEUS_SCALE = np.array([[1.5, 0, 0, 0.1], [0, 1.5, 0, -0.2], [0, 0, 1.5, 0.05], [0, 0, 0, 1.0]])


def neus_copy(root, n: int = 3, size: int = 32):
    """A small sample scene written in the NeuS/IDR layout (``cameras_sphere.npz``, ``image/``, ``mask/``) under
    ``root/scene``, its sphere frame mapped to the sample's world by :data:`NEUS_SCALE`. Returns
    ``(folder, source scene)``."""
    from pathlib import Path

    from PIL import Image

    from doodle.samples import write_sample
    from doodle.scenes import load_scene

    root = Path(root)
    src = load_scene(write_sample("chair", root / "src", n_train=n, n_test=1, size=size))
    scene = root / "scene"
    (scene / "image").mkdir(parents=True)
    (scene / "mask").mkdir()
    mats = {}
    for i, (cam, img, m) in enumerate(zip(src.cameras, src.images, src.masks)):
        world = np.eye(4)
        world[:3] = np.array([[cam.fx, 0, cam.cx], [0, cam.fy, cam.cy], [0, 0, 1]]) @ np.c_[cam.R, cam.t]
        mats[f"world_mat_{i}"] = world * (-2.0 if i == 1 else 1.0)  # any scale, even negative, is the same camera
        mats[f"scale_mat_{i}"] = NEUS_SCALE
        Image.fromarray(img).save(scene / "image" / f"{i:06d}.png")
        Image.fromarray(m.astype(np.uint8) * 255).save(scene / "mask" / f"{i:03d}.png")
    np.savez(scene / "cameras_sphere.npz", **mats)
    return scene, src
