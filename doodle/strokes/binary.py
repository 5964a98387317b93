"""Compact binary encoding of a stroke set (``.doodleb``).

Layout (little-endian), version 5::

    magic "DDLB" | version u8 | n_curves u16 | n_superquadrics u8
    frame: up 3×f32, center 3×f64, radius f64, fov/distance/elevation/azimuth 4×f32, width u16, height u16,
           width_px f32
    quantisation: origin 3×f64, position step f64, scale step f64, position bits u8, scale bits u8
    flags u8 (bit 0: curve normals follow, bit 1: superquadric outline flags follow, bit 2: outline cells
              follow, bit 3: contour gates follow, bit 4: tapering and bending follow, bit 5: the trailer
              holds voxel volumes)
    stream length u32 (bytes)
    bit stream: curves (below), superquadric translations (M·3 × position bits), scales (M·3 × scale bits),
                shapes (M·2 × 12 bits on [0.1, 1.9]), rotations (M × (2 + 3·14) bits, "smallest three"
                quaternion components), [curve normals (below)], [outline flags (M × 1 bit)],
                [outline cells (M × 8 × 16 bits, row-major)], [contour gates (below)],
                [tapers and bends (M × 4 × DEFORM_BITS bits, symmetric codes with zero exact)]
    trailer: length u32 + zlib(JSON of provenance and extras), or with flag bit 5: xz(JSON length u32 | JSON of
             provenance, extras and the voxel volumes' objects without their ``bits`` | the volumes' packed
             occupancy, ``occluder`` then ``hull``)

Curves are coded as a geometry coder codes a mesh: by what is predictable about them
(:mod:`.bitcodes` has the codes). A curve's control points ``P0 … P3`` on the position grid: its chord
``P3 − P0``, and each handle's offset from a third of the chord (``P1 − (P0 + ⌊(P3 − P0)/3⌋)``,
``P2 − (P3 − ⌊(P3 − P0)/3⌋)``: zero for a straight, evenly parametrised cubic) as signed exponential-Golomb
codes; ``P0`` in full (position bits) unless the curve starts where the one before it ends (a flag bit; the
joined chains of a fit). The section: three orders (6 bits each: chord, first handle, second handle),
``N − 1`` chain flags, the unchained starts, then the ``3N`` chords, ``3N`` first and ``3N`` second handle
offsets. Normals: per curve end a flag bit (its second face's normal equals its first's: every contour curve,
half the feature curves), the first faces' octahedral codes (2 × NORMAL_BITS), then the second faces' where
the flag is clear. Gates: a palette (its size − 1 on 8 bits, its codes on GATE_BITS) and per curve an index
(⌈log₂ size⌉ bits; a fit's gates take three values). The decoded strokes are the same as version 4's, bit for
bit; DTU's skull takes 2.5 kB where version 4 took 3.3 kB.

Versions 1 to 4 are still read: curve control points as ``N·12`` fixed-width positions before the
superquadrics' translations, normals ``N·4`` codes, gates ``N`` codes; the stream's length follows from the
counts and flags; version 1 has no flags byte and versions 1 and 2 a 16-bit trailer length; version 3 keeps
the volumes as base64 text in a zlib trailer, version 4 as raw bits under xz (its flag bit 5 is implied).

Positions are quantised on a grid whose step keeps the round-trip error ≤ 5e-4 of the scene radius
(the bits per coordinate follow from the extent: 12 bits for a typical object).
"""

from __future__ import annotations

import json
import lzma
import math
import struct
import zlib

import numpy as np

from ..errors import StrokeFileError
from .fileio import (BEND_LIMIT, FORMAT, MAX_CURVES, MAX_SUPERQUADRICS, MAX_VOXEL_SIDE, SHAPE_RANGE, TAPER_LIMIT,
                     VERSION, outline_cell_rows,
                     pack_voxels, stroke_set_from_dict, voxel_bytes, voxel_shape, voxels_from_dict, voxels_to_dict)
from .bitcodes import ORDER_BITS, BitReader, best_order, golomb, pack
from .model import OUTLINE_CELLS, StrokeSet

MAGIC = b"DDLB"
BINARY_VERSION = 5
VOLUMES = ("occluder", "hull")
NORMAL_BITS = 6
GATE_BITS = 8
#: A contour gate's top code: codes 0 to this stand for gates 0 to 1.
_GATE_TOP = 2**GATE_BITS - 1
#: Bits of each tapering factor and bend component; ``2**DEFORM_BITS − 2`` steps over a symmetric range, so
#: the middle code is exactly zero (an undeformed superquadric beside a deformed one stays undeformed).
DEFORM_BITS = 12
#: Round-trip tolerance of positions and scales, as a fraction of the scene radius.
REL_TOLERANCE = 5e-4
SHAPE_BITS = 12
ROT_BITS = 14
_HEAD = struct.Struct("<4sBHB")
_FRAME = struct.Struct("<3f3ddffffHHf")
_QUANT = struct.Struct("<3dddBB")
_SQRT_HALF = math.sqrt(0.5)
N_CELLS = OUTLINE_CELLS[0] * OUTLINE_CELLS[1]


def _bits_for(extent: float, step_limit: float) -> tuple[int, float]:
    """Smallest bit count (8..32) whose step over ``extent`` is ≤ ``step_limit``; returns (bits, step)."""
    if not (step_limit > 0 and math.isfinite(step_limit) and math.isfinite(extent)):
        raise StrokeFileError(f"cannot quantise an extent of {extent:g} in steps of {step_limit:g}")
    levels = max(extent / step_limit, 1.0)
    bits = int(min(max(math.ceil(math.log2(levels + 1)), 8), 32))
    step = extent / (2**bits - 1) if extent > 0 else step_limit
    return bits, step


def _curve_codes(q: np.ndarray, pos_bits: int) -> list[np.ndarray]:
    """Version 5's curve section (see the module docstring) of grid codes ``q`` ``(N, 4, 3)`` (int64)."""
    chord = q[:, 3] - q[:, 0]
    third = chord // 3
    handles = (q[:, 1] - (q[:, 0] + third), q[:, 2] - (q[:, 3] - third))
    chained = (q[1:, 0] == q[:-1, 3]).all(axis=1)
    groups = (chord, *handles)
    orders = [best_order(g) for g in groups]
    out = [pack(np.array(orders), ORDER_BITS), chained.astype(np.uint8),
           pack(q[np.r_[True, ~chained], 0], pos_bits)]
    return out + [golomb(g, k) for g, k in zip(groups, orders)]


def _read_curves(reader: BitReader, n: int, pos_bits: int) -> np.ndarray:
    """Grid codes ``(N, 4, 3)`` from version 5's curve section."""
    if n == 0:
        return np.zeros((0, 4, 3), np.int64)
    orders = [int(k) for k in reader.take(3, ORDER_BITS)]
    chained = reader.take(n - 1, 1).astype(bool)
    starts = reader.take(int(n - chained.sum()) * 3, pos_bits).astype(np.int64).reshape(-1, 3)
    chord, first, second = (reader.golomb(3 * n, k).reshape(n, 3) for k in orders)
    p0 = np.empty((n, 3), np.int64)
    p0[0], at = starts[0], 1
    for i in range(1, n):  # a chained curve starts where the one before it ends
        if chained[i - 1]:
            p0[i] = p0[i - 1] + chord[i - 1]
        else:
            p0[i], at = starts[at], at + 1
    p3, third = p0 + chord, chord // 3
    return np.stack([p0, p0 + third + first, p3 - third + second, p3], axis=1)


def _normal_codes(normals: np.ndarray) -> list[np.ndarray]:
    """Version 5's normals: per curve end a flag (second face as the first), the first faces' codes, then the
    second faces' where they differ."""
    codes = _octahedral(normals.reshape(-1, 3)).reshape(-1, 2, 2)  # (ends, face, 2)
    same = (codes[:, 0] == codes[:, 1]).all(axis=1)
    return [same.astype(np.uint8), pack(codes[:, 0], NORMAL_BITS), pack(codes[~same, 1], NORMAL_BITS)]


def _read_normals(reader: BitReader, n: int) -> np.ndarray:
    same = reader.take(2 * n, 1).astype(bool)
    codes = np.empty((2 * n, 2, 2))
    codes[:, 0] = reader.take(4 * n, NORMAL_BITS).reshape(-1, 2)
    codes[:, 1] = codes[:, 0]
    codes[~same, 1] = reader.take(2 * int((~same).sum()), NORMAL_BITS).reshape(-1, 2)
    return _from_octahedral(codes.reshape(-1, 2)).reshape(n, 2, 2, 3)


def _gate_codes(gates: np.ndarray) -> list[np.ndarray]:
    """Version 5's gates: a palette of the codes used, and an index into it per curve."""
    codes = _quantise(np.clip(gates, 0.0, 1.0), 0.0, 1.0 / _GATE_TOP, GATE_BITS).astype(np.int64)
    palette, index = np.unique(codes, return_inverse=True)
    return [pack(np.array([len(palette) - 1]), GATE_BITS), pack(palette, GATE_BITS),
            pack(index, _index_bits(len(palette)))]


def _read_gates(reader: BitReader, n: int) -> np.ndarray:
    size = int(reader.take(1, GATE_BITS)[0]) + 1
    palette = reader.take(size, GATE_BITS)
    index = reader.take(n, _index_bits(size)).astype(np.int64)
    if index.size and index.max() >= size:
        raise ValueError("contour gate index beyond its palette")
    return palette[index] / _GATE_TOP


def _index_bits(size: int) -> int:
    return max(size - 1, 0).bit_length()


def _quantise(x: np.ndarray, lo: float | np.ndarray, step: float, bits: int) -> np.ndarray:
    return np.clip(np.rint((x - lo) / step), 0, 2**bits - 1)


def _octahedral(n: np.ndarray) -> np.ndarray:
    """Unit vectors ``(K, 3)`` → codes ``(K, 2)`` on ``NORMAL_BITS`` bits (octahedral map; zero → top code)."""
    top = 2**NORMAL_BITS - 1
    norm = np.abs(n).sum(axis=1, keepdims=True)
    zero = norm[:, 0] < 1e-9
    p = n / np.where(norm > 1e-9, norm, 1.0)
    folded = (1.0 - np.abs(p[:, ::-1][:, 1:])) * np.where(p[:, :2] >= 0, 1.0, -1.0)  # lower hemisphere
    uv = np.where(p[:, 2:3] >= 0, p[:, :2], folded)
    codes = np.clip(np.rint((uv + 1.0) / 2.0 * (top - 1)), 0, top - 1)
    codes[zero] = top
    return codes


def _from_octahedral(codes: np.ndarray) -> np.ndarray:
    top = 2**NORMAL_BITS - 1
    uv = codes / (top - 1) * 2.0 - 1.0
    z = 1.0 - np.abs(uv).sum(axis=1)
    xy = np.where(z[:, None] >= 0, uv, (1.0 - np.abs(uv[:, ::-1])) * np.where(uv >= 0, 1.0, -1.0))
    n = np.concatenate([xy, z[:, None]], axis=1)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    n[(codes == top).any(axis=1)] = 0.0
    return n


def encode(strokes: StrokeSet) -> bytes:
    """Encode a stroke set (see the module docstring for the layout)."""
    f, cam = strokes.frame, strokes.frame.camera
    cp = strokes.curves.control_points.reshape(-1, 3)
    sq = strokes.superquadrics
    n, m = len(strokes.curves), len(sq)
    if n > MAX_CURVES or m > MAX_SUPERQUADRICS:
        raise StrokeFileError(f"too many strokes for the binary format ({n} curves, {m} superquadrics)")
    tol = REL_TOLERANCE * f.radius * 2  # the step; rounding error is half of it
    positions = np.concatenate([cp, sq.translation], axis=0)
    origin = positions.min(axis=0) if len(positions) else np.zeros(3)
    pos_bits, pos_step = _bits_for(float((positions.max(axis=0) - origin).max()) if len(positions) else 0.0, tol)
    max_scale = float(sq.scale.max()) if m else 0.0
    scale_bits, scale_step = _bits_for(max_scale, tol)
    if max(pos_step, scale_step if m else 0.0) > tol * (1 + 1e-9):
        # 32 bits are not enough: the strokes span over 10⁶ radii, or a scale would round to zero
        raise StrokeFileError(f"strokes span {max(pos_step, scale_step) * 2**32:.3g} scene units, too much for the "
                              f"binary format's 32-bit steps at radius {f.radius:.3g}; keep this file as JSON")
    if m and float(sq.scale.min()) < scale_step:
        raise StrokeFileError(f"a superquadric scale ({float(sq.scale.min()):.3g}) is below the binary format's step "
                              f"({scale_step:.3g}); keep this file as JSON")

    grid = _quantise(positions, origin, pos_step, pos_bits).astype(np.int64)
    bits = _curve_codes(grid[: 4 * n].reshape(n, 4, 3), pos_bits) if n else []
    bits.append(pack(grid[4 * n:], pos_bits))
    if m:
        bits.append(pack(_quantise(sq.scale, 0.0, scale_step, scale_bits), scale_bits))
        lo, hi = SHAPE_RANGE
        bits.append(pack(_quantise(np.clip(sq.shape, lo, hi), lo, (hi - lo) / (2**SHAPE_BITS - 1), SHAPE_BITS), SHAPE_BITS))
        q = sq.rotation / np.linalg.norm(sq.rotation, axis=1, keepdims=True)
        largest = np.abs(q).argmax(axis=1)
        q = q * np.sign(q[np.arange(m), largest])[:, None]  # make the dropped component positive
        rest = np.stack([np.delete(q[i], largest[i]) for i in range(m)])
        qbits = _quantise(rest, -_SQRT_HALF, 2 * _SQRT_HALF / (2**ROT_BITS - 1), ROT_BITS)
        for i in range(m):
            bits.append(pack(np.array([largest[i]]), 2))
            bits.append(pack(qbits[i], ROT_BITS))
    normals = strokes.curves.normals if n else None
    if normals is not None:
        bits += _normal_codes(normals)
    outline = sq.drawn if m and not sq.drawn.all() else None
    if outline is not None:
        bits.append(outline.astype(np.uint8))
    cells = sq.drawn_cells
    cells = cells if m and not cells.all() else None
    if cells is not None:
        bits.append(cells.reshape(-1).astype(np.uint8))
    gates = strokes.curves.gates if n and strokes.curves.gates.any() else None
    if gates is not None:
        bits += _gate_codes(gates)
    deformed = m and sq.deformed.any()
    if deformed:
        for values, limit in ((sq.tapers, TAPER_LIMIT), (sq.bends, BEND_LIMIT)):
            bits.append(pack(_quantise(np.clip(values, -limit, limit), -limit, _deform_step(limit), DEFORM_BITS),
                             DEFORM_BITS))
    stream = np.packbits(np.concatenate(bits)).tobytes() if bits else b""

    volumes = [(k, v) for k, v in zip(VOLUMES, (strokes.occluder, strokes.hull)) if v is not None]
    meta = {"provenance": strokes.provenance, "extra": strokes.extra,
            **{k: voxels_to_dict(v, bits=False) for k, v in volumes}}
    text = json.dumps(meta, separators=(",", ":"), allow_nan=False).encode()
    if len(text) > MAX_TRAILER_BYTES:
        raise StrokeFileError("provenance too large for the binary format's trailer; keep this file as JSON")
    if volumes:  # raw bits under LZMA: a third smaller than zlib on their base64 text, and faster to read
        payload = b"".join([struct.pack("<I", len(text)), text, *(pack_voxels(v) for _, v in volumes)])
        trailer = lzma.compress(payload, format=lzma.FORMAT_XZ, check=lzma.CHECK_CRC32, preset=9)
    else:
        trailer = zlib.compress(text, 9) if any(meta.values()) else b""
    flags = (normals is not None) | ((outline is not None) << 1) | ((cells is not None) << 2) | ((gates is not None) << 3)
    flags |= (bool(deformed) << 4) | (bool(volumes) << 5)
    return b"".join([
        _HEAD.pack(MAGIC, BINARY_VERSION, n, m),
        _FRAME.pack(*map(float, f.up), *map(float, f.center), float(f.radius), float(cam.fov_deg), float(cam.distance),
                    float(cam.elevation_deg), float(cam.azimuth_deg), int(cam.width), int(cam.height),
                    float(strokes.curves.width_px)),
        _QUANT.pack(*map(float, origin), pos_step, scale_step, pos_bits, scale_bits),
        bytes([flags]),
        struct.pack("<I", len(stream)),
        stream,
        struct.pack("<I", len(trailer)),
        trailer,
    ])


def _deform_step(limit: float) -> float:
    return 2 * limit / (2**DEFORM_BITS - 2)


def _deform_values(codes: np.ndarray, limit: float) -> np.ndarray:
    step = _deform_step(limit)
    v = codes * step - limit
    return np.where(np.abs(v) < 0.5 * step, 0.0, v)


MAX_TRAILER_BYTES = 4 << 20  # the inflated trailer (provenance, voxel volumes): a small one must not become gigabytes
#: Version 4's inflated trailer: its JSON and two volumes of the largest grid the readers accept.
MAX_VOLUME_TRAILER_BYTES = MAX_TRAILER_BYTES + 2 * voxel_bytes((MAX_VOXEL_SIDE,) * 3)


def _inflate(data: bytes) -> bytes:
    z = zlib.decompressobj()
    out = z.decompress(data, MAX_TRAILER_BYTES)
    if z.unconsumed_tail:
        raise StrokeFileError(f"trailer inflates beyond {MAX_TRAILER_BYTES} bytes")
    return out


def _unxz(data: bytes) -> bytes:
    z = lzma.LZMADecompressor(format=lzma.FORMAT_XZ)
    out = z.decompress(data, MAX_VOLUME_TRAILER_BYTES)
    if not z.eof:
        raise StrokeFileError("trailer truncated, or inflates beyond "
                              f"{MAX_VOLUME_TRAILER_BYTES} bytes")
    if z.unused_data:
        raise StrokeFileError(f"trailer has {len(z.unused_data)} bytes beyond its end")
    return out


def _volume_trailer(data: bytes) -> tuple[dict, dict]:
    """Version 4's trailer: its JSON object and the packed occupancy of each volume it names."""
    raw = _unxz(data)
    (jlen,) = struct.unpack_from("<I", raw, 0)
    if 4 + jlen > len(raw):
        raise StrokeFileError("trailer: JSON length beyond the trailer")
    meta = json.loads(raw[4:4 + jlen].decode("utf-8"), parse_constant=_reject)
    if not isinstance(meta, dict):
        raise StrokeFileError("trailer: expected an object")
    at, packed = 4 + jlen, {}
    for key in VOLUMES:
        if key in meta:
            size = voxel_bytes(voxel_shape(meta[key], key))
            packed[key], at = raw[at:at + size], at + size
    if at != len(raw):
        raise StrokeFileError(f"trailer: {len(raw) - at:+d} bytes beside its volumes")
    return meta, packed


def stored_version(data: bytes) -> int | None:
    """The binary version ``data`` (a stroke file's first bytes, at least five) says it is in; ``None`` for a file
    that is not binary (JSON)."""
    return data[len(MAGIC)] if data[:len(MAGIC)] == MAGIC and len(data) > len(MAGIC) else None


def decode(data: bytes) -> StrokeSet:
    """Decode bytes from :func:`encode`; every inconsistency raises :class:`StrokeFileError`."""
    try:
        return _decode(data)
    except (struct.error, zlib.error, lzma.LZMAError, ValueError, UnicodeDecodeError, RecursionError) as exc:
        raise StrokeFileError(f"corrupt binary stroke data ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__})") from None


def _decode(data: bytes) -> StrokeSet:
    if len(data) < _HEAD.size + _FRAME.size + _QUANT.size + 2:
        raise StrokeFileError(f"binary stroke data truncated ({len(data)} bytes)")
    magic, version, n, m = _HEAD.unpack_from(data, 0)
    if magic != MAGIC:
        raise StrokeFileError("not a binary stroke file (bad magic)")
    if version not in (1, 2, 3, 4, BINARY_VERSION):
        raise StrokeFileError(f"version: unsupported binary version {version} (this doodle reads 1 to {BINARY_VERSION})")
    fr = _FRAME.unpack_from(data, _HEAD.size)
    qo = _HEAD.size + _FRAME.size
    *origin, pos_step, scale_step, pos_bits, scale_bits = _QUANT.unpack_from(data, qo)
    if not (8 <= pos_bits <= 32 and 8 <= scale_bits <= 32):
        raise StrokeFileError(f"quantisation bits out of range ({pos_bits}, {scale_bits})")
    if not all(math.isfinite(v) for v in (*origin, pos_step, scale_step)):
        raise StrokeFileError("quantisation parameters are not finite")
    start = qo + _QUANT.size
    flags = 0
    if version >= 2:
        flags = data[start]
        start += 1
        if flags & ~(63 if version == BINARY_VERSION else 31):
            raise StrokeFileError(f"unknown flags {flags:#x}")
    if version == BINARY_VERSION:
        (stream_len,) = struct.unpack_from("<I", data, start)
        start += 4
    else:  # the stream's length follows from the counts and flags
        n_bits = (n * 12 + m * 3) * pos_bits + m * 3 * scale_bits + m * 2 * SHAPE_BITS + m * (2 + 3 * ROT_BITS)
        n_bits += (n * 4 * 2 * NORMAL_BITS if flags & 1 else 0) + (m if flags & 2 else 0) + (m * N_CELLS if flags & 4 else 0)
        n_bits += n * GATE_BITS if flags & 8 else 0
        n_bits += m * 4 * DEFORM_BITS if flags & 16 else 0
        stream_len = (n_bits + 7) // 8
        flags |= 32 if version == 4 else 0
    length = struct.Struct("<I" if version >= 3 else "<H")
    if len(data) < start + stream_len + length.size:
        raise StrokeFileError(f"binary stroke data truncated ({len(data)} bytes, need {start + stream_len + length.size})")
    reader = BitReader(np.unpackbits(np.frombuffer(data, dtype=np.uint8, count=stream_len, offset=start)))
    (tlen,) = length.unpack_from(data, start + stream_len)
    tstart = start + stream_len + length.size
    if len(data) != tstart + tlen:
        raise StrokeFileError(f"binary stroke data has {len(data) - tstart - tlen:+d} bytes beyond its trailer")
    packed: dict = {}
    if flags & 32:
        meta, packed = _volume_trailer(data[tstart:])
    else:
        meta = json.loads(_inflate(data[tstart:]).decode("utf-8"), parse_constant=_reject) if tlen else {}
    if not isinstance(meta, dict):
        raise StrokeFileError("trailer: expected an object")

    take = reader.take
    compact = version == BINARY_VERSION
    if compact:
        grid = np.concatenate([_read_curves(reader, n, pos_bits).reshape(-1, 3),
                               take(m * 3, pos_bits).astype(np.int64).reshape(-1, 3)])
    else:
        grid = take((n * 4 + m) * 3, pos_bits).reshape(-1, 3)
    positions = grid * pos_step + np.array(origin)
    cp = positions[: n * 4].reshape(n, 4, 3)
    trans = positions[n * 4:]
    scale = take(m * 3, scale_bits).reshape(m, 3) * scale_step
    lo, hi = SHAPE_RANGE
    shape = take(m * 2, SHAPE_BITS).reshape(m, 2) * ((hi - lo) / (2**SHAPE_BITS - 1)) + lo
    rots = np.zeros((m, 4))
    for i in range(m):
        largest = int(take(1, 2)[0])
        rest = take(3, ROT_BITS) * (2 * _SQRT_HALF / (2**ROT_BITS - 1)) - _SQRT_HALF
        w = math.sqrt(max(0.0, 1.0 - float((rest**2).sum())))
        rots[i] = np.insert(rest, largest, w)
        rots[i] /= np.linalg.norm(rots[i])
    curves_doc: dict = {"control_points": cp.tolist(), "width_px": fr[13]}
    if flags & 1:
        normals = _read_normals(reader, n) if compact else \
            _from_octahedral(take(n * 4 * 2, NORMAL_BITS).reshape(-1, 2)).reshape(n, 2, 2, 3)
        curves_doc["normals"] = normals.tolist()
    drawn = take(m, 1).astype(bool) if flags & 2 else np.ones(m, bool)
    cells = take(m * N_CELLS, 1).astype(bool).reshape(m, *OUTLINE_CELLS) if flags & 4 else None
    if flags & 8:
        curves_doc["contour"] = (_read_gates(reader, n) if compact else take(n, GATE_BITS) / _GATE_TOP).tolist()
    tapers = _deform_values(take(m * 2, DEFORM_BITS).reshape(m, 2), TAPER_LIMIT) if flags & 16 else np.zeros((m, 2))
    bends = _deform_values(take(m * 2, DEFORM_BITS).reshape(m, 2), BEND_LIMIT) if flags & 16 else np.zeros((m, 2))
    bends *= np.minimum(1.0, BEND_LIMIT / np.maximum(np.linalg.norm(bends, axis=1, keepdims=True), 1e-12))
    if compact and reader.left >= 8:
        raise StrokeFileError(f"bit stream has {reader.left // 8} bytes beyond its fields")
    extra = meta.get("extra", {}) if isinstance(meta.get("extra", {}), dict) else {}
    doc = {
        "format": FORMAT, "version": VERSION,
        "scene": {"up": list(fr[0:3]), "center": list(fr[3:6]), "radius": fr[6],
                  "camera": {"fov_deg": fr[7], "distance": fr[8], "elevation_deg": fr[9], "azimuth_deg": fr[10],
                             "width": fr[11], "height": fr[12]}},
        "curves": curves_doc,
        "superquadrics": [{"scale": scale[i].tolist(), "shape": shape[i].tolist(), "rotation": rots[i].tolist(),
                           "translation": trans[i].tolist(), **({} if drawn[i] else {"outline": False}),
                           **({} if cells is None else
                              {"outline_cells": outline_cell_rows(cells[i])}),
                           **({"taper": tapers[i].tolist()} if tapers[i].any() else {}),
                           **({"bend": bends[i].tolist()} if bends[i].any() else {})}
                          for i in range(m)],
        "provenance": meta.get("provenance", {}),
        **{k: meta[k] for k in VOLUMES if k in meta and version < 4},
    }
    strokes = stroke_set_from_dict(doc)
    for key, raw in packed.items():
        setattr(strokes, key, voxels_from_dict(meta[key], key, raw))
    if not all(isinstance(v, dict) for v in extra.values()):
        raise StrokeFileError("trailer.extra: expected objects")
    strokes.extra = extra
    return strokes


def _reject(name: str) -> None:
    raise ValueError(f"{name} is not allowed")
