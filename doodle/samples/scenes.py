"""Procedural sample scenes with known geometry, written as NeRF-synthetic folders.

``write_sample("chair", out)`` writes ``transforms_{train,test}.json``, ``train/r_*.png``, ``test/r_*.png``
(RGBA, Blender camera convention, world up +z) and ``ground_truth.json`` (primitives and visible
feature-edge segments) for quantitative tests.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Callable

import numpy as np
from PIL import Image

from ..atomic import atomic_folder
from ..cameras import Camera, look_at
from ..errors import DoodleError
from .primitives import Box, Cone, Cylinder, Ellipsoid, Primitive, Sphere, Torus
from .raycast import render_rgba

FOV_DEG = 40.0
DISTANCE = 3.6
N_TRAIN = 40
N_TEST = 10
SIZE = 256


def _rot_z_to(axis: np.ndarray) -> np.ndarray:
    """A rotation taking local +z to ``axis``."""
    z = np.asarray(axis, float) / np.linalg.norm(axis)
    ref = np.array([0, 0, 1.0]) if abs(z[2]) < 0.9 else np.array([1.0, 0, 0])
    x = np.cross(ref, z)
    x /= np.linalg.norm(x)
    return np.stack([x, np.cross(z, x), z], axis=1)


def chair() -> list[Primitive]:
    """Four legs, a seat and a back: boxes only, so every line is a sharp feature edge."""
    wood = (0.62, 0.40, 0.22)
    legs = [Box(np.array([sx * 0.36, sy * 0.36, -0.55]), half=np.array([0.04, 0.04, 0.35]), color=wood)
            for sx in (-1, 1) for sy in (-1, 1)]
    seat = Box(np.array([0.0, 0.0, -0.15]), half=np.array([0.42, 0.42, 0.05]), color=(0.78, 0.52, 0.30))
    back = Box(np.array([0.0, 0.37, 0.35]), half=np.array([0.42, 0.05, 0.45]), color=(0.72, 0.47, 0.27))
    return [*legs, seat, back]


def snowman() -> list[Primitive]:
    """Three spheres and a carrot nose: smooth contours, almost no sharp edges."""
    snow = (0.93, 0.93, 0.97)
    return [
        Sphere(np.array([0.0, 0.0, -0.45]), radius=0.5, color=snow),
        Sphere(np.array([0.0, 0.0, 0.25]), radius=0.36, color=snow),
        Sphere(np.array([0.0, 0.0, 0.73]), radius=0.25, color=snow),
        Cone(np.array([0.2, 0.0, 0.75]), R=_rot_z_to(np.array([1.0, 0, 0])), radius=0.06, height=0.26,
             color=(0.95, 0.5, 0.1)),
    ]


def lamp() -> list[Primitive]:
    """A box base, a cylindrical stem, a conical shade and a ball: sharp edges and smooth contours mixed."""
    return [
        Box(np.array([0.0, 0.0, -0.84]), half=np.array([0.4, 0.4, 0.06]), color=(0.25, 0.32, 0.5)),
        Cylinder(np.array([0.0, 0.0, -0.78]), radius=0.05, height=0.92, color=(0.7, 0.7, 0.72)),
        Cone(np.array([0.0, 0.0, 0.1]), radius=0.5, height=0.6, color=(0.95, 0.88, 0.7)),
        Sphere(np.array([0.0, 0.0, 0.74]), radius=0.1, color=(0.85, 0.65, 0.2)),
    ]


def _rod(a: np.ndarray, b: np.ndarray, radius: float, color: tuple[float, float, float]) -> Cylinder:
    """A capped cylinder from point ``a`` to point ``b``."""
    return Cylinder(a, R=_rot_z_to(b - a), radius=radius, height=float(np.linalg.norm(b - a)), color=color)


def tripod() -> list[Primitive]:
    """A studio microphone on a tripod with a looping cable: thin parts (three splayed legs, a pole, the cable's
    loop around an empty hole) below the microphone (a ball on a short, narrow body). The thin parts are
    what a sketch must draw as curves, not as superquadrics."""
    metal, dark = (0.55, 0.56, 0.6), (0.18, 0.18, 0.2)
    hub = np.array([0.0, 0.0, -0.3])
    legs = [_rod(hub, np.array([0.68 * math.cos(a), 0.68 * math.sin(a), -0.95]), 0.022, dark)
            for a in np.radians([90.0, 210.0, 330.0])]
    return [
        *legs,
        _rod(np.array([0.0, 0.0, -0.36]), np.array([0.0, 0.0, 0.5]), 0.026, metal),
        Cylinder(np.array([0.0, 0.0, 0.5]), radius=0.085, height=0.3, color=(0.3, 0.3, 0.34)),
        Sphere(np.array([0.0, 0.0, 0.88]), radius=0.13, color=(0.42, 0.42, 0.46)),
        # the cable's loop hangs beside the pole, in the x-z plane, touching it
        Torus(np.array([0.3, 0.0, -0.02]), R=_rot_z_to(np.array([0.0, 1.0, 0.0])), major=0.27, minor=0.018,
              color=(0.08, 0.08, 0.09)),
    ]


def mug() -> list[Primitive]:
    """A mug with a ring handle: a volume (the body) with a thin loop on its side whose hole must stay open."""
    glaze = (0.35, 0.5, 0.75)
    return [
        Cylinder(np.array([0.0, 0.0, -0.5]), radius=0.4, height=0.9, color=glaze),
        Torus(np.array([0.45, 0.0, -0.05]), R=_rot_z_to(np.array([0.0, 1.0, 0.0])), major=0.24, minor=0.045,
              color=glaze),
    ]


def parcel() -> list[Primitive]:
    """A box printed with diagonal tape and a beach ball on it: texture, which is not structure. The print's
    edges are as strong as the box's and as consistent across the views, but lie on flat or smooth faces;
    a sketch draws the box's edges and the ball's outline, not the print."""
    return [
        Box(np.array([0.0, 0.0, -0.55]), half=np.array([0.6, 0.45, 0.35]), color=(0.8, 0.66, 0.45), print="stripes"),
        Sphere(np.array([0.0, 0.0, 0.16]), radius=0.36, color=(0.9, 0.9, 0.92), print="gores"),
    ]


def teapot() -> list[Primitive]:
    """A teapot: a round body, a lid with a knob, a spout and a ring handle. A compact abstraction draws it as a
    few superquadrics (body, lid, spout) and curves (the handle), and must draw all four parts at every level."""
    glaze = (0.78, 0.84, 0.8)
    return [
        Ellipsoid(np.array([0.0, 0.0, -0.25]), axes=np.array([0.58, 0.58, 0.42]), color=glaze),
        Cylinder(np.array([0.0, 0.0, 0.1]), radius=0.3, height=0.08, color=(0.7, 0.76, 0.72)),
        Sphere(np.array([0.0, 0.0, 0.26]), radius=0.09, color=(0.6, 0.65, 0.62)),
        Cone(np.array([0.42, 0.0, -0.32]), R=_rot_z_to(np.array([1.0, 0.0, 1.1])), radius=0.13, height=0.62,
             color=glaze),
        Torus(np.array([-0.62, 0.0, -0.2]), R=_rot_z_to(np.array([0.0, 1.0, 0.0])), major=0.22, minor=0.05,
              color=glaze),
    ]


def cow() -> list[Primitive]:
    """A toy cow facing +x: a body, a head, four stubby legs, two ears and a thin tail. Parts a person names at
    a glance, which a compact abstraction must keep: a superquadric each for the body, the head and the legs."""
    hide, dark = (0.92, 0.9, 0.86), (0.3, 0.26, 0.24)
    legs = [Cylinder(np.array([sx * 0.36, sy * 0.17, -0.72]), radius=0.09, height=0.55, color=dark)
            for sx in (-1, 1) for sy in (-1, 1)]
    return [
        Ellipsoid(np.array([0.0, 0.0, 0.0]), axes=np.array([0.62, 0.3, 0.3]), color=hide),
        Ellipsoid(np.array([0.74, 0.0, 0.2]), axes=np.array([0.22, 0.15, 0.16]), color=(0.85, 0.8, 0.76)),
        *legs,
        *[Ellipsoid(np.array([0.7, sy * 0.2, 0.33]), axes=np.array([0.04, 0.1, 0.04]), color=dark) for sy in (-1, 1)],
        _rod(np.array([-0.6, 0.0, 0.08]), np.array([-0.75, 0.0, -0.35]), 0.018, dark),
    ]


def calf() -> list[Primitive]:
    """The toy cow painted as a cartoon: eyes and a muzzle with nostrils on its head, dark patches on its hide.
    A person sketching it draws the eyes and the muzzle first, then the patches; the ground truth's
    ``painted`` boundaries (:func:`painted_boundaries`) measure how many of them a sketch draws."""
    parts = cow()
    parts[0].print, parts[1].print = "patches", "face"
    return parts


def mouse() -> list[Primitive]:
    """A computer mouse facing +x: a rounded shell with the seams of its two buttons and rubber grips painted
    on, and a scroll wheel standing out between the buttons. What a person draws inside its outline: the
    seams, the wheel and the edge of the grips (the ground truth's painted boundaries, and the wheel's
    edges)."""
    return [
        Ellipsoid(np.array([0.0, 0.0, -0.3]), axes=np.array([0.62, 0.36, 0.26]), color=(0.82, 0.82, 0.85),
                  print="mouse"),
        Cylinder(np.array([0.3, -0.02, -0.09]), R=_rot_z_to(np.array([0.0, 1.0, 0.0])), radius=0.075, height=0.04,
                 color=(0.25, 0.25, 0.28)),
    ]


SCENES: dict[str, Callable[[], list[Primitive]]] = {"chair": chair, "snowman": snowman, "lamp": lamp, "tripod": tripod,
                                                    "mug": mug, "parcel": parcel, "teapot": teapot, "cow": cow,
                                                    "calf": calf, "mouse": mouse}


def visible_feature_edges(primitives: list[Primitive], max_len: float = 0.04, margin: float = 2e-3) -> np.ndarray:
    """Feature-edge segments ``(K, 2, 3)`` split to ≤ ``max_len`` with pieces inside (or on) another primitive
    removed: a leg's top edge lying on the seat's underside is no line anyone would draw."""
    out = []
    for i, prim in enumerate(primitives):
        for a, b in prim.feature_edges():
            k = max(1, math.ceil(np.linalg.norm(b - a) / max_len))
            ts = np.linspace(0, 1, k + 1)
            pts = a + ts[:, None] * (b - a)
            mids = 0.5 * (pts[1:] + pts[:-1])
            hidden = np.zeros(k, bool)
            for j, other in enumerate(primitives):
                if j != i:
                    hidden |= other.contains(mids, margin)
            out.extend(np.stack([pts[:-1], pts[1:]], 1)[~hidden])
    return np.array(out).reshape(-1, 2, 3)


def sample_cameras(split: str, n: int, size: int = SIZE) -> list[Camera]:
    """Deterministic cameras on the upper hemisphere looking at the origin (train: golden-angle spiral)."""
    f = 0.5 * size / math.tan(math.radians(FOV_DEG) / 2)
    cams = []
    for i in range(n):
        if split == "train":
            az, el = i * 137.50776405, 8.0 + 62.0 * (i + 0.5) / n
        else:
            az, el = 17.0 + 360.0 * i / n, 22.0 + 22.0 * (i % 2)
        a, e = math.radians(az), math.radians(el)
        eye = DISTANCE * np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])
        R, t = look_at(eye, np.zeros(3), np.array([0.0, 0, 1]))
        cams.append(Camera(f, f, size / 2, size / 2, size, size, R, t, name=f"r_{i}"))
    return cams


def _blender_c2w(cam: Camera) -> list[list[float]]:
    return (cam.c2w @ np.diag([1.0, -1.0, -1.0, 1.0])).tolist()  # OpenCV → Blender axes


def sample_target(name: str, out_dir: str | os.PathLike, force: bool) -> Path:
    """The folder a sample scene goes to, checked: a known name, and a missing or empty folder unless ``force``.

    Raises:
        DoodleError: unknown name, or ``out_dir`` exists and is not empty without ``force``.
    """
    if name not in SCENES:
        raise DoodleError(f"unknown sample scene {name!r} (choose from {', '.join(SCENES)})")
    out = Path(out_dir)
    if out.exists() and (not out.is_dir() or any(out.iterdir())) and not force:
        raise DoodleError(f"{out}: exists and is not empty (use --force to replace it)")
    return out


def write_sample(name: str, out_dir: str | os.PathLike, n_train: int = N_TRAIN, n_test: int = N_TEST,
                 size: int = SIZE, force: bool = False, supersample: int = 2) -> Path:
    """Render scene ``name`` into ``out_dir`` (built in a sibling folder that replaces it whole at the end,
    see :func:`doodle.atomic.atomic_folder`).

    Raises:
        DoodleError: unknown name, or ``out_dir`` exists and is not empty without ``force``.
    """
    out = sample_target(name, out_dir, force)
    prims = SCENES[name]()
    with atomic_folder(out, keep_others=False) as tmp:
        for split, n in (("train", n_train), ("test", n_test)):
            (tmp / split).mkdir()
            frames = []
            for cam in sample_cameras(split, n, size):
                Image.fromarray(render_rgba(prims, cam, supersample)).save(tmp / split / f"{cam.name}.png")
                frames.append({"file_path": f"./{split}/{cam.name}", "transform_matrix": _blender_c2w(cam)})
            doc = {"camera_angle_x": math.radians(FOV_DEG), "frames": frames}
            (tmp / f"transforms_{split}.json").write_text(json.dumps(doc, indent=1))
        gt = {"name": name, "up": [0, 0, 1], "primitives": [p.to_dict() for p in prims],
              "feature_edges": visible_feature_edges(prims).round(6).tolist()}
        (tmp / "ground_truth.json").write_text(json.dumps(gt))
    return out


def load_ground_truth(scene_dir: str | os.PathLike) -> dict:
    """Read ``ground_truth.json``; ``feature_edges`` becomes an ``(K, 2, 3)`` array and ``primitives`` objects."""
    path = Path(scene_dir) / "ground_truth.json"
    try:
        doc = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise DoodleError(f"{path}: cannot read ground truth ({exc})") from None
    doc["feature_edges"] = np.asarray(doc["feature_edges"], float).reshape(-1, 2, 3)
    doc["primitives"] = [primitive_from_dict(p) for p in doc["primitives"]]
    return doc


def primitive_from_dict(d: dict) -> Primitive:
    kinds = {"sphere": Sphere, "box": Box, "cylinder": Cylinder, "cone": Cone, "torus": Torus, "ellipsoid": Ellipsoid}
    cls = kinds[d["type"]]
    kw = {"center": np.asarray(d["center"], float), "R": np.asarray(d["rotation_matrix"], float), "color": tuple(d["color"]),
          "print": d.get("print", "")}
    if "half_size" in d:
        kw["half"] = np.asarray(d["half_size"], float)
    if "axes" in d:
        kw["axes"] = np.asarray(d["axes"], float)
    for key in ("radius", "height", "major", "minor"):
        if key in d:
            kw[key] = float(d[key])
    return cls(**kw)
