"""Compact binary encoding of a stroke set (``.doodleb``).

Layout (little-endian)::

    magic "DDLB" | version u8 | n_curves u16 | n_superquadrics u8
    frame: up 3×f32, center 3×f64, radius f64, fov/distance/elevation/azimuth 4×f32, width u16, height u16,
           width_px f32
    quantisation: origin 3×f64, position step f64, scale step f64, position bits u8, scale bits u8
    versions 2 and 3: flags u8 (bit 0: curve normals follow, bit 1: superquadric outline flags follow,
                              bit 2: outline cells follow, bit 3: contour gates follow, bit 4: tapering and
                              bending follow)
    bit stream: curve control points (N·12 × position bits), superquadric translations (M·3 × position bits),
                scales (M·3 × scale bits), shapes (M·2 × 12 bits on [0.1, 1.9]),
                rotations (M × (2 + 3·14) bits, "smallest three" quaternion components),
                [curve normals (N·4 × 2·NORMAL_BITS bits: octahedral coordinates, the top code for a zero
                normal)], [outline flags (M × 1 bit)], [outline cells (M × 8 × 16 bits, row-major)],
                [contour gates (N × GATE_BITS bits on [0, 1])], [tapers and bends (M × 4 × DEFORM_BITS bits,
                symmetric codes with zero exact)]
    trailer: length (u16; versions 3 and 4: u32) + zlib(JSON of provenance and extras); version 4:
             length u32 + xz(JSON length u32 | JSON of provenance, extras and the voxel volumes' objects
             without their ``bits`` | the volumes' packed occupancy, ``occluder`` then ``hull``)

Version 1 is written when there are no flags (older readers read it), version 4 when there are voxel volumes
(LZMA on their raw bits: Lego's hull and occluder take 24 kB where zlib on their base64 text took 36 kB),
version 2 otherwise. Version 3 (volumes as base64 text in a zlib trailer with a u32 length) is read.

Positions are quantised on a grid whose step keeps the round-trip error ≤ 5e-4 of the scene radius
(the bits per coordinate follow from the extent: 12 bits for a typical object). 32 curves and
8 superquadrics take about 800 bytes plus the provenance trailer.
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
from .model import OUTLINE_CELLS, StrokeSet

MAGIC = b"DDLB"
BINARY_VERSION = 4
VOLUMES = ("occluder", "hull")
NORMAL_BITS = 6
GATE_BITS = 8
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


def _pack(values: np.ndarray, bits: int) -> np.ndarray:
    """Unsigned integers → big-endian bit array of ``bits`` each."""
    v = values.astype(np.uint64).ravel()
    shifts = np.arange(bits - 1, -1, -1, dtype=np.uint64)
    return ((v[:, None] >> shifts) & np.uint64(1)).astype(np.uint8).ravel()


def _unpack(bitarr: np.ndarray, count: int, bits: int) -> np.ndarray:
    chunk = bitarr[: count * bits].reshape(count, bits).astype(np.uint64)
    weights = np.uint64(1) << np.arange(bits - 1, -1, -1, dtype=np.uint64)
    return (chunk * weights).sum(axis=1)


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

    bits = [_pack(_quantise(positions, origin, pos_step, pos_bits), pos_bits)]
    if m:
        bits.append(_pack(_quantise(sq.scale, 0.0, scale_step, scale_bits), scale_bits))
        lo, hi = SHAPE_RANGE
        bits.append(_pack(_quantise(np.clip(sq.shape, lo, hi), lo, (hi - lo) / (2**SHAPE_BITS - 1), SHAPE_BITS), SHAPE_BITS))
        q = sq.rotation / np.linalg.norm(sq.rotation, axis=1, keepdims=True)
        largest = np.abs(q).argmax(axis=1)
        q = q * np.sign(q[np.arange(m), largest])[:, None]  # make the dropped component positive
        rest = np.stack([np.delete(q[i], largest[i]) for i in range(m)])
        qbits = _quantise(rest, -_SQRT_HALF, 2 * _SQRT_HALF / (2**ROT_BITS - 1), ROT_BITS)
        for i in range(m):
            bits.append(_pack(np.array([largest[i]]), 2))
            bits.append(_pack(qbits[i], ROT_BITS))
    normals = strokes.curves.normals if n else None
    if normals is not None:
        bits.append(_pack(_octahedral(normals.reshape(-1, 3)), NORMAL_BITS))
    outline = sq.drawn if m and not sq.drawn.all() else None
    if outline is not None:
        bits.append(outline.astype(np.uint8))
    cells = sq.drawn_cells
    cells = cells if m and not cells.all() else None
    if cells is not None:
        bits.append(cells.reshape(-1).astype(np.uint8))
    gates = strokes.curves.gates if n and strokes.curves.gates.any() else None
    if gates is not None:
        bits.append(_pack(_quantise(np.clip(gates, 0.0, 1.0), 0.0, 1.0 / (2**GATE_BITS - 1), GATE_BITS), GATE_BITS))
    deformed = m and sq.deformed.any()
    if deformed:
        for values, limit in ((sq.tapers, TAPER_LIMIT), (sq.bends, BEND_LIMIT)):
            bits.append(_pack(_quantise(np.clip(values, -limit, limit), -limit, _deform_step(limit), DEFORM_BITS),
                              DEFORM_BITS))
    flags = (normals is not None) | ((outline is not None) << 1) | ((cells is not None) << 2) | ((gates is not None) << 3)
    flags |= bool(deformed) << 4
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
    version = 4 if volumes else 2 if flags else 1
    return b"".join([
        _HEAD.pack(MAGIC, version, n, m),
        _FRAME.pack(*map(float, f.up), *map(float, f.center), float(f.radius), float(cam.fov_deg), float(cam.distance),
                    float(cam.elevation_deg), float(cam.azimuth_deg), int(cam.width), int(cam.height),
                    float(strokes.curves.width_px)),
        _QUANT.pack(*map(float, origin), pos_step, scale_step, pos_bits, scale_bits),
        bytes([flags]) if version > 1 else b"",
        stream,
        struct.pack("<I" if version >= 3 else "<H", len(trailer)),
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
    if version not in (1, 2, 3, BINARY_VERSION):
        raise StrokeFileError(f"version: unsupported binary version {version} (this doodle reads 1 to {BINARY_VERSION})")
    fr = _FRAME.unpack_from(data, _HEAD.size)
    qo = _HEAD.size + _FRAME.size
    *origin, pos_step, scale_step, pos_bits, scale_bits = _QUANT.unpack_from(data, qo)
    if not (8 <= pos_bits <= 32 and 8 <= scale_bits <= 32):
        raise StrokeFileError(f"quantisation bits out of range ({pos_bits}, {scale_bits})")
    if not all(math.isfinite(v) for v in (*origin, pos_step, scale_step)):
        raise StrokeFileError("quantisation parameters are not finite")
    n_bits = (n * 12 + m * 3) * pos_bits + m * 3 * scale_bits + m * 2 * SHAPE_BITS + m * (2 + 3 * ROT_BITS)
    start = qo + _QUANT.size
    flags = 0
    if version >= 2:
        flags = data[start]
        start += 1
        if flags & ~31:
            raise StrokeFileError(f"unknown flags {flags:#x}")
        n_bits += (n * 4 * 2 * NORMAL_BITS if flags & 1 else 0) + (m if flags & 2 else 0) + (m * N_CELLS if flags & 4 else 0)
        n_bits += n * GATE_BITS if flags & 8 else 0
        n_bits += m * 4 * DEFORM_BITS if flags & 16 else 0
    stream_len = (n_bits + 7) // 8
    length = struct.Struct("<I" if version >= 3 else "<H")
    if len(data) < start + stream_len + length.size:
        raise StrokeFileError(f"binary stroke data truncated ({len(data)} bytes, need {start + stream_len + length.size})")
    bitarr = np.unpackbits(np.frombuffer(data, dtype=np.uint8, count=stream_len, offset=start))
    (tlen,) = length.unpack_from(data, start + stream_len)
    tstart = start + stream_len + length.size
    if len(data) != tstart + tlen:
        raise StrokeFileError(f"binary stroke data has {len(data) - tstart - tlen:+d} bytes beyond its trailer")
    packed: dict = {}
    if version == 4:
        meta, packed = _volume_trailer(data[tstart:])
    else:
        meta = json.loads(_inflate(data[tstart:]).decode("utf-8"), parse_constant=_reject) if tlen else {}
    if not isinstance(meta, dict):
        raise StrokeFileError("trailer: expected an object")

    pos = 0
    def take(count: int, bits: int) -> np.ndarray:
        nonlocal pos
        out = _unpack(bitarr[pos:], count, bits).astype(np.float64)
        pos += count * bits
        return out

    positions = take((n * 4 + m) * 3, pos_bits).reshape(-1, 3) * pos_step + np.array(origin)
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
        curves_doc["normals"] = _from_octahedral(take(n * 4 * 2, NORMAL_BITS).reshape(-1, 2)).reshape(n, 2, 2, 3).tolist()
    drawn = take(m, 1).astype(bool) if flags & 2 else np.ones(m, bool)
    cells = take(m * N_CELLS, 1).astype(bool).reshape(m, *OUTLINE_CELLS) if flags & 4 else None
    if flags & 8:
        curves_doc["contour"] = (take(n, GATE_BITS) / (2**GATE_BITS - 1)).tolist()
    tapers = _deform_values(take(m * 2, DEFORM_BITS).reshape(m, 2), TAPER_LIMIT) if flags & 16 else np.zeros((m, 2))
    bends = _deform_values(take(m * 2, DEFORM_BITS).reshape(m, 2), BEND_LIMIT) if flags & 16 else np.zeros((m, 2))
    bends *= np.minimum(1.0, BEND_LIMIT / np.maximum(np.linalg.norm(bends, axis=1, keepdims=True), 1e-12))
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
