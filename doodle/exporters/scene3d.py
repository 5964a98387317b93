"""3D export of a stroke set: the curves and superquadrics themselves, for 3D tools (OBJ, PLY, glTF binary).

Coordinates are the stroke file's scene units, unchanged, in its own frame: ``frame.up`` is written in a
header comment (NeRF-synthetic and the procedural scenes: +z up, as Blender; COLMAP: whatever the model's
frame is). Curves become sampled polylines, every sample on the exact cubic — in OBJ an object per curve
whose polyline is a chain of ``l`` segments, in PLY ``edge`` elements — and, in OBJ, also the exact cubic as
a free-form ``curv`` (``cstype bezier``, degree 3, in a block from ``cstype`` to ``end``), which readers that
know free-form geometry use and the others skip (checked with trimesh, Open3D/Assimp and Blender's importer). Superquadrics become closed
triangle meshes (:func:`superquadric_mesh`), each in its own object, and so does the hull of a file that draws
its outline by one (:func:`hull_mesh`: the smoothed boundary of its voxels).

glTF (``.glb``, written by trimesh) is the one format here with a fixed frame: +Y up, so the scene is turned
by the rotation that takes ``frame.up`` to +Y (z-up scenes: ``(x, y, z) → (x, z, −y)``, which Blender's glTF
importer turns back). A curve is a node whose mesh is a ``LINES`` primitive along its polyline, with the exact
control points (in the glTF frame) in the mesh's ``extras``; a superquadric is a node with a triangle mesh.
Pure numpy (and trimesh for glTF): no torch.
"""

from __future__ import annotations

import numpy as np

from ..strokes.bezier import bezier_points
from ..strokes.model import StrokeSet, SuperquadricSet, Voxels
from ..strokes.deform import bend_axis, deform
from ..strokes.superquadric import quaternion_to_matrix, surface_points_at
from .silhouettes import angle_warp

#: Samples per curve in the polylines (the exact cubic is the OBJ ``curv``).
CURVE_SAMPLES = 32


def superquadric_mesh(sq: SuperquadricSet, i: int, n_eta: int = 24, n_omega: int = 48
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Closed triangle mesh of superquadric ``i``: vertices ``(V, 3)`` in world coordinates and faces
    ``(F, 3)`` (counter-clockwise seen from outside). ``n_eta − 1`` rings of ``n_omega`` vertices between two
    poles, spaced evenly in the profiles' polar angles, so box-like ones keep their edges; tapered and bent as
    the superquadric is."""
    e1, e2 = float(sq.shape[i, 0]), float(sq.shape[i, 1])
    eta = angle_warp(np.linspace(-np.pi / 2, np.pi / 2, n_eta + 1)[1:-1], e1)
    omega = angle_warp(np.linspace(-np.pi, np.pi, n_omega, endpoint=False), e2)
    E, O = np.meshgrid(eta, omega, indexing="ij")
    eta_all = np.concatenate([[-np.pi / 2], E.ravel(), [np.pi / 2]])
    omega_all = np.concatenate([[0.0], O.ravel(), [0.0]])
    local, _ = surface_points_at(eta_all, omega_all, np.broadcast_to(sq.scale[i], (len(eta_all), 3)),
                                 np.broadcast_to(sq.shape[i], (len(eta_all), 2)))
    if sq.deformed[i]:
        local = deform(local, sq.scale[i], sq.tapers[i], *bend_axis(sq.bends[i], sq.scale[i]))
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


def hull_mesh(hull: Voxels, max_cells: int = 96) -> tuple[np.ndarray, np.ndarray]:
    """Closed triangle mesh of a voxel volume's boundary: vertices ``(V, 3)`` in world coordinates, faces
    ``(F, 3)`` counter-clockwise from outside. Marching cubes (scikit-image) on the occupancy smoothed by a
    voxel, so the surface is not a staircase, with a step that keeps about ``max_cells`` cells along the longest
    side (Lego's 192-voxel hull: 50 k triangles rather than 200 k)."""
    from scipy.ndimage import gaussian_filter
    from skimage.measure import marching_cubes

    binary = np.pad(hull.occupied, 2).astype(np.float32)
    occ = gaussian_filter(binary, 0.8)
    step = max(1, int(np.ceil(max(hull.occupied.shape) / max_cells)))
    if occ.max() <= 0.5 or hull.occupied.sum() < 64:
        # nothing thicker than a voxel or two (the fit's hulls are opened by a voxel, so never theirs): smoothing
        # would erase it, so the voxels' own faces, at full resolution
        occ, step = binary, 1
    verts, faces, _, _ = marching_cubes(occ, 0.5, step_size=step, allow_degenerate=False)
    # marching cubes winds its faces towards increasing values (inwards here): flip them to face outwards
    return hull.centres(verts - 2.0), faces[:, ::-1].astype(np.int64)


def _meshes(strokes: StrokeSet) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """``(name, vertices, faces)`` of every closed mesh: a superquadric each, then the hull if the file has one."""
    out = [(f"superquadric-{i:02d}", *superquadric_mesh(strokes.superquadrics, i))
           for i in range(len(strokes.superquadrics))]
    if strokes.hull is not None and strokes.hull.occupied.any():
        out.append(("hull", *hull_mesh(strokes.hull)))
    return out


def curve_polylines(strokes: StrokeSet, samples: int = CURVE_SAMPLES) -> np.ndarray:
    """``(N, samples, 3)`` points on each curve, evenly in its parameter, ends included."""
    return bezier_points(strokes.curves.control_points, np.linspace(0.0, 1.0, samples))


def _f(v: float) -> str:
    return f"{v:.6g}"


def to_obj(strokes: StrokeSet, samples: int = CURVE_SAMPLES) -> str:
    """Wavefront OBJ text: per curve an object ``curve-NNN`` with its polyline (``l`` segments) and its exact cubic
    (``curv``, on the control points, written after the polyline's vertices), per superquadric an object
    ``superquadric-NN`` with its closed mesh (``f``), and the hull's mesh as object ``hull`` if the file has one."""
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
    for name, verts, faces in _meshes(strokes):
        out.append(f"o {name}")
        out += [f"v {_f(p[0])} {_f(p[1])} {_f(p[2])}" for p in verts]
        out += [f"f {a + base} {b + base} {c + base}" for a, b, c in faces]
        base += len(verts)
    return "\n".join(out) + "\n"


def to_ply(strokes: StrokeSet, samples: int = CURVE_SAMPLES) -> bytes:
    """ASCII PLY: vertices (with the stroke each belongs to: ``stroke`` is the curve's index, ``−1 − i`` for
    superquadric ``i``, ``−1 − M`` for the hull after ``M`` superquadrics), ``edge`` elements along each curve's
    polyline, ``face`` elements of the meshes."""
    verts, owner, edges, faces = [], [], [], []
    count = 0
    for n, poly in enumerate(curve_polylines(strokes, samples)):
        verts.append(poly)
        owner.append(np.full(len(poly), n))
        edges.append(np.stack([np.arange(len(poly) - 1), np.arange(1, len(poly))], 1) + count)
        count += len(poly)
    for i, (_, v, f) in enumerate(_meshes(strokes)):
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


def y_up_rotation(up: np.ndarray) -> np.ndarray:
    """``(3, 3)`` rotation taking the unit vector ``up`` to +Y by the shortest turn (glTF's frame).

    >>> np.round(y_up_rotation(np.array([0.0, 0.0, 1.0])) @ [1.0, 2.0, 3.0], 6).tolist()
    [1.0, 3.0, -2.0]
    """
    u = np.asarray(up, dtype=float) / np.linalg.norm(up)
    y = np.array([0.0, 1.0, 0.0])
    axis, c = np.cross(u, y), float(u @ y)
    if np.linalg.norm(axis) < 1e-12:  # already +Y, or −Y: half a turn about x
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + K + K @ K / (1.0 + c)  # Rodrigues with sin·k = axis, (1 − cos)/sin² = 1/(1 + cos)


def to_glb(strokes: StrokeSet, samples: int = CURVE_SAMPLES) -> bytes:
    """Binary glTF: a node ``curve-NNN`` per curve (a ``LINES`` mesh along its polyline; the exact cubic's control
    points in the mesh's ``extras.bezier``), a node ``superquadric-NN`` per superquadric and ``hull`` for a hull
    (closed meshes), turned to glTF's +Y up. trimesh reads each curve back as a ``Path3D`` of one ``Line``."""
    import trimesh
    from trimesh.path.entities import Line

    R = y_up_rotation(strokes.frame.up)
    scene = trimesh.Scene()
    for n, (poly, ctrl) in enumerate(zip(curve_polylines(strokes, samples), strokes.curves.control_points)):
        path = trimesh.path.Path3D(entities=[Line(np.arange(len(poly)))], vertices=poly @ R.T, process=False,
                                   metadata={"bezier": np.round(ctrl @ R.T, 7).tolist()})
        scene.add_geometry(path, geom_name=f"curve-{n:03d}", node_name=f"curve-{n:03d}")
    for name, verts, faces in _meshes(strokes):
        scene.add_geometry(trimesh.Trimesh(verts @ R.T, faces, process=False), geom_name=name, node_name=name)
    return scene.export(file_type="glb")


#: The 3D formats :func:`encode_3d` writes, by file suffix.
FORMATS_3D = (".obj", ".ply", ".glb")


def encode_3d(strokes: StrokeSet, suffix: str, samples: int = CURVE_SAMPLES) -> bytes:
    """The stroke set as a 3D file's bytes, by its suffix (one of :data:`FORMATS_3D`)."""
    if suffix == ".obj":
        return to_obj(strokes, samples).encode()
    if suffix == ".ply":
        return to_ply(strokes, samples)
    if suffix == ".glb":
        return to_glb(strokes, samples)
    raise ValueError(f"unknown 3D format {suffix or '(no suffix)'!r} (use {', '.join(FORMATS_3D)})")


def blender_addon_source() -> str:
    """The Blender add-on that imports ``.doodle`` files (``doodle/exporters/blender/doodle_import.py``)."""
    from importlib.resources import files

    return files("doodle.exporters").joinpath("blender/doodle_import.py").read_text(encoding="utf-8")
