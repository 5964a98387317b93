"""The ``.doodle`` stroke file: JSON v1 (DESIGN.md) with strict validation (files on disk: :mod:`.files`).

Readers check every field and raise :class:`~doodle.errors.StrokeFileError` with a message that names the
file and the field (``lego.doodle: curves.control_points[3][1]: expected 3 numbers``). Unknown keys of the
top level, ``scene``, ``scene.camera`` and ``curves`` are kept in :attr:`StrokeSet.extra` and written back.
"""

from __future__ import annotations

import base64
import json
import math
import zlib
from typing import Any

import numpy as np

from ..errors import StrokeFileError
from .model import OUTLINE_CELLS, CurveSet, DefaultCamera, SceneFrame, StrokeSet, SuperquadricSet, Voxels

FORMAT = "doodle-strokes"
VERSION = 1
MAX_CURVES = 65535
MAX_SUPERQUADRICS = 255
MAX_FILE_BYTES = 64 * 1024 * 1024
SHAPE_RANGE = (0.1, 1.9)
#: A superquadric's tapering factors and bend (radians over its half-length) in a file (:mod:`.deform`).
TAPER_LIMIT = 1.0
BEND_LIMIT = math.pi / 2
#: Largest coordinate (scene units) and radius the readers accept: far beyond any capture, far below what
#: float32 drawing and the binary format's 32-bit quantisation can no longer handle.
MAX_COORD = 1e6
MIN_RADIUS = 1e-6
MIN_CANVAS, MAX_CANVAS = 16, 16384
_QUAT_TOL = 1e-3
#: A voxel volume's (``occluder``, ``hull``) largest side and its base64 text's largest length: 256³ bits inflate
#: to 2 MB.
MAX_VOXEL_SIDE = 256
MAX_VOXEL_TEXT = 4 * 1024 * 1024

_KNOWN = {
    "": {"format", "version", "scene", "curves", "superquadrics", "provenance", "occluder", "hull"},
    "scene": {"up", "center", "radius", "camera"},
    "scene.camera": {"fov_deg", "distance", "elevation_deg", "width", "height", "azimuth_deg"},
    "curves": {"control_points", "width_px", "normals", "contour"},
}


class _Invalid(Exception):
    """Internal: a field failed validation (message names the field)."""


def _obj(value: Any, name: str) -> dict:
    if not isinstance(value, dict):
        raise _Invalid(f"{name}: expected an object, got {type(value).__name__}")
    return value


def _number(value: Any, name: str, lo: float = -MAX_COORD, hi: float = MAX_COORD, lo_open: bool = False,
            hi_open: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise _Invalid(f"{name}: expected a number, got {type(value).__name__}")
    try:
        v = float(value)
    except OverflowError:
        raise _Invalid(f"{name}: number too large") from None
    if not math.isfinite(v):
        raise _Invalid(f"{name}: must be finite, got {v}")
    if v < lo or v > hi or (lo_open and v == lo) or (hi_open and v == hi):
        raise _Invalid(f"{name}: {v:g} outside {'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}")
    return v


def _int(value: Any, name: str, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise _Invalid(f"{name}: expected an integer, got {type(value).__name__}")
    if not lo <= value <= hi:
        raise _Invalid(f"{name}: {value if abs(value) < 10**12 else 'a huge number'} outside [{lo}, {hi}]")
    return value


def _vector(value: Any, n: int, name: str) -> np.ndarray:
    if not isinstance(value, list) or len(value) != n:
        raise _Invalid(f"{name}: expected {n} numbers")
    return np.array([_number(v, f"{name}[{i}]") for i, v in enumerate(value)], dtype=np.float64)


def _required(d: dict, key: str, prefix: str) -> Any:
    if key not in d:
        raise _Invalid(f"{prefix}{key}: missing")
    return d[key]


def _extras(d: dict, section: str) -> dict:
    return {k: v for k, v in d.items() if k not in _KNOWN[section]}


def stroke_set_from_dict(data: Any) -> StrokeSet:
    """Validate a decoded JSON document and build a :class:`StrokeSet`.

    Raises:
        StrokeFileError: naming the first invalid field.
    """
    try:
        return _parse(data)
    except _Invalid as exc:
        raise StrokeFileError(str(exc)) from None


def _parse(data: Any) -> StrokeSet:
    top = _obj(data, "document")
    if top.get("format") != FORMAT:
        raise _Invalid(f"format: expected {FORMAT!r}, got {top.get('format')!r}")
    version = top.get("version")
    if isinstance(version, bool) or version != VERSION:
        raise _Invalid(f"version: unsupported version {version!r} (this doodle reads version {VERSION})")

    scene = _obj(_required(top, "scene", ""), "scene")
    up = _vector(_required(scene, "up", "scene."), 3, "scene.up")
    if np.linalg.norm(up) < 1e-9:
        raise _Invalid("scene.up: must be a non-zero vector")
    cam = _obj(_required(scene, "camera", "scene."), "scene.camera")
    camera = DefaultCamera(
        fov_deg=_number(_required(cam, "fov_deg", "scene.camera."), "scene.camera.fov_deg", 0.0, 179.0, lo_open=True),
        distance=_number(_required(cam, "distance", "scene.camera."), "scene.camera.distance", 0.0, lo_open=True),
        # an orbit straight above or below has no azimuth: the drawing needs the open interval
        elevation_deg=_number(_required(cam, "elevation_deg", "scene.camera."), "scene.camera.elevation_deg",
                              -90.0, 90.0, lo_open=True, hi_open=True),
        width=_int(_required(cam, "width", "scene.camera."), "scene.camera.width", MIN_CANVAS, MAX_CANVAS),
        height=_int(_required(cam, "height", "scene.camera."), "scene.camera.height", MIN_CANVAS, MAX_CANVAS),
        azimuth_deg=_number(cam.get("azimuth_deg", 0.0), "scene.camera.azimuth_deg", -3600.0, 3600.0),
    )
    frame = SceneFrame(
        up=up / np.linalg.norm(up),
        center=_vector(_required(scene, "center", "scene."), 3, "scene.center"),
        radius=_number(_required(scene, "radius", "scene."), "scene.radius", MIN_RADIUS),
        camera=camera,
    )

    curves_d = _obj(_required(top, "curves", ""), "curves")
    cps = _required(curves_d, "control_points", "curves.")
    if not isinstance(cps, list):
        raise _Invalid("curves.control_points: expected a list of curves")
    if len(cps) > MAX_CURVES:
        raise _Invalid(f"curves.control_points: {len(cps)} curves exceed the limit of {MAX_CURVES}")
    control = np.zeros((len(cps), 4, 3))
    for i, curve in enumerate(cps):
        if not isinstance(curve, list) or len(curve) != 4:
            raise _Invalid(f"curves.control_points[{i}]: expected 4 control points")
        for j, p in enumerate(curve):
            control[i, j] = _vector(p, 3, f"curves.control_points[{i}][{j}]")
    width_px = _number(curves_d.get("width_px", 1.5), "curves.width_px", 0.0, 1000.0, lo_open=True)
    normals = _curve_normals(curves_d["normals"], len(cps)) if "normals" in curves_d else None
    contour = None
    if "contour" in curves_d:
        value = curves_d["contour"]
        if not isinstance(value, list) or len(value) != len(cps):
            raise _Invalid(f"curves.contour: expected one number per curve ({len(cps)})")
        contour = np.array([_number(v, f"curves.contour[{i}]", 0.0, 1.0) for i, v in enumerate(value)])
        if normals is None and contour.any():
            raise _Invalid("curves.contour: contour curves need curves.normals (their surface normals)")

    sq_list = _required(top, "superquadrics", "")
    if not isinstance(sq_list, list):
        raise _Invalid("superquadrics: expected a list")
    if len(sq_list) > MAX_SUPERQUADRICS:
        raise _Invalid(f"superquadrics: {len(sq_list)} exceed the limit of {MAX_SUPERQUADRICS}")
    m = len(sq_list)
    sq = SuperquadricSet(np.zeros((m, 3)), np.zeros((m, 2)), np.zeros((m, 4)), np.zeros((m, 3)))
    for i, item in enumerate(sq_list):
        name = f"superquadrics[{i}]"
        item = _obj(item, name)
        sq.scale[i] = [_number(v, f"{name}.scale[{k}]", 0.0, lo_open=True) for k, v in
                       enumerate(_checked_list(_required(item, "scale", f"{name}."), 3, f"{name}.scale"))]
        sq.shape[i] = [_number(v, f"{name}.shape[{k}]", SHAPE_RANGE[0] - 1e-6, SHAPE_RANGE[1] + 1e-6) for k, v in
                       enumerate(_checked_list(_required(item, "shape", f"{name}."), 2, f"{name}.shape"))]
        q = _vector(_required(item, "rotation", f"{name}."), 4, f"{name}.rotation")
        norm = float(np.linalg.norm(q))
        if abs(norm - 1.0) > _QUAT_TOL:
            raise _Invalid(f"{name}.rotation: quaternion norm {norm:.6g} is not 1 (tolerance {_QUAT_TOL})")
        sq.rotation[i] = q / norm
        sq.translation[i] = _vector(_required(item, "translation", f"{name}."), 3, f"{name}.translation")
        if "outline" in item:
            if not isinstance(item["outline"], bool):
                raise _Invalid(f"{name}.outline: expected true or false")
            if sq.outline is None:
                sq.outline = np.ones(m, bool)
            sq.outline[i] = item["outline"]
        if "outline_cells" in item:
            if sq.outline_cells is None:
                sq.outline_cells = np.ones((m, *OUTLINE_CELLS), bool)
            sq.outline_cells[i] = _outline_cells(item["outline_cells"], f"{name}.outline_cells")
        for key, limit in (("taper", TAPER_LIMIT), ("bend", BEND_LIMIT)):
            if key in item:
                if getattr(sq, key) is None:
                    setattr(sq, key, np.zeros((m, 2)))
                getattr(sq, key)[i] = [_number(v, f"{name}.{key}[{k}]", -limit, limit) for k, v in
                                       enumerate(_checked_list(item[key], 2, f"{name}.{key}"))]
        if "bend" in item and float(np.linalg.norm(sq.bend[i])) > BEND_LIMIT + 1e-9:
            raise _Invalid(f"{name}.bend: bends by {np.linalg.norm(sq.bend[i]):.4g} rad, more than "
                           f"{BEND_LIMIT:.4g} (a quarter turn over the half-length)")

    provenance = top.get("provenance", {})
    if not isinstance(provenance, dict):
        raise _Invalid("provenance: expected an object")
    occluder, hull = (_voxels(top[k], k) if k in top else None for k in ("occluder", "hull"))

    extra = {s: e for s, e in (("", _extras(top, "")), ("scene", _extras(scene, "scene")),
                               ("scene.camera", _extras(cam, "scene.camera")), ("curves", _extras(curves_d, "curves"))) if e}
    return StrokeSet(frame, CurveSet(control, width_px, normals, contour), sq, dict(provenance), extra, occluder, hull)


def _curve_normals(value: Any, n: int) -> np.ndarray:
    """``curves.normals``: per curve, ``[[start face a, start face b], [end face a, end face b]]``, each a
    unit or zero 3-vector."""
    if not isinstance(value, list) or len(value) != n:
        raise _Invalid(f"curves.normals: expected one entry per curve ({n})")
    out = np.zeros((n, 2, 2, 3))
    for i, per_curve in enumerate(value):
        if not isinstance(per_curve, list) or len(per_curve) != 2:
            raise _Invalid(f"curves.normals[{i}]: expected [start, end]")
        for j, pair in enumerate(per_curve):
            if not isinstance(pair, list) or len(pair) != 2:
                raise _Invalid(f"curves.normals[{i}][{j}]: expected two normals")
            for k, vec in enumerate(pair):
                name = f"curves.normals[{i}][{j}][{k}]"
                v = _vector(vec, 3, name)
                norm = float(np.linalg.norm(v))
                if norm > 1e-9 and abs(norm - 1.0) > 1e-2:
                    raise _Invalid(f"{name}: expected a unit vector or zero, norm is {norm:.4g}")
                out[i, j, k] = v / norm if norm > 1e-9 else 0.0
    return out


def _voxels(value: Any, name: str, packed: bytes | None = None) -> Voxels:
    """A voxel volume (``occluder``, ``hull``): a grid's ``origin``, ``voxel`` size, orthonormal ``axes`` (rows),
    ``shape`` and its ``bits``: the occupancy in C order, packed 8 a byte (most significant first), zlib-compressed,
    base64 — or, from a binary file, the ``packed`` occupancy itself (then ``bits`` is absent)."""
    d = _obj(value, name)
    origin = _vector(_required(d, "origin", f"{name}."), 3, f"{name}.origin")
    voxel = _number(_required(d, "voxel", f"{name}."), f"{name}.voxel", 0.0, lo_open=True)
    rows = _required(d, "axes", f"{name}.")
    if not isinstance(rows, list) or len(rows) != 3:
        raise _Invalid(f"{name}.axes: expected 3 axes")
    axes = np.stack([_vector(r, 3, f"{name}.axes[{i}]") for i, r in enumerate(rows)])
    if not np.allclose(axes @ axes.T, np.eye(3), atol=1e-3):
        raise _Invalid(f"{name}.axes: expected orthonormal rows")
    shape = _voxel_shape(d, name)
    size = voxel_bytes(shape)
    where = name  # what the byte count is reported against
    if packed is None:
        where = f"{name}.bits"
        text = _required(d, "bits", f"{name}.")
        if not isinstance(text, str) or len(text) > MAX_VOXEL_TEXT:
            raise _Invalid(f"{name}.bits: expected base64 text of at most {MAX_VOXEL_TEXT} characters")
        try:
            z = zlib.decompressobj()
            # one byte past the grid is enough to tell that the data is too long
            packed = z.decompress(base64.b64decode(text, validate=True), size + 1)
        except (ValueError, zlib.error) as exc:  # binascii.Error is a ValueError
            raise _Invalid(f"{name}.bits: not base64 of zlib data ({exc})") from None
    if len(packed) != size:
        raise _Invalid(f"{where}: expected {size} bytes for a {shape[0]}×{shape[1]}×{shape[2]} grid")
    bits = np.unpackbits(np.frombuffer(packed, np.uint8))[: int(np.prod(shape))].astype(bool).reshape(shape)
    return Voxels(origin, float(voxel), axes / np.linalg.norm(axes, axis=1, keepdims=True), bits)


def _voxel_shape(d: dict, name: str) -> tuple[int, int, int]:
    dims = _required(d, "shape", f"{name}.")
    if not isinstance(dims, list) or len(dims) != 3:
        raise _Invalid(f"{name}.shape: expected 3 integers")
    return tuple(_int(v, f"{name}.shape[{i}]", 1, MAX_VOXEL_SIDE) for i, v in enumerate(dims))


def voxel_shape(value: Any, name: str) -> tuple[int, int, int]:
    """A voxel volume object's validated ``shape``.

    Raises:
        StrokeFileError: naming the invalid field.
    """
    try:
        return _voxel_shape(_obj(value, name), name)
    except _Invalid as exc:
        raise StrokeFileError(str(exc)) from None


def voxel_bytes(shape: tuple[int, ...]) -> int:
    """Bytes of a ``shape`` grid's occupancy packed eight voxels a byte."""
    return (int(np.prod(shape)) + 7) // 8


def pack_voxels(occ: Voxels) -> bytes:
    """The occupancy in C order, eight voxels a byte, most significant bit first."""
    return np.packbits(np.asarray(occ.occupied, bool).ravel()).tobytes()


def voxels_to_dict(occ: Voxels, bits: bool = True) -> dict:
    """The file's ``occluder`` or ``hull`` object (see :func:`_voxels`); ``bits=False`` leaves the occupancy out
    (the binary format carries it packed beside the object)."""
    d = {"origin": _floats(occ.origin), "voxel": float(f"{occ.voxel:.9g}"), "axes": _floats(occ.axes),
         "shape": [int(v) for v in occ.occupied.shape]}
    if bits:
        d["bits"] = base64.b64encode(zlib.compress(pack_voxels(occ), 9)).decode("ascii")
    return d


def voxels_from_dict(value: Any, name: str, packed: bytes) -> Voxels:
    """A voxel volume from its object without ``bits`` and its ``packed`` occupancy (the binary format's).

    Raises:
        StrokeFileError: naming the invalid field.
    """
    try:
        return _voxels(value, name, packed)
    except _Invalid as exc:
        raise StrokeFileError(str(exc)) from None


def _outline_cells(value: Any, name: str) -> np.ndarray:
    """``outline_cells``: one string per latitude band, one ``0``/``1`` per longitude sector (1: drawn)."""
    rows, cols = OUTLINE_CELLS
    if (not isinstance(value, list) or len(value) != rows
            or not all(isinstance(r, str) and len(r) == cols and set(r) <= {"0", "1"} for r in value)):
        raise _Invalid(f"{name}: expected {rows} strings of {cols} 0s and 1s")
    return np.array([[c == "1" for c in r] for r in value], bool)


def outline_cell_rows(cells: np.ndarray) -> list[str]:
    """One superquadric's ``OUTLINE_CELLS`` bools → the file's strings (one per latitude band, ``1``: drawn)."""
    return ["".join("1" if c else "0" for c in row) for row in cells]


def _checked_list(value: Any, n: int, name: str) -> list:
    if not isinstance(value, list) or len(value) != n:
        raise _Invalid(f"{name}: expected {n} numbers")
    return value


def _floats(a: np.ndarray) -> list:
    """Plain Python floats, rounded to 9 significant digits (well below any tolerance, half the bytes)."""
    return [float(f"{v:.9g}") for v in np.asarray(a, dtype=np.float64).ravel()] if a.ndim == 1 else [_floats(r) for r in a]


def stroke_set_to_dict(strokes: StrokeSet) -> dict:
    """The JSON document of a stroke set (DESIGN.md "Stroke file"), extras included."""
    f, cam = strokes.frame, strokes.frame.camera
    extra = strokes.extra
    sq = strokes.superquadrics
    cells = sq.drawn_cells
    return {
        "format": FORMAT,
        "version": VERSION,
        "scene": {
            "up": _floats(f.up), "center": _floats(f.center), "radius": float(f.radius),
            "camera": {"fov_deg": float(cam.fov_deg), "distance": float(cam.distance),
                       "elevation_deg": float(cam.elevation_deg), "width": int(cam.width), "height": int(cam.height),
                       "azimuth_deg": float(cam.azimuth_deg), **extra.get("scene.camera", {})},
            **extra.get("scene", {}),
        },
        "curves": {"control_points": _floats(strokes.curves.control_points.reshape(-1, 4, 3)) if len(strokes.curves) else [],
                   "width_px": float(strokes.curves.width_px),
                   **({"normals": [_floats(m) for m in np.round(strokes.curves.normals, 4)]}
                      if strokes.curves.normals is not None and len(strokes.curves) else {}),
                   **({"contour": _floats(np.round(strokes.curves.gates, 4))} if strokes.curves.gates.any() else {}),
                   **extra.get("curves", {})},
        "superquadrics": [
            {"scale": _floats(sq.scale[i]), "shape": _floats(sq.shape[i]), "rotation": _floats(sq.rotation[i]),
             "translation": _floats(sq.translation[i]), **({} if sq.drawn[i] else {"outline": False}),
             **({} if cells[i].all() else {"outline_cells": outline_cell_rows(cells[i])}),
             **({"taper": _floats(sq.tapers[i])} if sq.tapers[i].any() else {}),
             **({"bend": _floats(sq.bends[i])} if sq.bends[i].any() else {})}
            for i in range(len(sq))
        ],
        "provenance": strokes.provenance,
        **({"occluder": voxels_to_dict(strokes.occluder)} if strokes.occluder is not None else {}),
        **({"hull": voxels_to_dict(strokes.hull)} if strokes.hull is not None else {}),
        **extra.get("", {}),
    }


def dumps(strokes: StrokeSet) -> str:
    """Serialise to JSON text (one curve per line keeps diffs readable)."""
    return json.dumps(stroke_set_to_dict(strokes), indent=1, allow_nan=False) + "\n"


def loads(text: str | bytes, source: str = "<string>") -> StrokeSet:
    """Parse JSON text; errors name ``source``."""
    try:
        data = json.loads(text, parse_constant=_reject_constant)
    except (ValueError, RecursionError) as exc:  # JSONDecodeError and UnicodeDecodeError are ValueErrors
        raise StrokeFileError(f"{source}: not valid JSON ({_first_line(exc)})") from None
    try:
        return stroke_set_from_dict(data)
    except StrokeFileError as exc:
        raise StrokeFileError(f"{source}: {exc}") from None


def _reject_constant(name: str) -> Any:
    raise ValueError(f"{name} is not allowed")


def _first_line(exc: BaseException) -> str:
    return str(exc).splitlines()[0] if str(exc) else type(exc).__name__
