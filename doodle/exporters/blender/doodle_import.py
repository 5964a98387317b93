"""Import a doodle stroke file (``.doodle``, JSON) into Blender.

An add-on (File > Import > doodle strokes) and a script. Curves come in exactly: a doodle curve is a cubic
Bézier and so is a Blender Bézier spline (two points, the inner control points as their handles). Each
superquadric comes in as a closed mesh, and each orbit view of the stroke file's default camera as a camera.
A file that draws its outline by a voxel hull brings the hull in as a closed mesh too (made by the ``doodle``
command: ``doodle export3d``'s smoothed boundary). Scene units and axes are the stroke file's (NeRF-synthetic
and the procedural scenes: +z up, as Blender's).

Script use, headless::

    blender -b --python doodle_import.py -- strokes.doodle [--views 8] [--bevel 0.004] [--no-hull] [--save out.blend]

Binary ``.doodleb`` files are converted by the ``doodle`` command when it is on the PATH (Blender's Python
has no numpy to decode them), else convert first: ``doodle convert s.doodleb s.doodle``. Written out by
``doodle blender-addon``; this file needs nothing but Blender's own Python (bpy, mathutils).
"""

bl_info = {
    "name": "doodle strokes",
    "author": "doodle",
    "version": (1, 1, 0),
    "blender": (3, 0, 0),
    "location": "File > Import > doodle strokes (.doodle)",
    "description": "3D Bézier curves and superquadrics of a doodle stroke file",
    "category": "Import-Export",
}

import json  # noqa: E402
import math  # noqa: E402
import os  # noqa: E402
import shutil  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402

import bpy  # noqa: E402
from mathutils import Vector  # noqa: E402


def _signed_pow(v, e):
    return 0.0 if abs(v) < 1e-9 else math.copysign(abs(v) ** e, v)


def _warp(phi, e):
    """Parameter whose superellipse point lies at polar angle ``phi`` (even spacing on box-like shapes)."""
    c, s = math.cos(phi), math.sin(phi)
    return math.atan2(math.copysign(abs(s) ** (1 / e), s), math.copysign(abs(c) ** (1 / e), c))


def _rotate(q, p):
    """Rotate point ``p`` by the unit quaternion ``q = (w, x, y, z)``."""
    n = math.sqrt(sum(v * v for v in q))
    w, x, y, z = (v / n for v in q)
    R = ((1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)),
         (2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)),
         (2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)))
    return tuple(sum(R[r][c] * p[c] for c in range(3)) for r in range(3))


def _sinc(v):
    return 1.0 if abs(v) < 1e-12 else math.sin(v) / v


def _deform(p, a, taper, bend):
    """Barr's tapering, then bending, of a local point (``doodle.strokes.deform``: the same formulas)."""
    x, y, z = p
    x, y = x * (1 + taper[0] * z / a[2]), y * (1 + taper[1] * z / a[2])
    angle = math.hypot(*bend)
    if angle < 1e-12:
        return x, y, z
    k, dx, dy = angle / a[2], bend[0] / angle, bend[1] / angle
    g, lever = k * z, 1 - k * (x * dx + y * dy)
    s = z * z * 0.5 * _sinc(0.5 * g) ** 2 * k * lever
    return x + s * dx, y + s * dy, z * _sinc(g) * lever


def superquadric_mesh(sq, n_eta=24, n_omega=48):
    """Vertices and triangles of one superquadric (``scale``, ``shape``, ``rotation``, ``translation``, optional
    ``taper`` and ``bend``): the same closed mesh as ``doodle export3d`` writes
    (``doodle.exporters.scene3d.superquadric_mesh``)."""
    a = [float(v) for v in sq["scale"]]
    taper = [float(v) for v in sq.get("taper", (0.0, 0.0))]
    bend = [float(v) for v in sq.get("bend", (0.0, 0.0))]
    e1, e2 = (float(v) for v in sq["shape"])
    t = [float(v) for v in sq["translation"]]

    def point(eta, omega):
        c1 = _signed_pow(math.cos(eta), e1)
        local = (a[0] * c1 * _signed_pow(math.cos(omega), e2), a[1] * c1 * _signed_pow(math.sin(omega), e2),
                 a[2] * _signed_pow(math.sin(eta), e1))
        return tuple(r + o for r, o in zip(_rotate(sq["rotation"], _deform(local, a, taper, bend)), t))

    etas = [_warp(-math.pi / 2 + math.pi * (i + 1) / n_eta, e1) for i in range(n_eta - 1)]
    omegas = [_warp(-math.pi + 2 * math.pi * j / n_omega, e2) for j in range(n_omega)]
    verts = [point(-math.pi / 2, 0.0)] + [point(e, o) for e in etas for o in omegas] + [point(math.pi / 2, 0.0)]
    ring = lambda i, j: 1 + i * n_omega + j % n_omega  # noqa: E731
    faces = [(0, ring(0, j + 1), ring(0, j)) for j in range(n_omega)]
    for i in range(n_eta - 2):
        for j in range(n_omega):
            faces += [(ring(i, j), ring(i, j + 1), ring(i + 1, j + 1)), (ring(i, j), ring(i + 1, j + 1), ring(i + 1, j))]
    top = len(verts) - 1
    faces += [(top, ring(n_eta - 2, j), ring(n_eta - 2, j + 1)) for j in range(n_omega)]
    return verts, faces


def orbit(scene, views):
    """``(location, look-at, fov)`` of ``views`` cameras orbiting ``up`` as ``doodle export --views`` does."""
    up = Vector(scene["up"]).normalized()
    centre = Vector(scene["center"])
    cam = scene.get("camera", {})
    dist, el = float(cam.get("distance", 4.0)), math.radians(float(cam.get("elevation_deg", 30.0)))
    az0 = math.radians(float(cam.get("azimuth_deg", 0.0)))
    ref = Vector((1.0, 0, 0)) if abs(up.x) < 0.9 else Vector((0, 1.0, 0))
    e1 = (ref - up * ref.dot(up)).normalized()
    e2 = up.cross(e1)
    out = []
    for k in range(views):
        az = az0 + 2 * math.pi * k / views
        d = math.cos(el) * (math.cos(az) * e1 + math.sin(az) * e2) + math.sin(el) * up
        out.append((centre + dist * d, centre, math.radians(float(cam.get("fov_deg", 39.6)))))
    return out


def read_document(path):
    """The stroke file as JSON data; a binary file is converted by the ``doodle`` command on the PATH."""
    with open(path, "rb") as fh:
        raw = fh.read()
    if raw[:4] == b"DDLB":
        doodle = shutil.which("doodle")
        if doodle is None:
            raise ValueError(f"{path}: a binary stroke file and no doodle command to convert it "
                             f"(run: doodle convert {path} {os.path.splitext(path)[0]}.doodle)")
        with tempfile.TemporaryDirectory() as tmp:
            out = os.path.join(tmp, "strokes.doodle")
            done = subprocess.run([doodle, "convert", path, out], capture_output=True, text=True)
            if done.returncode != 0:
                raise ValueError((done.stderr.strip() or f"{path}: doodle convert failed").splitlines()[-1])
            with open(out, "rb") as fh:
                raw = fh.read()
    try:
        doc = json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, ValueError):
        doc = None
    if not isinstance(doc, dict) or doc.get("format") != "doodle-strokes":
        raise ValueError(f"{path}: not a doodle stroke file")
    return doc


def read_ply_mesh(path):
    """Vertices and faces of an ASCII PLY as written by ``doodle export3d`` (its ``edge`` elements skipped)."""
    with open(path, encoding="ascii") as fh:
        lines = fh.read().splitlines()
    end = lines.index("end_header")
    counts = {ln.split()[1]: int(ln.split()[2]) for ln in lines[:end] if ln.startswith("element ")}
    rows = lines[end + 1:]
    nv, nf = counts.get("vertex", 0), counts.get("face", 0)
    verts = [tuple(float(x) for x in r.split()[:3]) for r in rows[:nv]]
    faces = [tuple(int(x) for x in r.split()[1:]) for r in rows[nv:nv + nf]]
    return verts, faces


def hull_mesh(path):
    """The hull's closed mesh, by ``doodle export3d`` (the ``doodle`` command on the PATH): vertices, faces."""
    doodle = shutil.which("doodle")
    if doodle is None:
        raise ValueError(f"{path}: its hull needs the doodle command to be meshed (or import with --no-hull)")
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "hull.ply")
        done = subprocess.run([doodle, "export3d", path, "-o", out, "--no-curves", "--no-superquadrics"],
                              capture_output=True, text=True)
        if done.returncode != 0:
            raise ValueError((done.stderr.strip() or f"{path}: doodle export3d failed").splitlines()[-1])
        return read_ply_mesh(out)


def import_strokes(path, views=8, bevel=None, collection_name=None, hull=True):
    """Create the stroke file's curves, superquadrics, hull (``hull``: if it has one) and orbit cameras in a new
    collection; returns it."""
    doc = read_document(path)
    scene = doc["scene"]
    radius = float(scene.get("radius", 1.0))
    coll = bpy.data.collections.new(collection_name or "doodle")
    bpy.context.scene.collection.children.link(coll)
    for i, ctrl in enumerate(doc.get("curves", {}).get("control_points", [])):
        data = bpy.data.curves.new(f"curve-{i:03d}", type="CURVE")
        data.dimensions = "3D"
        data.bevel_depth = 0.004 * radius if bevel is None else bevel
        spline = data.splines.new("BEZIER")
        spline.bezier_points.add(1)
        p0, p1, p2, p3 = (Vector(p) for p in ctrl)
        a, b = spline.bezier_points
        for point in (a, b):
            point.handle_left_type = point.handle_right_type = "FREE"
        a.co, a.handle_right, a.handle_left = p0, p1, p0 - (p1 - p0)
        b.co, b.handle_left, b.handle_right = p3, p2, p3 + (p3 - p2)
        coll.objects.link(bpy.data.objects.new(f"curve-{i:03d}", data))
    for i, sq in enumerate(doc.get("superquadrics", [])):
        verts, faces = superquadric_mesh(sq)
        mesh = bpy.data.meshes.new(f"superquadric-{i:02d}")
        mesh.from_pydata(verts, [], faces)
        mesh.update()
        coll.objects.link(bpy.data.objects.new(f"superquadric-{i:02d}", mesh))
    if hull and doc.get("hull"):
        verts, faces = hull_mesh(path)
        mesh = bpy.data.meshes.new("hull")
        mesh.from_pydata(verts, [], faces)
        mesh.update()
        coll.objects.link(bpy.data.objects.new("hull", mesh))
    for k, (loc, target, fov) in enumerate(orbit(scene, views)):
        cam = bpy.data.cameras.new(f"view-{k:03d}")
        cam.angle = fov
        obj = bpy.data.objects.new(f"view-{k:03d}", cam)
        obj.location = loc
        obj.rotation_euler = (target - loc).to_track_quat("-Z", "Y").to_euler()
        coll.objects.link(obj)
    bpy.context.view_layer.update()  # world matrices of the new objects, for scripts that use them next
    return coll


class ImportDoodle(bpy.types.Operator):
    """Import a doodle stroke file"""

    bl_idname = "import_scene.doodle"
    bl_label = "Import doodle strokes"
    filename_ext = ".doodle"
    filepath: bpy.props.StringProperty(subtype="FILE_PATH")
    views: bpy.props.IntProperty(name="Orbit cameras", default=8, min=0, max=360)
    hull: bpy.props.BoolProperty(name="Hull as a mesh", default=True,
                                 description="Mesh the file's voxel hull, if it has one (needs the doodle command)")

    def execute(self, context):
        try:
            import_strokes(self.filepath, self.views, hull=self.hull)
        except (OSError, ValueError, KeyError) as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        return {"FINISHED"}

    def invoke(self, context, event):
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}


def _menu(self, context):
    self.layout.operator(ImportDoodle.bl_idname, text="doodle strokes (.doodle)")


def register():
    bpy.utils.register_class(ImportDoodle)
    bpy.types.TOPBAR_MT_file_import.append(_menu)


def unregister():
    bpy.types.TOPBAR_MT_file_import.remove(_menu)
    bpy.utils.unregister_class(ImportDoodle)


def _main(argv):
    import argparse

    ap = argparse.ArgumentParser(prog="doodle_import.py")
    ap.add_argument("strokes")
    ap.add_argument("--views", type=int, default=8)
    ap.add_argument("--bevel", type=float, default=None)
    ap.add_argument("--no-hull", dest="hull", action="store_false", help="leave out the hull's mesh")
    ap.add_argument("--save", help="write the scene to this .blend file")
    args = ap.parse_args(argv)
    # Paths as the user typed them, from the folder Blender was started in: Blender refuses to save to a
    # relative path ("cannot save blend file, path ... is not writable"), and reads its own // as the .blend's
    import_strokes(os.path.abspath(args.strokes), args.views, args.bevel, hull=args.hull)
    if args.save:
        bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(args.save))


if __name__ == "__main__":
    _main(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else [])
