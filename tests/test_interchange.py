"""3D interchange: OBJ, PLY and glTF exports read by real readers (trimesh, Open3D, Blender's importers), and the
Blender add-on run in the real Blender (headless). Tests that need Open3D or Blender skip cleanly without them."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from doodle.cameras import orbit_cameras
from doodle.cli import cli
from doodle.exporters.scene3d import (blender_addon_source, curve_polylines, hull_mesh, superquadric_mesh, to_glb,
                                      to_obj, to_ply, y_up_rotation)
from doodle.strokes import read_strokes, write_strokes
from doodle.strokes.model import Voxels
from doodle.strokes.superquadric import quaternion_to_matrix

from helpers import random_strokes


@pytest.fixture
def strokes():
    return random_strokes(3, n_curves=7, n_sq=3)


@pytest.mark.parametrize("shape", [(1.0, 1.0), (0.1, 0.1), (1.9, 0.3), (0.3, 1.9)])
def test_superquadric_mesh_is_closed_and_on_the_surface(shape):
    """Every edge is shared by exactly two triangles (V − E + F = 2), the winding is consistent, and every
    vertex lies on the surface (f = 1)."""
    from doodle.strokes.model import SuperquadricSet
    from doodle.strokes.superquadric import inside_outside, world_to_local

    sq = SuperquadricSet(np.array([[0.3, 0.5, 0.7]]), np.array([shape]), np.array([[0.9, 0.1, -0.3, 0.2]]) /
                         np.linalg.norm([0.9, 0.1, -0.3, 0.2]), np.array([[0.1, -0.2, 0.3]]))
    v, f = superquadric_mesh(sq, 0)
    directed = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    edges = {tuple(e) for e in directed.tolist()}
    assert len(edges) == len(directed)  # no directed edge twice: consistent winding
    undirected = {tuple(sorted(e)) for e in edges}
    assert all((b, a) in edges for a, b in edges)  # every edge has its twin
    assert len(v) - len(undirected) + len(f) == 2
    fx = inside_outside(world_to_local(v, sq.rotation, sq.translation), sq.scale, sq.shape)[0]
    assert np.allclose(fx, 1.0, atol=1e-6)


def _obj_polylines(lines: list[str]) -> dict[str, list[int]]:
    """Each object's ``l`` elements followed as one chain of 0-based vertex indices (asserting they chain)."""
    out: dict[str, list[int]] = {}
    name = ""
    for ln in lines:
        if ln.startswith("o "):
            name = ln[2:]
        elif ln.startswith("l "):
            idx = [int(k) - 1 for k in ln.split()[1:]]
            chain = out.setdefault(name, [])
            assert not chain or chain[-1] == idx[0], f"{name}: the segments do not chain"
            chain += idx if not chain else idx[1:]
    return out


def test_obj_has_one_polyline_and_one_exact_cubic_per_curve(strokes):
    text = to_obj(strokes)
    lines = text.splitlines()
    assert sum(ln.startswith("o curve-") for ln in lines) == len(strokes.curves)
    chains = _obj_polylines(lines)
    assert sorted(chains) == [f"curve-{n:03d}" for n in range(len(strokes.curves))]
    assert all(len(c) == len(curve_polylines(strokes)[0]) for c in chains.values())
    assert sum(ln.startswith("curv ") for ln in lines) == len(strokes.curves)
    assert sum(ln.startswith("o superquadric-") for ln in lines) == len(strokes.superquadrics)
    verts = np.array([[float(x) for x in ln.split()[1:]] for ln in lines if ln.startswith("v ")])
    # the curv records point at the exact control points
    for n, ln in enumerate(ln for ln in lines if ln.startswith("curv ")):
        idx = [int(k) - 1 for k in ln.split()[3:]]
        assert np.allclose(verts[idx], strokes.curves.control_points[n], atol=1e-5)
    # the polylines' points are on the cubics
    for n, poly in enumerate(curve_polylines(strokes)):
        assert np.allclose(verts[chains[f"curve-{n:03d}"]], poly, atol=1e-5)


def test_obj_free_form_blocks_are_skipped_whole_by_readers_that_skip_them(strokes):
    """Assimp (Open3D, game engines) skips from ``cstype`` to ``end``: every free-form statement must be inside
    such a block and nothing else (a ``parm`` outside is read as a point element and fails the whole file)."""
    inside = False
    for ln in to_obj(strokes).splitlines():
        word = ln.split()[0]
        if word == "cstype":
            assert not inside
            inside = True
        elif inside:
            assert word in {"deg", "curv", "parm", "end"}, ln
            inside = word != "end"
        else:
            assert word in {"#", "o", "v", "l", "f"}, ln
    assert not inside


def test_obj_loads_in_open3d(strokes, tmp_path):
    """Open3D reads OBJ through Assimp: the superquadric meshes come in whole, the free-form blocks skipped."""
    o3d = pytest.importorskip("open3d", reason="needs Open3D, an optional extra (pip install -e '.[open3d]')")
    (tmp_path / "s.obj").write_text(to_obj(strokes))
    mesh = o3d.io.read_triangle_mesh(str(tmp_path / "s.obj"))
    per_sq = superquadric_mesh(strokes.superquadrics, 0)
    assert len(mesh.triangles) == len(per_sq[1]) * len(strokes.superquadrics)
    assert len(mesh.vertices) == len(per_sq[0]) * len(strokes.superquadrics)
    (tmp_path / "s.ply").write_bytes(to_ply(strokes))
    lines = o3d.io.read_line_set(str(tmp_path / "s.ply"))
    assert len(lines.lines) == len(strokes.curves) * (len(curve_polylines(strokes)[0]) - 1)


def test_obj_and_ply_load_in_trimesh(strokes, tmp_path):
    """trimesh reads the OBJ's superquadric meshes, the PLY's meshes, and a curves-only PLY as one path entity
    per curve (its OBJ reader skips ``l`` elements, so the curves are checked in the PLY)."""
    trimesh = pytest.importorskip("trimesh")
    from dataclasses import replace

    from doodle.strokes.model import SuperquadricSet

    per_sq = len(superquadric_mesh(strokes.superquadrics, 0)[1])
    (tmp_path / "s.obj").write_text(to_obj(strokes))
    mesh = trimesh.load(tmp_path / "s.obj", force="mesh")
    assert len(mesh.faces) == per_sq * len(strokes.superquadrics)
    (tmp_path / "s.ply").write_bytes(to_ply(strokes))
    assert len(trimesh.load(tmp_path / "s.ply").faces) == per_sq * len(strokes.superquadrics)
    (tmp_path / "c.ply").write_bytes(to_ply(replace(strokes, superquadrics=SuperquadricSet())))
    path = trimesh.load(tmp_path / "c.ply")
    assert len(path.entities) == len(strokes.curves)
    for entity, poly in zip(path.entities, curve_polylines(strokes)):
        assert np.allclose(path.vertices[entity.points], poly, atol=1e-5)


def _ball_hull() -> Voxels:
    """A ball of radius 0.5 on a turned 24³ grid of 0.05 voxels."""
    ijk = np.stack(np.meshgrid(*[np.arange(24)] * 3, indexing="ij"), -1)
    R = quaternion_to_matrix(np.array([0.9, 0.2, -0.3, 0.1]) / np.linalg.norm([0.9, 0.2, -0.3, 0.1]))
    vox = Voxels(np.array([0.1, -0.2, 0.3]), 0.05, R, np.zeros((24, 24, 24), bool))
    vox.occupied = np.linalg.norm(vox.centres(ijk.reshape(-1, 3)) - vox.centres(np.array([11.5] * 3)), axis=1
                                  ).reshape(24, 24, 24) < 0.5
    return vox


def test_hull_mesh_is_the_closed_outward_boundary_of_the_voxels():
    trimesh = pytest.importorskip("trimesh")
    vox = _ball_hull()
    v, f = hull_mesh(vox)
    mesh = trimesh.Trimesh(v, f)
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0  # outward normals
    centre = vox.centres(np.array([11.5] * 3))
    assert np.allclose(np.linalg.norm(v - centre, axis=1), 0.5, atol=0.05)  # on the boundary within a voxel
    assert np.isclose(mesh.volume, 4 / 3 * np.pi * 0.5 ** 3, rtol=0.1)


@pytest.mark.parametrize("thin", ["voxel", "plate"])
def test_hull_mesh_keeps_what_smoothing_would_erase(thin):
    """A single voxel or a plate one voxel thick (not the fit's own hulls, which are opened) still meshes closed."""
    trimesh = pytest.importorskip("trimesh")
    occ = np.zeros((12, 12, 12), bool)
    if thin == "voxel":
        occ[5, 6, 7] = True
    else:
        occ[2:10, 2:10, 6] = True
    vox = Voxels(np.array([1.0, 2.0, 3.0]), 0.1, np.eye(3), occ)
    v, f = hull_mesh(vox)
    mesh = trimesh.Trimesh(v, f)
    assert len(f) and mesh.is_watertight and mesh.volume > 0
    lo, hi = vox.centres(np.argwhere(occ)).min(0), vox.centres(np.argwhere(occ)).max(0)
    assert np.all(v >= lo - 0.05 - 1e-6) and np.all(v <= hi + 0.05 + 1e-6)


def test_exports_carry_the_hull_as_a_mesh(strokes, tmp_path):
    """A file that draws its outline by a hull exports the hull's mesh too (object ``hull``)."""
    import trimesh

    strokes.hull = _ball_hull()
    n_faces = len(hull_mesh(strokes.hull)[1])
    assert "o hull" in to_obj(strokes)
    (tmp_path / "s.glb").write_bytes(to_glb(strokes))
    assert len(trimesh.load(tmp_path / "s.glb").geometry["hull"].faces) == n_faces
    (tmp_path / "s.ply").write_bytes(to_ply(strokes))
    ply = trimesh.load(tmp_path / "s.ply")
    per_sq = len(superquadric_mesh(strokes.superquadrics, 0)[1])
    assert len(ply.faces) == n_faces + per_sq * len(strokes.superquadrics)


@pytest.mark.parametrize("up", [(0, 0, 1), (0, 1, 0), (0, -1, 0), (1, 0, 0), (0.3, -0.5, 0.8)])
def test_y_up_rotation_is_a_rotation_taking_up_to_y(up):
    u = np.array(up, float) / np.linalg.norm(up)
    R = y_up_rotation(u)
    assert np.allclose(R @ R.T, np.eye(3)) and np.isclose(np.linalg.det(R), 1.0)
    assert np.allclose(R @ u, [0, 1, 0])


def test_glb_loads_in_trimesh_with_one_polyline_per_curve(strokes, tmp_path):
    """trimesh reads the glTF as a scene of one ``Path3D`` per curve — a single ``Line`` through its samples, in
    order, turned to +Y up, the exact cubic in the extras — and one closed mesh per superquadric."""
    import trimesh

    strokes.frame.up[:] = (0.0, 0.0, 1.0)
    (tmp_path / "s.glb").write_bytes(to_glb(strokes))
    scene = trimesh.load(tmp_path / "s.glb")
    R = y_up_rotation(strokes.frame.up)
    polys = curve_polylines(strokes)
    paths = {k: g for k, g in scene.geometry.items() if k.startswith("curve-")}
    assert len(paths) == len(strokes.curves)
    for n, (poly, ctrl) in enumerate(zip(polys, strokes.curves.control_points)):
        path = paths[f"curve-{n:03d}"]
        assert len(path.entities) == 1 and type(path.entities[0]).__name__ == "Line"
        pts = path.entities[0].discrete(path.vertices)
        pts = pts[np.r_[True, np.any(np.abs(np.diff(pts, axis=0)) > 0, axis=1)]]  # GL_LINES repeats inner points
        assert np.allclose(pts, poly @ R.T, atol=1e-5)
        assert np.allclose(pts @ R, poly, atol=1e-5) and np.allclose(pts[:, 1], poly[:, 2], atol=1e-5)
        assert np.allclose(np.array(path.metadata["bezier"]), ctrl @ R.T, atol=1e-6)
        assert np.allclose(scene.graph[f"curve-{n:03d}"][0], np.eye(4))
    v, f = superquadric_mesh(strokes.superquadrics, 0)
    for i in range(len(strokes.superquadrics)):
        mesh = scene.geometry[f"superquadric-{i:02d}"]
        assert len(mesh.faces) == len(f) and mesh.is_watertight and mesh.is_winding_consistent
        assert np.allclose(mesh.vertices, superquadric_mesh(strokes.superquadrics, i)[0] @ R.T, atol=1e-5)


def test_export3d_command(strokes, tmp_path):
    src = tmp_path / "s.doodleb"
    write_strokes(src, strokes)
    r = CliRunner().invoke(cli, ["export3d", str(src), "-o", str(tmp_path / "s.obj"), "--no-superquadrics"])
    assert r.exit_code == 0, r.output
    assert "o superquadric" not in (tmp_path / "s.obj").read_text()
    r = CliRunner().invoke(cli, ["export3d", str(src), "-o", str(tmp_path / "s.glb")])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "s.glb").read_bytes()[:4] == b"glTF"
    r = CliRunner().invoke(cli, ["export3d", str(src), "-o", str(tmp_path / "s.stl")])
    assert r.exit_code == 2 and "s.stl" in r.output and len(r.output.strip().splitlines()) == 1
    assert not (tmp_path / "s.stl").exists()
    r = CliRunner().invoke(cli, ["export3d", str(src), "-o", str(tmp_path / "e.glb"), "--no-curves",
                                 "--no-superquadrics"])
    assert r.exit_code == 2 and "nothing to write" in r.output and not (tmp_path / "e.glb").exists()


def test_blender_addon_command_writes_the_shipped_file(tmp_path):
    r = CliRunner().invoke(cli, ["blender-addon", "-o", str(tmp_path / "imp.py")])
    assert r.exit_code == 0, r.output
    text = (tmp_path / "imp.py").read_text()
    assert text == blender_addon_source() and "bl_info" in text and "def register" in text
    compile(text, "imp.py", "exec")


def _with_doodle() -> dict:
    """The environment with this installation's ``doodle`` command first on the PATH (as the README's reader
    has it), found beside the Python running the tests, as ``tests/test_readme.py`` finds it."""
    import sys

    doodle = Path(sys.executable).with_name("doodle")
    assert doodle.exists() or shutil.which("doodle"), "the doodle command is not installed (pip install -e .)"
    folder = str(doodle.parent) if doodle.exists() else str(Path(shutil.which("doodle")).parent)
    return dict(os.environ, PATH=os.pathsep.join([folder, os.environ["PATH"]]))


@pytest.mark.timeout(300)
@pytest.mark.skipif(shutil.which("blender") is None, reason="Blender is not installed")
def test_the_readmes_blender_command_works_as_written(tmp_path):
    """``blender -b --python doodle_import.py -- cow.doodleb --views 8 --save cow.blend``, from the folder the
    files are in (relative paths, which Blender itself refuses to save to)."""
    import re

    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text(encoding="utf-8")
    command = next(ln for ln in readme.splitlines() if ln.startswith("blender -b --python doodle_import.py"))
    argv = re.sub(r"\s+#.*$", "", command).split()
    s = random_strokes(4, n_curves=5, n_sq=2)
    write_strokes(tmp_path / argv[argv.index("--") + 1], s)
    (tmp_path / "doodle_import.py").write_text(blender_addon_source())
    save = argv[argv.index("--save") + 1]
    # as from a shell in that folder (Blender reads relative paths against $PWD, which a shell keeps)
    r = subprocess.run([*argv[:1], "--factory-startup", *argv[1:]], cwd=tmp_path, capture_output=True, text=True,
                       timeout=240, env={**_with_doodle(), "PWD": str(tmp_path)})
    assert r.returncode == 0 and (tmp_path / save).is_file(), r.stdout[-1500:] + r.stderr[-1500:]
    assert (tmp_path / save).stat().st_size > 1000


CHECK = """
import bpy, json, sys
from bpy_extras.object_utils import world_to_camera_view
sys.argv = [sys.argv[0], "--", STROKES, "--views", "4"]
exec(open(ADDON).read())
scene = bpy.context.scene
scene.render.resolution_x, scene.render.resolution_y = 200, 100
out = {"curves": [], "meshes": 0, "views": []}
objs = sorted(bpy.data.objects, key=lambda o: o.name)
for o in objs:
    if o.type == "CURVE":
        a, b = o.data.splines[0].bezier_points
        out["curves"].append([list(a.co), list(a.handle_right), list(b.handle_left), list(b.co)])
    out["meshes"] += o.type == "MESH" and o.name.startswith("superquadric-")
    if o.type == "MESH" and o.name.startswith("superquadric-"):
        out.setdefault("vertices", []).append([list(o.matrix_world @ v.co) for v in o.data.vertices])
    if o.name == "hull":
        out["hull"] = [len(o.data.vertices), len(o.data.polygons)]
for cam in [o for o in objs if o.type == "CAMERA" and o.name.startswith("view-")]:
    pts = [world_to_camera_view(scene, cam, o.data.splines[0].bezier_points[0].co) for o in objs if o.type == "CURVE"]
    out["views"].append([[p.x * 200, (1 - p.y) * 100] for p in pts])
print("RESULT " + json.dumps(out))
"""


@pytest.mark.timeout(300)
@pytest.mark.skipif(shutil.which("blender") is None, reason="Blender is not installed")
@pytest.mark.parametrize("suffix", [".doodle", ".doodleb"])
def test_blender_imports_exact_curves_meshes_and_doodles_cameras(strokes, tmp_path, suffix):
    """In the real Blender, headless: one Bézier curve per stroke whose control points equal the file's to
    1e-5, one mesh per superquadric, the hull's mesh (with the doodle command), and orbit cameras that see the curves where doodle's own cameras draw
    them (within 0.05 px at 200 × 100). A binary file is converted by the ``doodle`` command."""
    strokes.hull = _ball_hull()
    m = len(strokes.superquadrics)  # the first one tapered and bent: Blender's mesh is export3d's
    strokes.superquadrics = replace(strokes.superquadrics, taper=np.r_[[[0.4, -0.3]], np.zeros((m - 1, 2))],
                                    bend=np.r_[[[0.5, 0.2]], np.zeros((m - 1, 2))])
    src = tmp_path / f"s{suffix}"
    write_strokes(src, strokes)
    strokes = read_strokes(src)  # the binary file's positions are quantised
    addon = tmp_path / "doodle_import.py"
    addon.write_text(blender_addon_source())
    script = tmp_path / "check.py"
    script.write_text(CHECK.replace("STROKES", repr(str(src))).replace("ADDON", repr(str(addon))))
    r = subprocess.run(["blender", "-b", "--factory-startup", "--python", str(script)], capture_output=True,
                       text=True, timeout=240, env=_with_doodle())
    line = next((ln for ln in r.stdout.splitlines() if ln.startswith("RESULT ")), None)
    assert line is not None, r.stdout[-2000:] + r.stderr[-2000:]
    out = json.loads(line[len("RESULT "):])
    assert np.allclose(np.array(out["curves"]), strokes.curves.control_points, atol=1e-5)
    assert out["meshes"] == len(strokes.superquadrics)
    for i, seen in enumerate(out["vertices"]):
        assert np.allclose(np.array(seen), superquadric_mesh(strokes.superquadrics, i)[0], atol=1e-4)
    v, f = hull_mesh(strokes.hull)  # the hull is meshed by the doodle command, as export3d meshes it
    assert out["hull"] == [len(v), len(f)]
    cams = orbit_cameras(strokes.frame, 4, 200, 100)
    for cam, seen in zip(cams, out["views"]):
        uv, _ = cam.project(strokes.curves.control_points[:, 0])
        assert np.allclose(np.array(seen), uv, atol=0.05), (np.array(seen) - uv)


OBJ_CHECK = """
import bpy, json
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.wm.obj_import(filepath=OBJ)
out = {}
for o in bpy.context.scene.objects:
    m = o.data
    out[o.name] = {"verts": [list(o.matrix_world @ v.co) for v in m.vertices], "edges": [list(e.vertices) for e in m.edges],
                   "faces": len(m.polygons)}
print("RESULT " + json.dumps(out))
"""


@pytest.mark.timeout(300)
@pytest.mark.skipif(shutil.which("blender") is None, reason="Blender is not installed")
def test_blenders_own_obj_importer_reads_a_polyline_per_curve_and_closed_meshes(strokes, tmp_path):
    """Blender's built-in OBJ importer (no add-on): an object per curve whose edges chain through every sample
    in order, and a closed mesh per superquadric."""
    obj = tmp_path / "s.obj"
    obj.write_text(to_obj(strokes))
    script = tmp_path / "check.py"
    script.write_text(OBJ_CHECK.replace("OBJ", repr(str(obj))))
    r = subprocess.run(["blender", "-b", "--factory-startup", "--python", str(script)], capture_output=True,
                       text=True, timeout=240)
    line = next((ln for ln in r.stdout.splitlines() if ln.startswith("RESULT ")), None)
    assert line is not None, r.stdout[-2000:] + r.stderr[-2000:]
    out = json.loads(line[len("RESULT "):])
    # Blender turns OBJ's y-up into its z-up on import (-Y forward): x, y, z → x, −z, y
    to_blender = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]])
    for n, poly in enumerate(curve_polylines(strokes)):
        o = out[f"curve-{n:03d}"]
        verts = np.array(o["verts"])
        assert len(verts) == len(poly) and len(o["edges"]) == len(poly) - 1 and o["faces"] == 0
        # walk the chain from an end: it visits the samples in order
        nbrs: dict[int, list[int]] = {}
        for a, b in o["edges"]:
            nbrs.setdefault(a, []).append(b)
            nbrs.setdefault(b, []).append(a)
        start = next(k for k, v in nbrs.items() if len(v) == 1)
        walk, prev = [start], -1
        while len(walk) < len(verts):
            nxt = next(k for k in nbrs[walk[-1]] if k != prev)
            prev = walk[-1]
            walk.append(nxt)
        pts = verts[walk]
        want = poly @ to_blender.T
        assert np.allclose(pts, want, atol=1e-4) or np.allclose(pts, want[::-1], atol=1e-4)
    v, f = superquadric_mesh(strokes.superquadrics, 0)
    for i in range(len(strokes.superquadrics)):
        o = out[f"superquadric-{i:02d}"]
        assert o["faces"] == len(f) and len(o["verts"]) - len(o["edges"]) + o["faces"] == 2


GLB_CHECK = """
import bpy, json, sys
try:
    import numpy
except ImportError:  # Blender's glTF importer needs numpy in Blender's own Python
    print("NO-NUMPY")
    sys.exit(0)
numpy.bool = bool  # Debian's Blender 3.4 glTF importer still uses numpy.bool, gone since numpy 1.24
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=GLB)
out = {o.name: {"verts": [list(o.matrix_world @ v.co) for v in o.data.vertices], "edges": len(o.data.edges),
                "faces": len(o.data.polygons)} for o in bpy.context.scene.objects if o.type == "MESH"}
print("RESULT " + json.dumps(out))
"""


@pytest.mark.timeout(300)
@pytest.mark.skipif(shutil.which("blender") is None, reason="Blender is not installed")
def test_blenders_gltf_importer_puts_the_strokes_back_in_the_scenes_frame(strokes, tmp_path):
    """Blender's glTF importer turns glTF's +Y up back into its +Z up: a z-up scene's curves come in where the
    stroke file has them, an object per curve, and a closed mesh per superquadric."""
    strokes.frame.up[:] = (0.0, 0.0, 1.0)
    glb = tmp_path / "s.glb"
    glb.write_bytes(to_glb(strokes))
    script = tmp_path / "check.py"
    script.write_text(GLB_CHECK.replace("GLB", repr(str(glb))))
    # a system Blender finds its Python from the PATH: a virtualenv's or pyenv's first hides the system numpy
    env = dict(os.environ, PATH=os.pathsep.join([str(Path(shutil.which("blender")).parent), os.environ["PATH"]]))
    r = subprocess.run(["blender", "-b", "--factory-startup", "--python", str(script)], capture_output=True,
                       text=True, timeout=240, env=env)
    if "NO-NUMPY" in r.stdout:
        pytest.skip("numpy is not installed for Blender's Python, which its glTF importer needs (Debian: python3-numpy)")
    line = next((ln for ln in r.stdout.splitlines() if ln.startswith("RESULT ")), None)
    assert line is not None, r.stdout[-2000:] + r.stderr[-2000:]
    out = json.loads(line[len("RESULT "):])
    for n, poly in enumerate(curve_polylines(strokes)):
        o = out[f"curve-{n:03d}"]
        verts = np.array(o["verts"])
        assert o["faces"] == 0 and o["edges"] == len(poly) - 1
        assert np.allclose(np.unique(verts.round(5), axis=0), np.unique(poly.round(5), axis=0), atol=2e-5)
    per_sq = len(superquadric_mesh(strokes.superquadrics, 0)[1])
    for i in range(len(strokes.superquadrics)):
        assert out[f"superquadric-{i:02d}"]["faces"] == per_sq
