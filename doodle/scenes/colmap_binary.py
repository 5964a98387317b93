"""Walk a COLMAP binary model before pycolmap reads it.

pycolmap trusts every count in ``cameras.bin``, ``images.bin``, ``points3D.bin``, ``rigs.bin`` and
``frames.bin``: a corrupt count made it loop for ever, allocate until ``std::bad_alloc`` (97 s), or abort the
process. This walk checks the whole layout (every record and nested count fits in the file, camera models
exist, numbers are finite and within reach, rotations non-zero, names UTF-8) in one pass over the bytes, and
raises a one-line :class:`SceneError` naming the file. What the numbers mean (image sizes, focal lengths) is
checked after reading, for binary and text models alike (``colmap.py``).

Layout (COLMAP ``src/colmap/scene/reconstruction_io.cc``), little-endian:
    cameras.bin   u64 n; n × (u32 id, i32 model, u64 width, u64 height, f64 params[model])
    images.bin    u64 n; n × (u32 id, f64 qvec[4], f64 tvec[3], u32 camera, name '\\0', u64 m, m × (f64 x, f64 y, i64 point))
    points3D.bin  u64 n; n × (u64 id, f64 xyz[3], u8 rgb[3], f64 error, u64 t, t × (u32 image, u32 point2D))
    rigs.bin      u64 n; n × (u32 id, u32 s, [i32 type, u32 id of the reference sensor if s > 0],
                  (s − 1) × (i32 type, u32 id, u8 has_pose, [f64 qvec[4], f64 tvec[3] if has_pose]))
    frames.bin    u64 n; n × (u32 id, u32 rig, f64 qvec[4], f64 tvec[3], u32 d, d × (i32 type, u32 id, u64 data))
"""

from __future__ import annotations

import math
import struct
from pathlib import Path

from ..errors import SceneError
from .scene import MAX_COORD

#: Parameters per COLMAP camera model id (``src/colmap/sensor/models.h``).
MODEL_PARAMS = {0: 3, 1: 4, 2: 4, 3: 5, 4: 8, 5: 8, 6: 12, 7: 5, 8: 4, 9: 5, 10: 12, 11: 16}


class _Bytes:
    """A cursor over a file's bytes that refuses to read past the end."""

    def __init__(self, path: Path) -> None:
        self.path, self.data, self.at = path, path.read_bytes(), 0

    def corrupt(self, why: str) -> SceneError:
        return SceneError(f"{self.path}: corrupt COLMAP model ({why} at byte {self.at})")

    def take(self, fmt: str) -> tuple:
        size = struct.calcsize(fmt)
        if self.at + size > len(self.data):
            raise self.corrupt("file too short")
        out = struct.unpack_from(fmt, self.data, self.at)
        self.at += size
        return out

    def count(self, record: int, fmt: str = "<Q") -> int:
        """A count (u64 unless ``fmt`` says otherwise) of records of at least ``record`` bytes each, which
        must fit in the rest of the file."""
        (n,) = self.take(fmt)
        if n * record > len(self.data) - self.at:
            raise self.corrupt(f"claims {n} records of {record} bytes, more than the file holds")
        return n

    def skip(self, n: int) -> None:
        if self.at + n > len(self.data):
            raise self.corrupt("file too short")
        self.at += n

    def finite(self, values: tuple, what: str, bound: float = math.inf) -> None:
        if not all(math.isfinite(v) and abs(v) <= bound for v in values):
            raise self.corrupt(f"non-finite or huge {what}")

    def pose(self, values: tuple, what: str) -> None:
        """A quaternion (w, x, y, z) and translation: finite, within reach, and a rotation (non-zero)."""
        self.finite(values, what, MAX_COORD)
        if sum(q * q for q in values[:4]) < 1e-12:
            raise self.corrupt("zero rotation quaternion")

    def end(self) -> None:
        if self.at != len(self.data):
            raise self.corrupt(f"{len(self.data) - self.at} bytes after the last record")


def _cameras(path: Path) -> None:
    f = _Bytes(path)
    for _ in range(f.count(24)):
        _, model, _, _ = f.take("<IiQQ")  # id, model, width, height
        if model not in MODEL_PARAMS:
            raise f.corrupt(f"unknown camera model {model}")
        f.finite(f.take(f"<{MODEL_PARAMS[model]}d"), "camera parameters", MAX_COORD)
    f.end()


def _images(path: Path) -> None:
    f = _Bytes(path)
    for _ in range(f.count(4 + 56 + 4 + 1 + 8)):
        values = f.take("<I7dI")
        f.pose(values[1:8], "pose")
        stop = f.data.find(b"\0", f.at)
        if stop < 0:
            raise f.corrupt("unterminated image name")
        try:
            f.data[f.at:stop].decode("utf-8")
        except UnicodeDecodeError:
            raise f.corrupt("image name is not UTF-8") from None
        f.at = stop + 1
        f.skip(24 * f.count(24))
    f.end()


def _points(path: Path) -> None:
    f = _Bytes(path)
    for _ in range(f.count(8 + 24 + 3 + 8 + 8)):
        values = f.take("<Q3d3Bd")
        f.finite(values[1:4], "point", MAX_COORD)
        f.skip(8 * f.count(8))
    f.end()


def _rigs(path: Path) -> None:
    f = _Bytes(path)
    for _ in range(f.count(8)):
        f.take("<I")
        sensors = f.count(8, "<I")
        if sensors:
            f.take("<iI")  # the reference sensor, at the rig's origin
        for _ in range(max(sensors - 1, 0)):
            *_, has_pose = f.take("<iIB")
            if has_pose:
                f.pose(f.take("<7d"), "sensor pose")
    f.end()


def _frames(path: Path) -> None:
    f = _Bytes(path)
    for _ in range(f.count(4 + 4 + 56 + 4)):
        f.pose(f.take("<II7d")[2:], "frame pose")
        f.skip(16 * f.count(16, "<I"))
    f.end()


def check_binary_model(model_dir: Path) -> None:
    """Raise :class:`SceneError` unless every binary model file in ``model_dir`` is well formed (see above).

    Text models (``.txt``) are parsed by pycolmap line by line and need no walk.
    """
    for name, walk in (("cameras.bin", _cameras), ("images.bin", _images), ("points3D.bin", _points),
                       ("rigs.bin", _rigs), ("frames.bin", _frames)):
        path = model_dir / name
        if not path.exists():
            continue
        if not path.is_file():
            raise SceneError(f"{path}: not a regular file")
        walk(path)
