"""3D curve accuracy against ground-truth feature curves, as NEF, EMAP and CurveGaussian report it.

Ground truth (ABC's format, as in the ABC-NEF benchmark): ``mesh.obj`` vertices, ``features.yml`` curves
(``sharp`` flags and ``vert_indices`` into the mesh's vertices, in order along each curve) and
``normalisation.json`` (``world = vertex · scale + offset``: the cameras' frame).

Protocol: truth = the vertices along the **sharp** curves, densified along each polyline; prediction =
points sampled densely on the fitted curves and thinned on a 64³ grid over their own bounding box (the
mean point of each occupied cell). Chamfer distance = mean nearest distance prediction → truth plus truth →
prediction; precision / recall = share of prediction / truth points within ``threshold`` (0.02 for objects
that span about one unit) of the other set; F = their harmonic mean.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from .errors import DoodleError
from .strokes.bezier import bezier_points

#: Spacing of the densified ground truth and of the samples on predicted curves, in world units.
SPACING = 0.002
THIN_GRID = 64
MAX_GT_FILE_BYTES = 512 * 1024 * 1024


@dataclass
class GroundTruthCurves:
    """Dense points ``(P, 3)`` on the sharp feature curves, in the cameras' (world) frame."""

    points: np.ndarray
    curves: int
    source: str


def _read_obj_vertices(path: Path) -> np.ndarray:
    rows = []
    try:
        with path.open("r", encoding="utf-8", errors="replace") as fh:
            for line in fh:
                if line.startswith("v "):
                    rows.append(line.split()[1:4])
    except OSError as exc:
        raise DoodleError(f"{path}: cannot read ({exc.strerror})") from None
    try:
        v = np.array(rows, dtype=np.float64).reshape(-1, 3)
    except ValueError:
        raise DoodleError(f"{path}: a vertex line does not hold three numbers") from None
    if len(v) == 0 or not np.isfinite(v).all():
        raise DoodleError(f"{path}: no finite vertices")
    return v


def _densify(poly: np.ndarray, spacing: float) -> np.ndarray:
    """Points along a polyline ``(K, 3)`` at most ``spacing`` apart (the vertices included)."""
    if len(poly) < 2:
        return poly
    seg = np.diff(poly, axis=0)
    n = np.maximum(1, np.ceil(np.linalg.norm(seg, axis=1) / spacing).astype(int))
    t = np.concatenate([np.arange(k) / k for k in n])
    start = np.repeat(np.arange(len(seg)), n)
    return np.vstack([poly[start] + t[:, None] * seg[start], poly[-1:]])


def read_abc_ground_truth(folder: str | Path, spacing: float = SPACING) -> GroundTruthCurves:
    """Read ``mesh.obj``, ``features.yml`` and ``normalisation.json`` from ``folder`` (see the module doc)."""
    import yaml

    folder = Path(folder)
    for name in ("mesh.obj", "features.yml"):
        p = folder / name
        if not p.is_file():
            raise DoodleError(f"{p}: missing (--gt-curves needs mesh.obj, features.yml and normalisation.json)")
        if p.stat().st_size > MAX_GT_FILE_BYTES:
            raise DoodleError(f"{p}: larger than {MAX_GT_FILE_BYTES} bytes")
    verts = _read_obj_vertices(folder / "mesh.obj")
    norm_path = folder / "normalisation.json"
    scale, offset = 1.0, np.zeros(3)
    if norm_path.is_file():
        try:
            norm = json.loads(norm_path.read_text(encoding="utf-8"))
            scale = float(norm["scale"])
            offset = np.asarray(norm["offset"], dtype=np.float64).reshape(3)
        except (ValueError, KeyError, TypeError, OSError, OverflowError, RecursionError) as exc:
            raise DoodleError(f"{norm_path}: expected 'scale' (number) and 'offset' (3 numbers) "
                              f"({str(exc).splitlines()[0][:80]})") from None
        if not (np.isfinite(scale) and scale > 0 and np.isfinite(offset).all()):
            raise DoodleError(f"{norm_path}: scale must be positive and finite, offset finite")
    path = folder / "features.yml"
    try:
        with path.open("rb") as fh:
            doc = yaml.load(fh, Loader=getattr(yaml, "CSafeLoader", yaml.SafeLoader))
    except (yaml.YAMLError, OSError, RecursionError) as exc:
        raise DoodleError(f"{path}: not valid YAML ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__})") from None
    curves = doc.get("curves") if isinstance(doc, dict) else None
    if not isinstance(curves, list):
        raise DoodleError(f"{path}: expected a 'curves' list")
    world = verts * scale + offset
    pieces, n = [], 0
    for i, c in enumerate(curves):
        if not isinstance(c, dict) or not c.get("sharp", False):
            continue
        idx = c.get("vert_indices")
        if not isinstance(idx, list) or not idx or not all(isinstance(k, int) and not isinstance(k, bool) for k in idx):
            raise DoodleError(f"{path}: curves[{i}].vert_indices: expected a list of integers")
        idx = np.asarray(idx)
        if idx.min() < 0 or idx.max() >= len(world):
            raise DoodleError(f"{path}: curves[{i}].vert_indices: index outside the mesh's {len(world)} vertices")
        pieces.append(_densify(world[idx], spacing))
        n += 1
    if not pieces:
        raise DoodleError(f"{path}: no sharp curves")
    return GroundTruthCurves(np.vstack(pieces), n, str(folder))


def sample_curves(control_points: np.ndarray, spacing: float = SPACING) -> np.ndarray:
    """Points ``(P, 3)`` along cubic Béziers ``(N, 4, 3)``, at most about ``spacing`` apart."""
    out = []
    for c in np.asarray(control_points, dtype=np.float64):
        rough = bezier_points(c, np.linspace(0, 1, 33))
        length = float(np.linalg.norm(np.diff(rough, axis=0), axis=1).sum())
        out.append(bezier_points(c, np.linspace(0, 1, max(2, int(np.ceil(length / spacing)) + 1))))
    return np.vstack(out) if out else np.zeros((0, 3))


def thin_on_grid(points: np.ndarray, cells: int = THIN_GRID) -> np.ndarray:
    """The mean point of each occupied cell of a ``cells``³ grid over the points' bounding box."""
    if len(points) == 0:
        return points
    lo, hi = points.min(axis=0), points.max(axis=0)
    size = np.where(hi - lo > 0, (hi - lo) / cells, 1.0)
    ijk = np.clip(((points - lo) / size).astype(np.int64), 0, cells - 1)
    key = (ijk[:, 0] * cells + ijk[:, 1]) * cells + ijk[:, 2]
    _, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
    sums = np.zeros((len(counts), 3))
    np.add.at(sums, inverse, points)
    return sums / counts[:, None]


def curve_metrics(control_points: np.ndarray, truth: GroundTruthCurves, threshold: float = 0.02) -> dict:
    """Chamfer distance, precision, recall and F at ``threshold`` of curves against ground truth."""
    pred = thin_on_grid(sample_curves(control_points))
    gt = truth.points
    if len(pred) == 0:
        return {"chamfer": None, "precision": 0.0, "recall": 0.0, "f_score": 0.0, "threshold": threshold,
                "gt_curves": truth.curves}
    d_pred = cKDTree(gt).query(pred)[0]
    d_gt = cKDTree(pred).query(gt)[0]
    p = float((d_pred <= threshold).mean())
    r = float((d_gt <= threshold).mean())
    return {"chamfer": round(float(d_pred.mean() + d_gt.mean()), 5), "precision": round(p, 4), "recall": round(r, 4),
            "f_score": round(2 * p * r / (p + r), 4) if p + r > 0 else 0.0, "threshold": threshold,
            "gt_curves": truth.curves}
