"""The stroke model: what a fit produces and every exporter reads.

Arrays are numpy float64; the fitting core turns them into torch tensors (see ``doodle.fit``).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..arrays import nearest_voxels


@dataclass
class DefaultCamera:
    """The camera an orbit uses when no dataset is at hand (DESIGN.md "Orbit")."""

    fov_deg: float = 39.6
    """Vertical and horizontal field of view of the (square-pixel) pinhole, degrees."""
    distance: float = 4.0
    """Distance from ``center`` to the camera, scene units."""
    elevation_deg: float = 30.0
    """Angle above the plane perpendicular to ``up``, degrees."""
    width: int = 800
    height: int = 800
    azimuth_deg: float = 0.0
    """Azimuth of orbit view 0 around ``up`` (the first dataset camera's, when known)."""


@dataclass
class SceneFrame:
    """The frame a stroke set was fitted in: ``up`` (unit), bounding sphere ``center``/``radius``."""

    up: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    center: np.ndarray = field(default_factory=lambda: np.zeros(3))
    radius: float = 1.0
    camera: DefaultCamera = field(default_factory=DefaultCamera)


@dataclass
class CurveSet:
    """View-independent strokes: ``N`` cubic Bézier curves, control points ``(N, 4, 3)``.

    ``normals`` (optional, ``(N, 2, 2, 3)``: at the start and the end of each curve, the normals of the two
    faces that meet along it) say from where a curve can be seen: a point of a curve is hidden when both
    faces turn away from the camera (normals are interpolated linearly along the curve). A zero normal means
    "unknown": the curve is never hidden by it (a wire seen from every side).
    """

    control_points: np.ndarray = field(default_factory=lambda: np.zeros((0, 4, 3)))
    width_px: float = 1.5
    normals: np.ndarray | None = None
    contour: np.ndarray | None = None
    """Optional ``(N,)``: for a *contour curve* — where a smooth surface's outline lies for the views whose
    rays graze it there — the largest ``|cos|`` between its normal (the first face's, which needs normals)
    and the view ray at which a point is drawn; ``0`` for a feature curve, drawn from wherever its faces
    allow. A contour curve is the outline only from near-grazing views: from the front it would be a line
    across a smooth face."""

    def __len__(self) -> int:
        return int(self.control_points.shape[0])

    @property
    def gates(self) -> np.ndarray:
        """``(N,)`` the contour gate of each curve (``0``: a feature curve; all ``0`` without ``contour``)."""
        return np.zeros(len(self)) if self.contour is None else np.asarray(self.contour, np.float64)

    def subset(self, keep: np.ndarray) -> "CurveSet":
        """The curves selected by a boolean mask or index array."""
        return CurveSet(self.control_points[keep], self.width_px, None if self.normals is None else self.normals[keep],
                        None if self.contour is None else np.asarray(self.contour)[keep])


OUTLINE_CELLS = (8, 16)
"""The coarse grid over a superquadric's surface on which a fit marks where its outline is drawn: 8 bands of
latitude × 16 sectors of longitude, evenly spaced in the polar angles of its profiles (a parametric grid
warped so, ``doodle.exporters.silhouettes.angle_warp``, spreads evenly over a box-like one too)."""


@dataclass
class SuperquadricSet:
    """View-dependent strokes: ``M`` superquadrics whose union's contour is drawn.

    ``outline`` ``(M,)`` (optional, default all true): whether each one's contour is drawn. One that is not
    still hides what lies behind it: an occluder for hidden-line removal, where curves already draw the
    outline better than its rounded silhouette would.

    ``outline_cells`` ``(M, 8, 16)`` bool (optional, default all true): where on its surface a drawn one's
    contour is drawn, on a coarse grid of latitude bands × longitude sectors of its parametrisation
    (:data:`OUTLINE_CELLS`). A superquadric only approximates its part: where its
    contour strays from the object's outline (a sphere's rim across the neck it does not have), the fit
    leaves those cells out, and the outline is drawn only where the views confirm it.

    ``taper`` ``(M, 2)`` and ``bend`` ``(M, 2)`` (optional, default all zero): Barr's tapering and bending of
    each one's local frame along its ``z`` axis (:mod:`doodle.strokes.deform`), for parts a plain
    superquadric explains poorly (a lamp shade, a spout, a horn).
    """

    scale: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    shape: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    rotation: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    """Unit quaternions ``(w, x, y, z)``."""
    translation: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    outline: np.ndarray | None = None
    outline_cells: np.ndarray | None = None
    taper: np.ndarray | None = None
    bend: np.ndarray | None = None

    def __len__(self) -> int:
        return int(self.scale.shape[0])

    @property
    def tapers(self) -> np.ndarray:
        """``(M, 2)`` tapering factors (zeros without ``taper``)."""
        return np.zeros((len(self), 2)) if self.taper is None else np.asarray(self.taper, np.float64)

    @property
    def bends(self) -> np.ndarray:
        """``(M, 2)`` bend vectors (zeros without ``bend``)."""
        return np.zeros((len(self), 2)) if self.bend is None else np.asarray(self.bend, np.float64)

    @property
    def deformed(self) -> np.ndarray:
        """``(M,)`` bool: which ones are tapered or bent."""
        return (self.tapers != 0).any(axis=1) | (self.bends != 0).any(axis=1)

    @property
    def drawn(self) -> np.ndarray:
        """``(M,)`` bool: whose contour is drawn."""
        return np.ones(len(self), bool) if self.outline is None else np.asarray(self.outline, bool)

    @property
    def drawn_cells(self) -> np.ndarray:
        """``(M, *OUTLINE_CELLS)`` bool: where on each one's surface its contour is drawn (all, without cells)."""
        return np.ones((len(self), *OUTLINE_CELLS), bool) if self.outline_cells is None else np.asarray(self.outline_cells, bool)

    def subset(self, keep: np.ndarray) -> "SuperquadricSet":
        """The superquadrics selected by a boolean mask or index array."""
        return SuperquadricSet(self.scale[keep], self.shape[keep], self.rotation[keep], self.translation[keep],
                               None if self.outline is None else np.asarray(self.outline, bool)[keep],
                               None if self.outline_cells is None else np.asarray(self.outline_cells, bool)[keep],
                               None if self.taper is None else np.asarray(self.taper)[keep],
                               None if self.bend is None else np.asarray(self.bend)[keep])

    def with_deformation(self, taper: np.ndarray, bend: np.ndarray) -> "SuperquadricSet":
        """This set with ``taper`` and ``bend`` ``(M, 2)``, stored only when some are nonzero (a plain set stays
        one: its files and drawing are the plain path's)."""
        deformed = bool(np.any(taper) or np.any(bend))
        return replace(self, taper=taper if deformed else None, bend=bend if deformed else None)

    def where(self, keep: np.ndarray, other: "SuperquadricSet") -> "SuperquadricSet":
        """Row by row, this set's superquadric where ``keep`` ``(M,)``, ``other``'s (as many) elsewhere: shape,
        pose, tapering and bending (not the outline flags and cells, which a judge sets afterwards)."""
        keep = np.asarray(keep, bool)
        pick = lambda a, b: np.where(keep.reshape(-1, *([1] * (a.ndim - 1))), a, b)  # noqa: E731
        return SuperquadricSet(*(pick(getattr(self, k), getattr(other, k)) for k in _PARAMETERS)).with_deformation(
            pick(self.tapers, other.tapers), pick(self.bends, other.bends))

    @staticmethod
    def concatenate(sets: "list[SuperquadricSet]") -> "SuperquadricSet":
        """One set of the superquadrics of ``sets`` (at least one), in order: shape, pose, tapering and bending."""
        joined = SuperquadricSet(*(np.concatenate([getattr(s, k) for s in sets]) for k in _PARAMETERS))
        return joined.with_deformation(*(np.concatenate([getattr(s, k) for s in sets]) for k in ("tapers", "bends")))

    def and_occluders(self, occluders: "SuperquadricSet") -> "SuperquadricSet":
        """This set followed by ``occluders``, which draw no outline; this set's outline flags and cells kept."""
        if not len(occluders):
            return self
        joined = SuperquadricSet.concatenate([self, occluders])
        cells = None if self.outline_cells is None else np.concatenate(
            [self.drawn_cells, np.zeros((len(occluders), *OUTLINE_CELLS), bool)])
        return replace(joined, outline=np.r_[self.drawn, np.zeros(len(occluders), bool)], outline_cells=cells)


_PARAMETERS = ("scale", "shape", "rotation", "translation")


@dataclass
class Voxels:
    """A voxel volume on a grid that may turn with the object: a stroke set's :attr:`~StrokeSet.occluder` (hides
    what lies behind it, draws nothing) or its :attr:`~StrokeSet.hull` (draws the outline of its projection).

    Voxel ``(i, j, k)`` has centre ``origin + (i, j, k) · voxel @ axes``; ``axes`` ``(3, 3)`` are the grid's
    unit axes in world coordinates, one per row; ``occupied`` ``bool (X, Y, Z)``.
    """

    origin: np.ndarray
    voxel: float
    axes: np.ndarray
    occupied: np.ndarray

    def centres(self, ijk: np.ndarray) -> np.ndarray:
        """World centres ``(P, 3)`` of voxel indices ``(P, 3)``: the inverse of :meth:`coordinates`."""
        return self.origin + (ijk * self.voxel) @ self.axes

    def coordinates(self, points: np.ndarray) -> np.ndarray:
        """Fractional voxel indices ``(..., 3)`` of world points ``(..., 3)`` (voxel centres at integers)."""
        return ((points - self.origin) @ self.axes.T) / self.voxel

    def inside(self, points: np.ndarray) -> np.ndarray:
        """Whether world points ``(..., 3)`` fall in an occupied voxel (the nearest voxel's centre decides)."""
        return nearest_voxels(np.pad(self.occupied, 1), self.coordinates(points))


@dataclass
class StrokeSet:
    """Everything a ``.doodle`` file holds."""

    frame: SceneFrame = field(default_factory=SceneFrame)
    curves: CurveSet = field(default_factory=CurveSet)
    superquadrics: SuperquadricSet = field(default_factory=SuperquadricSet)
    provenance: dict[str, Any] = field(default_factory=dict)
    extra: dict[str, Any] = field(default_factory=dict)
    """Unknown top-level keys of the file, kept so a round trip loses nothing."""
    occluder: Voxels | None = None
    """Optional: a volume that hides curves and outlines behind it, and draws nothing (a fit stores the object's
    visual hull on a coarse grid, shrunk by a voxel)."""
    hull: Voxels | None = None
    """Optional: a volume whose projected outline every view draws (:mod:`doodle.exporters.outline`; a fit
    stores the visual hull carved for its evidence). A view-dependent outline like the superquadrics', as
    intricate as the object's."""

    @property
    def is_empty(self) -> bool:
        return len(self.curves) == 0 and len(self.superquadrics) == 0

    def bounding_box(self) -> tuple[np.ndarray, np.ndarray]:
        """Axis-aligned box of the curve control points (which hold each Bézier) and the superquadrics'
        world boxes (:func:`~doodle.strokes.superquadric.world_boxes`)."""
        pts = [self.curves.control_points.reshape(-1, 3)]
        if len(self.superquadrics):
            from .superquadric import world_boxes

            pts += list(world_boxes(self.superquadrics))
        allp = np.concatenate(pts, axis=0)
        if allp.size == 0:
            c = np.asarray(self.frame.center, dtype=float)
            return c.copy(), c.copy()
        return allp.min(axis=0), allp.max(axis=0)
