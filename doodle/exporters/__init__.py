"""Exporters: exact per-camera 2D paths (curves, silhouettes, hidden lines) → SVG / PNG / PDF / sheets."""

from .drawing import Drawing, DrawOptions, PathOp, draw, draw_many
from .export import ExportOptions, export_cameras, export_views
from .raster import contact_sheet, svg_to_array, svg_to_pdf, svg_to_png
from .svg import to_svg
from .visibility import union_mask

__all__ = ["Drawing", "DrawOptions", "ExportOptions", "PathOp", "contact_sheet", "draw", "draw_many", "export_cameras",
           "export_views", "svg_to_array", "svg_to_pdf", "svg_to_png", "to_svg", "union_mask"]
