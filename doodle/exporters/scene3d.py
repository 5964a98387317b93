"""3D export of a stroke set: the curves and superquadrics themselves, for 3D tools (OBJ, PLY).

Coordinates are the stroke file's scene units, unchanged, in its own frame: ``frame.up`` is written in a
header comment (NeRF-synthetic and the procedural scenes: +z up, as Blender; COLMAP: whatever the model's
frame is). Curves become sampled polylines, every sample on the exact cubic — in OBJ an object per curve
whose polyline is a chain of ``l`` segments, in PLY ``edge`` elements — and, in OBJ, also the exact cubic as
a free-form ``curv`` (``cstype bezier``, degree 3, in a block from ``cstype`` to ``end``), which readers that
know free-form geometry use and the others skip (checked with trimesh, Open3D/Assimp and Blender's importer). Superquadrics become closed
triangle meshes (:func:`superquadric_mesh`), each in its own object. Pure numpy: no torch.
"""

from __future__ import annotations

import numpy as np

from ..strokes.bezier import bezier_points
from ..strokes.model import StrokeSet, SuperquadricSet
from ..strokes.superquadric import quaternion_to_matrix, surface_points_at
from .silhouettes import angle_warp

#: Samples per curve in the polylines (the exact cubic is the OBJ ``curv``).
CURVE_SAMPLES = 32


def superquadric_mesh(sq: SuperquadricSet, i: int, n_eta: int = 24, n_omega: int = 48
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Closed triangle mesh of superquadric ``i``: vertices ``(V, 3)`` in world coordinates and faces
    ``(F, 3)`` (counter-clockwise seen from outside). ``n_eta − 1`` rings of ``n_omega`` vertices between two
    poles, spaced evenly in the profiles' polar angles, so box-like ones keep their edges."""
    e1, e2 = float(sq.shape[i, 0]), float(sq.shape[i, 1])
    eta = angle_warp(np.linspace(-np.pi / 2, np.pi / 2, n_eta + 1)[1:-1], e1)
    omega = angle_warp(np.linspace(-np.pi, np.pi, n_omega, endpoint=False), e2)
    E, O = np.meshgrid(eta, omega, indexing="ij")
    eta_all = np.concatenate([[-np.pi / 2], E.ravel(), [np.pi / 2]])
    omega_all = np.concatenate([[0.0], O.ravel(), [0.0]])
    local, _ = surface_points_at(eta_all, omega_all, np.broadcast_to(sq.scale[i], (len(eta_all), 3)),
                                 np.broadcast_to(sq.shape[i], (len(eta_all), 2)))
    R = quaternion_to_matrix(sq.rotation[i])
    verts = local @ R.T + sq.translation[i]
    rings, n = n_eta - 1, n_omega
    idx = 1 + np.arange(rings * n).reshape(rings, n)
    nxt = np.roll(idx, -1, axis=1)
    faces = [np.stack([np.zeros(n, int), nxt[0], idx[0]], 1)]  # the bottom pole's fan
    a, b, c, d = idx[:-1], nxt[:-1], nxt[1:], idx[1:]
    faces += [np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)]
    top = len(verts) - 1
    faces.append(np.stack([np.full(n, top), idx[-1], nxt[-1]], 1))
    return verts, np.concatenate(faces)


def curve_polylines(strokes: StrokeSet, samples: int = CURVE_SAMPLES) -> np.ndarray:
    """``(N, samples, 3)`` points on each curve, evenly in its parameter, ends included."""
    return bezier_points(strokes.curves.control_points, np.linspace(0.0, 1.0, samples))


def _f(v: float) -> str:
    return f"{v:.6g}"


def to_obj(strokes: StrokeSet, samples: int = CURVE_SAMPLES) -> str:
    """Wavefront OBJ text: per curve an object ``curve-NNN`` with its polyline (``l`` segments) and its exact cubic
    (``curv``, on the control points, written after the polyline's vertices), per superquadric an object
    ``superquadric-NN`` with its closed mesh (``f``)."""
    up = ", ".join(_f(v) for v in strokes.frame.up)
    out = [f"# doodle stroke set: {len(strokes.curves)} curves, {len(strokes.superquadrics)} superquadrics",
           f"# scene units; up = ({up}); polylines sample the exact cubic Béziers given as curv"]
    base = 1
    for n, (poly, ctrl) in enumerate(zip(curve_polylines(strokes, samples), strokes.curves.control_points)):
        out.append(f"o curve-{n:03d}")
        out += [f"v {_f(p[0])} {_f(p[1])} {_f(p[2])}" for p in poly]
        # the polyline as a chain of two-point ``l`` elements: Blender 3.4's importer keeps only the first two
        # points of a longer one; every reader takes these (one object, one connected chain a curve)
        out += [f"l {base + k} {base + k + 1}" for k in range(len(poly) - 1)]
        base += len(poly)
        out += [f"v {_f(p[0])} {_f(p[1])} {_f(p[2])}" for p in ctrl]
        # the free-form state is set again before each curve, so that the block runs from ``cstype`` to
        # ``end``: readers that skip free-form geometry (Assimp, so Open3D and game engines) skip exactly it
        out += ["cstype bezier", "deg 3", f"curv 0.0 1.0 {base} {base + 1} {base + 2} {base + 3}",
                "parm u 0.0 1.0", "end"]
        base += 4
    for i in range(len(strokes.superquadrics)):
        verts, faces = superquadric_mesh(strokes.superquadrics, i)
        out.append(f"o superquadric-{i:02d}")
        out += [f"v {_f(p[0])} {_f(p[1])} {_f(p[2])}" for p in verts]
        out += [f"f {a + base} {b + base} {c + base}" for a, b, c in faces]
        base += len(verts)
    return "\n".join(out) + "\n"


def to_ply(strokes: StrokeSet, samples: int = CURVE_SAMPLES) -> bytes:
    """ASCII PLY: vertices (with the stroke each belongs to: ``stroke`` is the curve's index, or ``−1 − i`` for
    superquadric ``i``), ``edge`` elements along each curve's polyline, ``face`` elements of the meshes."""
    verts, owner, edges, faces = [], [], [], []
    count = 0
    for n, poly in enumerate(curve_polylines(strokes, samples)):
        verts.append(poly)
        owner.append(np.full(len(poly), n))
        edges.append(np.stack([np.arange(len(poly) - 1), np.arange(1, len(poly))], 1) + count)
        count += len(poly)
    for i in range(len(strokes.superquadrics)):
        v, f = superquadric_mesh(strokes.superquadrics, i)
        verts.append(v)
        owner.append(np.full(len(v), -1 - i))
        faces.append(f + count)
        count += len(v)
    V = np.concatenate(verts) if verts else np.zeros((0, 3))
    O = np.concatenate(owner) if owner else np.zeros(0, int)
    E = np.concatenate(edges) if edges else np.zeros((0, 2), int)
    F = np.concatenate(faces) if faces else np.zeros((0, 3), int)
    up = " ".join(_f(v) for v in strokes.frame.up)
    head = ["ply", "format ascii 1.0", f"comment doodle stroke set, scene units, up {up}",
            f"element vertex {len(V)}", "property float x", "property float y", "property float z",
            "property int stroke", f"element face {len(F)}", "property list uchar int vertex_indices",
            f"element edge {len(E)}", "property int vertex1", "property int vertex2", "end_header"]
    body = [f"{_f(p[0])} {_f(p[1])} {_f(p[2])} {o}" for p, o in zip(V, O)]
    body += [f"3 {a} {b} {c}" for a, b, c in F]
    body += [f"{a} {b}" for a, b in E]
    return ("\n".join(head + body) + "\n").encode("ascii")


def blender_addon_source() -> str:
    """The Blender add-on that imports ``.doodle`` files (``doodle/exporters/blender/doodle_import.py``)."""
    from importlib.resources import files

    return files("doodle.exporters").joinpath("blender/doodle_import.py").read_text(encoding="utf-8")
