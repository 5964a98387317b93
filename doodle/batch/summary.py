"""A batch's overview: ``sheet.png`` (the first view of every object) and ``index.html`` (a table linking each
object's files, offline, with relative links)."""

from __future__ import annotations

import io
from html import escape
from pathlib import Path
from typing import Any

from PIL import Image, ImageDraw

from ..atomic import atomic_path, write_text

CELL = 256


def _tile(text: str, color: str) -> Image.Image:
    """A plain cell saying why there is no picture (wrapped to the cell, at most eight lines)."""
    import textwrap

    tile = Image.new("RGB", (CELL, CELL), "#f2f0eb")
    lines = textwrap.wrap(text, 38, break_long_words=True)[:8]
    ImageDraw.Draw(tile).multiline_text((12, CELL // 2 - 7 * len(lines)), "\n".join(lines), fill=color, spacing=4)
    return tile


def _first_view(out: Path, row: dict[str, Any]) -> Image.Image:
    from ..exporters.raster import svg_to_png

    view = next((f for f in row.get("files", []) if f.startswith("views/") and f.endswith(".svg")), None)
    if row["status"] == "error":
        return _tile("failed: " + row.get("error", ""), "#a01010")
    if row["status"] != "ok":
        return _tile("not made yet", "#666666")
    if view is None:
        return _tile("no views exported", "#666666")
    try:
        svg = (out / row["name"] / view).read_text(encoding="utf-8")
        return Image.open(io.BytesIO(svg_to_png(svg, "white", size=(CELL, CELL))))
    except OSError:
        return _tile("view missing", "#a01010")


def write_sheet(out: Path, summary: dict[str, Any]) -> Path:
    """``out/sheet.png``: one cell per object of the manifest, in its order, labelled with its name."""
    from ..exporters.raster import contact_sheet

    rows = summary["results"]
    sheet = contact_sheet([_first_view(out, r) for r in rows], cell=CELL, labels=[r["name"] for r in rows])
    path = out / "sheet.png"
    with atomic_path(path) as tmp:
        sheet.save(tmp, format="PNG")
    return path


def write_index(out: Path, summary: dict[str, Any]) -> Path:
    """``out/index.html``: every object with its first view, its numbers and links to its files."""
    cells = []
    for r in summary["results"]:
        name = escape(r["name"])
        view = next((f for f in r.get("files", []) if f.startswith("views/") and f.endswith(".svg")), None)
        picture = f'<img src="{name}/{escape(view)}" alt="{name}" width="192" height="192">' if view and r["status"] == "ok" else ""
        if r["status"] == "ok":
            m = r.get("metrics") or {}
            score = f", F {m['f_score']:.3f}" if m.get("f_score") is not None else ""
            facts = f"{r['curves']} curves + {r['superquadrics']} superquadrics, {r['bytes']:,} B{score}, {r['seconds']:.0f} s"
            links = " · ".join(f'<a href="{name}/{escape(f)}">{escape(f)}</a>' for f in r.get("files", [])
                               if not f.startswith("views/") or f == view)
        else:
            facts = escape(r.get("error", r["status"]))
            links = ""
        cells.append(f'<figure class="{r["status"]}">{picture}<figcaption><b>{name}</b><br>{facts}<br>{links}'
                     "</figcaption></figure>")
    html = f"""<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>doodle batch: {summary['objects']} objects</title>
<link rel="icon" href="data:,">
<style>
body {{ font: 14px/1.4 system-ui, sans-serif; margin: 1.5em; color: #222; }}
main {{ display: flex; flex-wrap: wrap; gap: 1em; }}
figure {{ margin: 0; width: 240px; padding: 0.6em; border: 1px solid #ddd; border-radius: 4px; overflow-wrap: anywhere; }}
figure.error {{ border-color: #d99; background: #fff5f5; }} figure.pending {{ color: #888; }}
img {{ display: block; margin: 0 auto 0.4em; }}
</style></head>
<body><h1>doodle batch</h1>
<p>{summary['ok']} made, {summary['error']} failed, {summary['pending']} not made yet, of {summary['objects']}
(manifest {escape(summary['manifest'])}; <a href="summary.json">summary.json</a>, <a href="sheet.png">sheet.png</a>)</p>
<main>
{chr(10).join(cells)}
</main></body></html>
"""
    path = out / "index.html"
    write_text(path, html)
    return path
