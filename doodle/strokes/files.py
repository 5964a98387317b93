"""Stroke files on disk in either encoding: JSON (:mod:`.fileio`) or compact binary (:mod:`.binary`).

Reading detects the encoding from the first bytes; writing picks it from the suffix (``.doodleb``) or the
caller, and is atomic.
"""

from __future__ import annotations

import os
from pathlib import Path

from ..atomic import write_bytes
from ..errors import StrokeFileError
from .binary import MAGIC, decode, encode
from .fileio import MAX_FILE_BYTES, dumps, loads
from .model import StrokeSet


def read_strokes(path: str | os.PathLike) -> StrokeSet:
    """Read a stroke file, JSON or compact binary (detected from its first bytes)."""
    path = Path(path)
    try:
        size = path.stat().st_size
        if size > MAX_FILE_BYTES:
            raise StrokeFileError(f"{path}: file is {size} bytes, larger than the {MAX_FILE_BYTES}-byte limit")
        raw = path.read_bytes()
    except IsADirectoryError:
        raise StrokeFileError(f"{path}: is a directory, not a stroke file") from None
    except FileNotFoundError:
        raise StrokeFileError(f"{path}: no such file") from None
    except OSError as exc:
        raise StrokeFileError(f"{path}: cannot read ({exc.strerror})") from None
    if raw.startswith(MAGIC):
        try:
            return decode(raw)
        except StrokeFileError as exc:
            raise StrokeFileError(f"{path}: {exc}") from None
    return loads(raw, source=str(path))


def write_strokes(path: str | os.PathLike, strokes: StrokeSet, binary: bool | None = None) -> int:
    """Write atomically; binary when ``binary`` is true or, if ``None``, the suffix is ``.doodleb``.

    Returns:
        The number of bytes written.
    """
    path = Path(path)
    if binary is None:
        binary = path.suffix == ".doodleb"
    data = encode(strokes) if binary else dumps(strokes).encode("utf-8")
    write_bytes(path, data)
    return len(data)
