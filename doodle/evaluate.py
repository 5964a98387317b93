"""``doodle eval``: weight-free metrics of a sketch on held-out cameras (DESIGN.md "Measuring a sketch").

For each camera, the exported SVG is rasterised; the reference line map is the mask boundary plus the
image's strong edges. Line precision = share of stroke pixels within τ px of a reference line; silhouette
recall = share of mask-boundary pixels (not the frame's edge where the object runs out of the photo) within τ px
of a stroke; F = their harmonic mean. Also the superquadric union's silhouette IoU against the mask and the
stroke file's size in both encodings.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from scipy import ndimage

from .arrays import silhouette_boundary
from .errors import DoodleError
from .exporters import DrawOptions, draw_many, svg_to_array, to_svg, union_mask
from .fit.gradient.targets import line_map
from .scenes import Scene, working_scene
from .strokes import StrokeSet, dumps
from .strokes.binary import encode


def _view_row(name: str, stroke: np.ndarray, image: np.ndarray, mask: np.ndarray | None, tau: float) -> dict[str, Any]:
    """Line precision and silhouette recall of one view's rasterised strokes ``bool (H, W)``."""
    ref = line_map(image, mask)
    row: dict[str, Any] = {"view": name}
    row["line_precision"] = float((ndimage.distance_transform_edt(~ref)[stroke] <= tau).mean()) if stroke.any() else 0.0
    if mask is not None:
        boundary = silhouette_boundary(mask)
        row["silhouette_recall"] = float((ndimage.distance_transform_edt(~stroke)[boundary] <= tau).mean()) \
            if stroke.any() and boundary.any() else 0.0
    return row


def _summary(rows: list[dict[str, Any]], tau: float, size: int) -> dict[str, Any]:
    out: dict[str, Any] = {"views": len(rows), "tau_px": tau, "size_px": size}
    for key in ("line_precision", "silhouette_recall", "silhouette_iou"):
        vals = [r[key] for r in rows if key in r]
        out[key] = round(float(np.mean(vals)), 4) if vals else None
    p, r = out["line_precision"], out["silhouette_recall"]
    out["f_score"] = round(2 * p * r / (p + r), 4) if p is not None and r is not None and p + r > 0 else None
    return out


def _inked(svg: str, size: tuple[int, int] | None = None) -> np.ndarray:
    """Pixels an SVG inks ``bool (H, W)`` (dark on white), at its own size or scaled to ``size = (W, H)``."""
    return svg_to_array(svg, "white", size)[..., :3].mean(-1) < 160


def drawn_pixels(strokes: StrokeSet, cameras) -> list[np.ndarray]:
    """The pixels the strokes ink in each camera's view ``bool (H, W)``, drawn as the metrics see them (the
    exporter's SVG at a quarter-pixel tolerance, rasterised at the camera's size)."""
    drawings = draw_many(strokes, list(cameras), DrawOptions(tolerance=0.25))
    return [_inked(to_svg(drawing, 0.25)) for drawing in drawings]


def natural_sorted(paths) -> list[Path]:
    """Paths in name order with numbers compared as numbers (``fs_2`` before ``fs_10``): the order of a
    folder of drawings, one per view.

    >>> [p.name for p in natural_sorted([Path("fs_10.svg"), Path("fs_2.svg"), Path("fs_1.svg")])]
    ['fs_1.svg', 'fs_2.svg', 'fs_10.svg']
    """
    import re

    return sorted(paths, key=lambda p: [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", Path(p).name)])


def evaluate(strokes: StrokeSet, scene: Scene, tau: float = 2.0, size: int = 256, truth=None,
             gt_threshold: float = 0.02) -> dict[str, Any]:
    """Metrics over all cameras of ``scene`` (images resized so the larger side is ``size`` px); with
    ``truth`` (:class:`~doodle.curvemetrics.GroundTruthCurves`) also the 3D curve metrics under ``"curves_3d"``."""
    work = working_scene(scene, size)
    rows = []
    for k, (cam, img, stroke) in enumerate(zip(work.cameras, work.images, drawn_pixels(strokes, work.cameras))):
        mask = work.masks[k] if work.masks is not None else None
        row = _view_row(cam.name or str(k), stroke, img, mask, tau)
        if mask is not None and len(strokes.superquadrics):
            u = union_mask(strokes.superquadrics, cam)
            row["silhouette_iou"] = float((u & mask).sum() / max((u | mask).sum(), 1))
        rows.append(row)
    out = _summary(rows, tau, size)
    out["curves"], out["superquadrics"] = len(strokes.curves), len(strokes.superquadrics)
    out["bytes_json"], out["bytes_binary"] = len(dumps(strokes).encode()), len(encode(strokes))
    out["contour_curves"] = int((strokes.curves.gates > 0).sum())
    if truth is not None:
        from .curvemetrics import curve_metrics

        # Feature curves only: a contour curve is where a smooth surface's outline lies for a few views, no
        # feature line of the object (NEF, EMAP and CurveGaussian score edge curves alone, too).
        features = strokes.curves.control_points[strokes.curves.gates == 0]
        out["curves_3d"] = {**curve_metrics(features, truth, gt_threshold), "feature_curves": len(features)}
    out["per_view"] = rows
    return out


def boundary_recall(strokes: StrokeSet, cameras: list, boundaries: list[np.ndarray], tau: float = 2.0) -> float:
    """Share of given boundary pixels (``bool (H, W)`` per camera, at the camera's size: painted boundaries,
    eyes and patches, from :func:`doodle.samples.painted_boundaries`) within ``tau`` px of the drawn strokes,
    over all the cameras (pixels of every view counted alike)."""
    near = total = 0
    for stroke, truth in zip(drawn_pixels(strokes, cameras), boundaries):
        if not truth.any():
            continue
        total += int(truth.sum())
        if stroke.any():
            near += int((ndimage.distance_transform_edt(~stroke)[truth] <= tau).sum())
    return near / total if total else float("nan")


def evaluate_svgs(svgs: list[str] | list[Path], scene: Scene, tau: float = 2.0, size: int = 256) -> dict[str, Any]:
    """The same line metrics for any line drawings, one SVG (text, or a file) per camera of ``scene`` in
    order (a mesh-based drawing such as Blender Freestyle's, a hand drawing), each drawn over the whole image:
    it is scaled to the evaluation size as it is rasterised, so its strokes keep their width relative to the
    image.

    Raises:
        DoodleError: the number of drawings differs from the cameras', or a drawing cannot be read.
    """
    if len(svgs) != len(scene.cameras):
        raise DoodleError(f"{len(svgs)} drawings for {len(scene.cameras)} cameras")
    work = working_scene(scene, size)
    rows = []
    for k, (cam, img, svg) in enumerate(zip(work.cameras, work.images, svgs)):
        where = str(svg) if isinstance(svg, Path) else f"drawing {k + 1}"
        try:
            stroke = _inked(svg.read_text() if isinstance(svg, Path) else svg, (cam.width, cam.height))
        except (OSError, UnicodeDecodeError) as exc:
            raise DoodleError(f"{where}: cannot read ({getattr(exc, 'strerror', None) or exc})") from None
        except Exception as exc:  # cairosvg raises the XML parser's errors, ValueError, …
            raise DoodleError(f"{where}: not a drawable SVG ({type(exc).__name__}: {exc})") from None
        rows.append(_view_row(cam.name or str(k), stroke, img, work.masks[k] if work.masks is not None else None, tau))
    out = _summary(rows, tau, size)
    out["per_view"] = rows
    return out


def format_metrics(m: dict[str, Any]) -> str:
    """A small text table of :func:`evaluate`'s result."""
    def f(v: Any) -> str:
        return "—" if v is None else f"{v:.3f}"

    return "\n".join([
        f"views                 {m['views']} (τ = {m['tau_px']:g} px at {m['size_px']} px)",
        f"line precision        {f(m['line_precision'])}",
        f"silhouette recall     {f(m['silhouette_recall'])}",
        f"F-score               {f(m['f_score'])}",
        *([] if "curves" not in m else [  # a stroke file (not line drawings)
            f"superquadric IoU      {f(m['silhouette_iou'])}",
            f"strokes               {m['curves']} curves" + (f" ({m['contour_curves']} contour)" if m.get("contour_curves")
                                                                  else "") + f", {m['superquadrics']} superquadrics",
            f"file size             {m['bytes_json']} B JSON, {m['bytes_binary']} B binary"]),
        *([] if "curves_3d" not in m else [
            f"3D curves (≤ {m['curves_3d']['threshold']:g})  precision {f(m['curves_3d']['precision'])}, recall "
            f"{f(m['curves_3d']['recall'])}, F {f(m['curves_3d']['f_score'])}, Chamfer "
            f"{'—' if m['curves_3d']['chamfer'] is None else format(m['curves_3d']['chamfer'], '.4f')} "
            f"({m['curves_3d']['feature_curves']} feature curves against {m['curves_3d']['gt_curves']} sharp curves)"]),
    ])
