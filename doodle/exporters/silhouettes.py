"""Contours of the superquadric union as 3D polylines (DESIGN.md "Projection to SVG").

Each superquadric is sampled on its parametric ``(η, ω)`` grid with analytic normals; the zero set of
``g = n · (p − c)`` (orthographic: ``n · d``) is found by marching squares (scikit-image), mapped back through
the exact parametrisation (so every vertex lies on the surface), and points inside another superquadric
are dropped: what remains is the union's contour generator.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from skimage import measure

from ..cameras import Camera
from ..strokes.model import OUTLINE_CELLS, SuperquadricSet
from ..strokes.superquadric import (canonical, deformation_of, deformed_surface_points_at, log_inside_outside,
                                    quaternion_to_matrix)


def angle_warp(phi: np.ndarray, e: float) -> np.ndarray:
    """Parameter ``θ`` whose superellipse point ``(c(θ,e), s(θ,e))`` lies at polar angle ``φ``.

    ``tan φ = tan^e θ``. Uniform ``φ`` spreads samples evenly around the profile; uniform ``θ`` leaves the
    rounded edges of a box-like superquadric (ε = 0.1: about 10⁻³ rad wide) without a single sample.
    """
    c, s = np.cos(phi), np.sin(phi)
    return np.arctan2(np.sign(s) * np.abs(s) ** (1 / e), np.sign(c) * np.abs(c) ** (1 / e))


def _grid(n_eta: int, n_omega: int, shape: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    eta = angle_warp(np.linspace(-np.pi / 2, np.pi / 2, n_eta), float(shape[0]))
    omega = angle_warp(np.linspace(-np.pi, np.pi, n_omega + 1), float(shape[1]))
    omega[-1] = np.pi  # last column repeats the first (−π ≡ π): the seam is closed
    omega[0] = -np.pi
    return np.meshgrid(eta, omega, indexing="ij")


def chain_polylines(polys: list[np.ndarray], tol: float) -> list[np.ndarray]:
    """Join polylines whose end points coincide (within ``tol``) into longer ones.

    Only the first three columns are positions; further columns (normals) travel with them."""
    polys = [p for p in polys if len(p) >= 2]
    changed = True
    while changed:
        changed = False
        for i in range(len(polys)):
            for j in range(len(polys)):
                if i == j:
                    continue
                a, b = polys[i], polys[j]
                if np.linalg.norm(a[-1, :3] - b[0, :3]) < tol:
                    polys[i] = np.vstack([a, b[1:]])
                elif np.linalg.norm(a[-1, :3] - b[-1, :3]) < tol:
                    polys[i] = np.vstack([a, b[::-1][1:]])
                else:
                    continue
                polys.pop(j)
                changed = True
                break
            if changed:
                break
    return polys


def split_runs(poly: np.ndarray, keep: np.ndarray) -> list[np.ndarray]:
    """Maximal runs of consecutive kept vertices (each with ≥ 2 vertices); a closed loop stays joined."""
    if keep.all():
        return [poly]
    closed = np.linalg.norm(poly[0] - poly[-1]) < 1e-9
    runs, start = [], None
    for k, flag in enumerate(np.r_[keep, False]):
        if flag and start is None:
            start = k
        elif not flag and start is not None:
            if k - start >= 2:
                runs.append(poly[start:k])
            start = None
    if closed and len(runs) >= 2 and keep[0] and keep[-1]:
        runs[0] = np.vstack([runs.pop(), runs[0][1:]])  # the loop's seam falls inside a kept run
    return runs


def _contour_function(p: np.ndarray, n: np.ndarray, camera: Camera) -> np.ndarray:
    """``g = n · (p − c)`` (perspective) or ``n · d`` (orthographic); its zero set is the contour generator."""
    if camera.projection == "orthographic":
        return n @ camera.forward
    return np.einsum("...k,...k->...", n, p - camera.center)


@dataclass(frozen=True)
class SurfaceGrids:
    """Every superquadric sampled on its parametric grid in world coordinates. View independent, so computed
    once per stroke set and reused for every camera."""

    eta: np.ndarray
    """``(M, n_eta)`` latitudes (warped per superquadric, see :func:`angle_warp`)."""
    omega: np.ndarray
    """``(M, n_omega + 1)`` longitudes; the last column repeats the first."""
    points: np.ndarray
    """``(M, n_eta, n_omega + 1, 3)``."""
    normals: np.ndarray


_GRID_CACHE: dict[tuple, SurfaceGrids] = {}


def _per(deformation: tuple | None, index) -> tuple | None:
    """A set's deformation arrays indexed by ``index`` (per superquadric of each point, or with axes added)."""
    return None if deformation is None else tuple(a[index] for a in deformation)


def surface_grids(sq: SuperquadricSet, n_eta: int, n_omega: int) -> SurfaceGrids:
    """Parametric grids of every superquadric, cached by value (drawing 36 views evaluates them once)."""
    key = (sq.scale.tobytes(), sq.shape.tobytes(), sq.rotation.tobytes(), sq.translation.tobytes(),
           sq.tapers.tobytes(), sq.bends.tobytes(), n_eta, n_omega)
    if key not in _GRID_CACHE:
        grids = [_grid(n_eta, n_omega, sq.shape[i]) for i in range(len(sq))]
        eta, omega = np.stack([g[0] for g in grids]), np.stack([g[1] for g in grids])
        p, n = deformed_surface_points_at(eta, omega, sq.scale[:, None, None], sq.shape[:, None, None],
                                          _per(deformation_of(sq), (slice(None), None, None)))
        R = quaternion_to_matrix(sq.rotation)[:, None]  # (M, 1, 3, 3)
        if len(_GRID_CACHE) >= 4:
            _GRID_CACHE.pop(next(iter(_GRID_CACHE)))
        _GRID_CACHE[key] = SurfaceGrids(eta[:, :, 0], omega[:, 0], p @ R.transpose(0, 1, 3, 2) + sq.translation[:, None, None],
                                        n @ R.transpose(0, 1, 3, 2))
    return _GRID_CACHE[key]


def _refine(c: np.ndarray, i: np.ndarray, grids: SurfaceGrids, g: np.ndarray, sq: SuperquadricSet,
            camera: Camera) -> tuple[np.ndarray, np.ndarray]:
    """Marching-squares vertices ``(K, 2)`` in grid units on superquadrics ``i`` ``(K,)`` → world surface points
    and unit normals ``(K, 3)`` after one regula-falsi step on the exact ``g`` along each vertex's grid edge:
    linear interpolation alone leaves the vertices a fraction of a pixel off the true contour, which the
    cubic fit would then chase. ``g`` ``(M, n_eta, n_omega + 1)``: the contour function on every grid."""
    n_eta, n_omega = grids.eta.shape[1], grids.omega.shape[1]
    on_row_edge = np.abs(c[:, 0] - np.round(c[:, 0])) > 1e-9  # the vertex moves along η (between two rows)
    r_lo = np.floor(c[:, 0]).astype(int).clip(0, n_eta - 2)
    c_lo = np.floor(c[:, 1]).astype(int).clip(0, n_omega - 2)
    r_at, c_at = np.round(c[:, 0]).astype(int), np.round(c[:, 1]).astype(int)  # exact on the other axis
    ra = np.where(on_row_edge, r_lo, r_at)
    rb = np.where(on_row_edge, r_lo + 1, r_at)
    ca = np.where(on_row_edge, c_at, c_lo)
    cb = np.where(on_row_edge, c_at, c_lo + 1)
    ea, wa, eb, wb = grids.eta[i, ra], grids.omega[i, ca], grids.eta[i, rb], grids.omega[i, cb]
    ga, gb = g[i, ra, ca], g[i, rb, cb]
    s = np.clip(np.where(on_row_edge, c[:, 0] - ra, c[:, 1] - ca), 0, 1)
    R = quaternion_to_matrix(sq.rotation)[i]  # (K, 3, 3)
    deformation = _per(deformation_of(sq), i)

    def surface(s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        p, n = deformed_surface_points_at(ea + s * (eb - ea), wa + s * (wb - wa), sq.scale[i], sq.shape[i], deformation)
        return (R @ p[:, :, None])[:, :, 0] + sq.translation[i], (R @ n[:, :, None])[:, :, 0]

    p, n = surface(s)
    gm = _contour_function(p, n, camera)
    left = np.sign(gm) == np.sign(ga)  # the root lies between the vertex and b
    s_lo, s_hi = np.where(left, s, 0.0), np.where(left, 1.0, s)
    g_lo, g_hi = np.where(left, gm, ga), np.where(left, gb, gm)
    denom = np.where(np.abs(g_hi - g_lo) > 1e-300, g_hi - g_lo, 1.0)
    return surface(np.clip(s_lo - g_lo * (s_hi - s_lo) / denom, s_lo, s_hi))


def contour_cells(c: np.ndarray, n_eta: int, n_omega: int, cells: tuple[int, int] = OUTLINE_CELLS) -> np.ndarray:
    """Marching-squares vertices ``(K, 2)`` in grid units of an ``n_eta × (n_omega + 1)`` grid → their flat
    index ``(K,)`` in the coarse ``cells`` grid (row-major: latitude band × longitude sector)."""
    rows = np.clip((c[:, 0] / (n_eta - 1) * cells[0]).astype(int), 0, cells[0] - 1)
    cols = np.clip((c[:, 1] / n_omega * cells[1]).astype(int), 0, cells[1] - 1)
    return rows * cells[1] + cols


@dataclass(frozen=True)
class ContourSamples:
    """The union's contour generator for one camera, as loose vertices (before chaining into polylines)."""

    pieces: list[tuple[int, int]]
    """Per marching-squares piece, ``(superquadric index, vertex count)``, in the order of the arrays."""
    points: np.ndarray
    """``(K, 3)`` world points on the surfaces."""
    normals: np.ndarray
    """``(K, 3)`` unit surface normals."""
    cells: np.ndarray
    """``(K,)`` each vertex's cell of its superquadric's :data:`OUTLINE_CELLS` grid."""
    on_union: np.ndarray
    """``(K,)`` bool: not inside another superquadric (on the union's contour)."""

    @property
    def owner(self) -> np.ndarray:
        return np.concatenate([np.full(k, i) for i, k in self.pieces]) if self.pieces else np.zeros(0, int)


def contour_samples(sq: SuperquadricSet, camera: Camera, n_eta: int = 72, n_omega: int = 144,
                    margin: float = 1e-4) -> ContourSamples:
    """Every superquadric's contour generator for ``camera``, with each vertex's outline cell and whether it lies
    on the union's contour (``margin``: how far inside another superquadric, in log inside-outside units, still
    counts as outside)."""
    empty = ContourSamples([], np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, int), np.zeros(0, bool))
    if len(sq) == 0:
        return empty
    grids = surface_grids(sq, n_eta, n_omega)
    g = _contour_function(grids.points, grids.normals, camera)  # (M, n_eta, n_omega + 1)
    contours = [(i, c) for i in range(len(sq)) for c in measure.find_contours(g[i], 0.0) if len(c) >= 2]
    if not contours:
        return empty
    owner = np.concatenate([np.full(len(c), i) for i, c in contours])
    c = np.concatenate([c for _, c in contours])
    p, n = _refine(c, owner, grids, g, sq, camera)
    # Vertices inside another superquadric are not on the union's contour.
    lf = log_inside_outside(canonical(p, sq.scale, sq.rotation, sq.translation, deformation_of(sq)), sq.scale,
                            sq.shape)  # (M, K)
    lf[owner, np.arange(len(p))] = np.inf
    return ContourSamples([(i, len(c)) for i, c in contours], p, n, contour_cells(c, n_eta, n_omega),
                          lf.min(axis=0) >= -margin)


def contour_polylines(sq: SuperquadricSet, camera: Camera, n_eta: int = 72, n_omega: int = 144,
                      margin: float = 1e-4) -> list[tuple[int, np.ndarray, np.ndarray]]:
    """The union's contour for ``camera`` as ``(superquadric index, (K, 3) world polyline, (K, 3) unit surface
    normals)`` triples, left out where a superquadric's ``outline_cells`` say its outline is not drawn.

    Polylines are closed when their first and last vertices coincide.
    """
    s = contour_samples(sq, camera, n_eta, n_omega, margin)
    if not s.pieces:
        return []
    keep = s.on_union
    if sq.outline_cells is not None:
        keep = keep & sq.outline_cells.reshape(len(sq), -1)[s.owner, s.cells]
    cuts = np.cumsum([k for _, k in s.pieces])[:-1]
    pieces = [(i, x) for (i, _), x in zip(s.pieces, np.split(np.hstack([s.points, s.normals, keep[:, None]]), cuts))]
    out: list[tuple[int, np.ndarray, np.ndarray]] = []
    for i in range(len(sq)):
        tol = 1e-6 * float(np.linalg.norm(sq.scale[i]))
        for piece in chain_polylines([x for j, x in pieces if j == i], tol):
            out.extend((i, r[:, :3], r[:, 3:6]) for r in split_runs(piece, piece[:, 6] > 0.5))
    return out
