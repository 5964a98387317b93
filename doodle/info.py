"""Summaries of stroke files (``doodle info``)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from .strokes import StrokeSet, dumps, read_strokes
from .strokes.binary import encode


def describe(path: str | Path) -> dict[str, Any]:
    """Counts, bounding box, byte sizes in both encodings, frame and provenance of a stroke file."""
    strokes: StrokeSet = read_strokes(path)
    lo, hi = strokes.bounding_box()
    f = strokes.frame
    return {
        "file": str(path),
        "curves": len(strokes.curves),
        "superquadrics": len(strokes.superquadrics),
        "bounding_box": {"min": [round(float(v), 4) for v in lo], "max": [round(float(v), 4) for v in hi]},
        "bytes": {"file": Path(path).stat().st_size, "json": len(dumps(strokes).encode()), "binary": len(encode(strokes))},
        "scene": {"up": [round(float(v), 4) for v in f.up], "center": [round(float(v), 4) for v in f.center],
                  "radius": round(float(f.radius), 4)},
        "provenance": strokes.provenance,
    }


def format_description(info: dict[str, Any]) -> str:
    """Human-readable text of :func:`describe`'s result."""
    bb = info["bounding_box"]
    lines = [
        f"{info['file']}",
        f"  curves          {info['curves']}",
        f"  superquadrics   {info['superquadrics']}",
        f"  bounding box    {bb['min']} .. {bb['max']}",
        f"  scene           center {info['scene']['center']}, radius {info['scene']['radius']}, up {info['scene']['up']}",
        f"  size            {info['bytes']['file']} B on disk; JSON {info['bytes']['json']} B, binary {info['bytes']['binary']} B",
    ]
    for k, v in info["provenance"].items():
        lines.append(f"  {k:<15} {v}")
    return "\n".join(lines)
