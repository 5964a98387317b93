"""Procedural sample scenes (chair, snowman, lamp, tripod, mug) rendered by doodle's own analytic ray caster."""

from .capture import write_capture
from .raycast import cast, painted_boundaries, render_rgba
from .scenes import SCENES, load_ground_truth, sample_cameras, visible_feature_edges, write_sample

__all__ = ["SCENES", "cast", "load_ground_truth", "painted_boundaries", "render_rgba", "sample_cameras", "visible_feature_edges", "write_capture",
           "write_sample"]
