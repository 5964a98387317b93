"""Geometry of one view, computed once: a list of 2D cubic paths per layer that every writer only reads."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from ..cameras import Camera
from ..errors import DoodleError
from ..strokes.model import StrokeSet
from ..strokes.superquadric import union_log_inside_outside
from .fitcurve import fit_cubics_many
from .project import depth_intervals, project_curves, visibility_runs
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
        paths.extend(_silhouette_paths(sq, camera, opt, margin if use_occlusion else None, near))
    if opt.curves and len(strokes.curves):
        paths.extend(_curve_paths(strokes.curves.control_points, camera, is_hidden, near, opt))
    return Drawing(camera, paths, strokes.curves.width_px)


def _silhouette_paths(sq, camera: Camera, opt: DrawOptions, margin: float | None, near: float) -> list[PathOp]:
    """Visible (and hidden) runs of the union's contour, all fitted with cubics in one batch."""
    polys = contour_polylines(sq, camera, *opt.silhouette_grid)
    if not polys:
        return []
    points = np.concatenate([p for _, p, _ in polys])
    if margin is None:
        hidden = np.zeros(len(points), bool)
    else:  # a contour point is never hidden by its own convex superquadric
        owner = np.concatenate([np.full(len(p), i) for i, p, _ in polys])
        hidden = occluded(points, camera, sq, margin, exclude=owner)
    depth = (points @ camera.R.T + camera.t)[:, 2]
    uv_all, _ = camera.project(points)
    # The outline's image tangent is perpendicular to the projected surface normal (n_x / f_x, n_y / f_y):
    # the tangent plane at a contour point contains the eye, so it projects to the outline's tangent line.
    n_cam = np.concatenate([n for _, _, n in polys]) @ camera.R.T
    tangent_all = np.stack([-n_cam[:, 1] / camera.fy, n_cam[:, 0] / camera.fx], axis=1)
    cuts = np.cumsum([len(p) for _, p, _ in polys])[:-1]
    ops, runs, tangents, closed = [], [], [], []
    per_sq: dict[int, int] = {}
    for (i, poly, _), hid, z, uv, tan in zip(polys, np.split(hidden, cuts), np.split(depth, cuts),
                                           np.split(uv_all, cuts), np.split(tangent_all, cuts)):
        k = per_sq.get(i, 0)
        per_sq[i] = k + 1
        pid = f"silhouette-{i:03d}-{k}"
        for is_h, layer in ((False, "silhouettes"), (True, "hidden")):
            if is_h and opt.hidden == "hide":
                continue
            op = PathOp(pid if not is_h else f"hidden-{pid}", layer)
            for run in split_runs(np.hstack([poly, uv, tan]), (hid == is_h) & (z > near)):
                is_closed = len(run) > 3 and np.linalg.norm(run[0, :3] - run[-1, :3]) < 1e-9
                runs.append(run[:, 3:5]), tangents.append(run[:, 5:]), closed.append(is_closed)
                op.closed.append(is_closed)
            ops.append(op)
    fitted = iter(fit_cubics_many(runs, opt.tolerance, closed, tangents))
    for op in ops:
        op.subpaths = [next(fitted) for _ in op.closed]
    return [op for op in ops if op.subpaths]


def _curve_paths(controls: np.ndarray, camera: Camera, is_hidden, near: float, opt: DrawOptions) -> list[PathOp]:
    """Visible (and hidden) pieces of every curve; one visibility query for all curves at each step."""
    intervals = [depth_intervals(c, camera, near) for c in controls]
    flat = [(n, a, b) for n, iv in enumerate(intervals) for a, b in iv]
    runs = visibility_runs(controls, flat, is_hidden)
    pieces = [(n, lo, hi, h) for n in range(len(controls)) for lo, hi, h in runs.get(n, [])
              if not (h and opt.hidden == "hide")]
    projected = project_curves(controls, [(n, lo, hi) for n, lo, hi, _ in pieces], camera, opt.tolerance)
    ops: dict[tuple[int, bool], PathOp] = {}
    for (n, _, _, h), (cubics, _) in zip(pieces, projected):
        op = ops.setdefault((n, h), PathOp(f"hidden-curve-{n:03d}" if h else f"curve-{n:03d}", "hidden" if h else "curves"))
        op.subpaths.append(cubics)
        op.closed.append(False)
    return [ops[key] for key in sorted(ops)]
