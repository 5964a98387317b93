"""Summaries of stroke files (``doodle info``)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

from .strokes import CurveSet, StrokeSet, SuperquadricSet, dumps, read_strokes
from .strokes.binary import BINARY_VERSION, MAGIC, encode, stored_version


def binary_cost(strokes: StrokeSet) -> dict[str, int]:
    """Bytes of the binary encoding that each part of a stroke set costs: what the file loses without it
    (curves with their normals and gates, superquadrics with their outline flags and cells, each voxel volume,
    the provenance), and the rest (header, frame, quantisation, trailer length)."""
    total = len(encode(strokes))
    without = {
        "curves": replace(strokes, curves=CurveSet(width_px=strokes.curves.width_px)),
        "superquadrics": replace(strokes, superquadrics=SuperquadricSet()),
        "hull": replace(strokes, hull=None),
        "occluder": replace(strokes, occluder=None),
        "provenance": replace(strokes, provenance={}, extra={}),
    }
    cost = {name: total - len(encode(s)) for name, s in without.items()}
    cost["header"] = total - sum(cost.values())
    cost["total"] = total
    return cost


def encoding(path: str | Path) -> str:
    """How a stroke file is stored: ``"json"`` or ``"binary N"`` (its binary version)."""
    with open(path, "rb") as fh:
        version = stored_version(fh.read(len(MAGIC) + 1))
    return "json" if version is None else f"binary {version}"


def describe(path: str | Path) -> dict[str, Any]:
    """Counts, bounding box, byte sizes in both encodings, frame and provenance of a stroke file."""
    strokes: StrokeSet = read_strokes(path)
    lo, hi = strokes.bounding_box()
    f = strokes.frame
    sq = strokes.superquadrics
    return {
        "file": str(path),
        "curves": len(strokes.curves),
        "contour_curves": int((strokes.curves.gates > 0).sum()),
        "superquadrics": len(sq),
        "outlines_drawn": int(sq.drawn.sum()),
        "outline_cells_left_out": int((~sq.drawn_cells[sq.drawn]).sum()),
        "deformed": int(sq.deformed.sum()) if len(sq) else 0,
        **{name: None if vol is None else {"shape": [int(v) for v in vol.occupied.shape], "voxel": round(float(vol.voxel), 6),
                                           "occupied": int(vol.occupied.sum())}
           for name, vol in (("occluder", strokes.occluder), ("hull", strokes.hull))},
        "bounding_box": {"min": [round(float(v), 4) for v in lo], "max": [round(float(v), 4) for v in hi]},
        "encoding": encoding(path),
        "bytes": {"file": Path(path).stat().st_size, "json": len(dumps(strokes).encode()), "binary": len(encode(strokes)),
                  "binary_parts": binary_cost(strokes)},
        "scene": {"up": [round(float(v), 4) for v in f.up], "center": [round(float(v), 4) for v in f.center],
                  "radius": round(float(f.radius), 4)},
        "provenance": strokes.provenance,
    }


def _stored(kind: str) -> str:
    """``kind`` (:func:`encoding`) in words, with how to rewrite an earlier binary version."""
    if kind == "json":
        return "JSON"
    # a file this release reads is of its version or an earlier one
    return kind.replace("binary", "binary version") + (f"; `doodle convert` rewrites it as version {BINARY_VERSION}"
                                                       if kind != f"binary {BINARY_VERSION}" else "")


def format_description(info: dict[str, Any]) -> str:
    """Human-readable text of :func:`describe`'s result."""
    bb = info["bounding_box"]
    lines = [
        f"{_printable(info['file'])}",
        f"  curves          {info['curves']}"
        + (f" ({info['contour_curves']} of them contour curves, drawn where the view grazes them)" if info["contour_curves"] else ""),
        f"  superquadrics   {info['superquadrics']} ({info['outlines_drawn']} outlines drawn"
        + (f", {info['outline_cells_left_out']} of their surface cells left out" if info["outline_cells_left_out"] else "")
        + (f", {info['deformed']} tapered or bent" if info.get("deformed") else "")
        + ")",
        *[f"  {name:<15} {'×'.join(map(str, v['shape']))} voxels of {v['voxel']:g} ({v['occupied']} occupied): {role}"
          for name, role in (("occluder", "hides what lies behind the object's bulk"),
                             ("hull", "every view draws its outline where the curves leave it undrawn"))
          if (v := info.get(name)) is not None],
        f"  bounding box    {bb['min']} .. {bb['max']}",
        f"  scene           center {info['scene']['center']}, radius {info['scene']['radius']}, up {info['scene']['up']}",
        f"  size            {info['bytes']['file']} B on disk ({_stored(info['encoding'])}); JSON {info['bytes']['json']} B, "
        f"binary {info['bytes']['binary']} B",
        "  binary parts    " + ", ".join(f"{k} {v} B" for k, v in info["bytes"]["binary_parts"].items()
                                         if k != "total" and v),
    ]
    for k, v in info["provenance"].items():
        lines.append(f"  {_printable(k):<15} {_printable(v)}")
    return "\n".join(lines)


def _printable(value: object, limit: int = 200) -> str:
    """``value`` as text safe for a terminal: control characters (escape sequences) shown escaped, cut to
    ``limit`` characters. Provenance comes from files that anyone may have written."""
    text = "".join(c if c.isprintable() else repr(c)[1:-1] for c in str(value))
    return text if len(text) <= limit else text[: limit - 1] + "…"
