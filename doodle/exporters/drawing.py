"""Geometry of one view, computed once: a list of 2D cubic paths per layer that every writer only reads."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from ..cameras import Camera
from ..errors import DoodleError
from ..strokes.model import StrokeSet
from ..strokes.superquadric import union_log_inside_outside
from .fitcurve import fit_cubics
from .project import depth_intervals, project_curve, visibility_runs
from .silhouettes import contour_polylines, split_runs
from .visibility import occluded

HiddenMode = Literal["show", "dash", "hide"]
LAYERS = ("silhouettes", "curves", "hidden")


@dataclass
class DrawOptions:
    """How strokes become 2D paths."""

    tolerance: float = 0.05
    """Maximum distance in pixels between a drawn cubic and the exact projection."""
    hidden: HiddenMode = "hide"
    """Parts behind the superquadric volume: removed (``hide``), drawn dashed in layer ``hidden`` (``dash``) or
    drawn like the rest (``show``)."""
    curves: bool = True
    silhouettes: bool = True
    occlusion_margin: float = 0.03
    """Depth, as a fraction of the scene radius, that a point may lie under the union's surface and still
    count as visible (feature curves lie on the object the superquadrics only approximate)."""
    silhouette_grid: tuple[int, int] = (48, 96)


@dataclass
class PathOp:
    """One SVG path: consecutive cubic pieces grouped in subpaths, in pixels."""

    id: str
    layer: str
    subpaths: list[np.ndarray] = field(default_factory=list)
    """Each ``(K, 4, 2)``: pieces joined end to end."""
    closed: list[bool] = field(default_factory=list)


@dataclass
class Drawing:
    camera: Camera
    paths: list[PathOp]
    width_px: float

    def layer(self, name: str) -> list[PathOp]:
        return [p for p in self.paths if p.layer == name]


def check_camera(strokes: StrokeSet, camera: Camera) -> None:
    """Reject cameras that cannot see the object: at the centre or inside the strokes' volume."""
    c = camera.center  # orthographic cameras: the eye point on the axis, at the orbit distance
    f = strokes.frame
    name = f"camera {camera.name}" if camera.name else "the camera"
    if np.linalg.norm(c - f.center) < 1e-6 * f.radius:
        raise DoodleError(f"{name} sits at the scene centre")
    lo, hi = strokes.bounding_box()
    sq = strokes.superquadrics
    inside_union = len(sq) and union_log_inside_outside(c[None], sq.scale, sq.shape, sq.rotation, sq.translation)[0] < 0
    if inside_union or (np.all(c > lo) and np.all(c < hi)):
        raise DoodleError(f"{name} at {np.round(c, 3).tolist()} is inside the object "
                          f"(the strokes' bounding box); move it further out")


def draw(strokes: StrokeSet, camera: Camera, options: DrawOptions | None = None) -> Drawing:
    """Project a stroke set for ``camera`` into per-layer 2D cubic paths."""
    opt = options or DrawOptions()
    if opt.hidden not in ("show", "dash", "hide"):
        raise DoodleError(f"hidden mode must be show, dash or hide, got {opt.hidden!r}")
    check_camera(strokes, camera)
    sq = strokes.superquadrics
    margin = opt.occlusion_margin * strokes.frame.radius
    use_occlusion = opt.hidden != "show" and len(sq) > 0
    is_hidden = (lambda pts: occluded(pts, camera, sq, margin)) if use_occlusion else (lambda pts: np.zeros(len(pts), bool))
    near = 1e-3 * strokes.frame.radius
    paths: list[PathOp] = []

    if opt.silhouettes and len(sq):
        per_sq: dict[int, int] = {}
        for i, poly in contour_polylines(sq, camera, *opt.silhouette_grid):
            k = per_sq.get(i, 0)
            per_sq[i] = k + 1
            depth = (poly @ camera.R.T + camera.t)[:, 2]
            hidden = is_hidden(poly)
            pid = f"silhouette-{i:03d}-{k}"
            for is_h, layer in ((False, "silhouettes"), (True, "hidden")):
                if is_h and opt.hidden == "hide":
                    continue
                keep = (hidden == is_h) & (depth > near)
                op = PathOp(pid if not is_h else f"hidden-{pid}", layer)
                for run in split_runs(poly, keep):
                    closed = len(run) > 3 and np.linalg.norm(run[0] - run[-1]) < 1e-9
                    uv, _ = camera.project(run)
                    op.subpaths.append(fit_cubics(uv, opt.tolerance, closed=closed))
                    op.closed.append(closed)
                if op.subpaths:
                    paths.append(op)

    if opt.curves and len(strokes.curves):
        paths.extend(_curve_paths(strokes.curves.control_points, camera, is_hidden, near, opt))
    return Drawing(camera, paths, strokes.curves.width_px)


def _curve_paths(controls: np.ndarray, camera: Camera, is_hidden, near: float, opt: DrawOptions) -> list[PathOp]:
    """Visible (and hidden) pieces of every curve; one visibility query for all curves at each step."""
    intervals = [depth_intervals(c, camera, near) for c in controls]
    flat = [(n, a, b) for n, iv in enumerate(intervals) for a, b in iv]
    runs = visibility_runs(controls, flat, is_hidden)
    out = []
    for n, control in enumerate(controls):
        vis, hid = PathOp(f"curve-{n:03d}", "curves"), PathOp(f"hidden-curve-{n:03d}", "hidden")
        for lo, hi, h in runs.get(n, []):
            if h and opt.hidden == "hide":
                continue
            target = hid if h else vis
            target.subpaths.append(project_curve(control, camera, lo, hi, opt.tolerance))
            target.closed.append(False)
        out.extend(op for op in (vis, hid) if op.subpaths)
    return out
