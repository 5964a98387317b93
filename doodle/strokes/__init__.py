"""Stroke model: cubic Bézier curves and superquadrics, and the ``.doodle`` file format."""

from .fileio import dumps, loads, stroke_set_from_dict, stroke_set_to_dict
from .files import read_strokes, write_strokes
from .model import CurveSet, DefaultCamera, SceneFrame, StrokeSet, SuperquadricSet

__all__ = [
    "CurveSet", "DefaultCamera", "SceneFrame", "StrokeSet", "SuperquadricSet",
    "dumps", "loads", "read_strokes", "write_strokes", "stroke_set_from_dict", "stroke_set_to_dict",
]
