"""Superquadric abstraction of the object's volume, fitted in 3D to the carved visual hull.

The paper fits superquadrics to the training silhouettes by rendering them; that needs many steps and finds
one ball where a cow has a body, a head and four legs. Here the fit already holds the object's volume (the
visual hull the evidence is carved on), so the superquadrics are fitted to it directly, the way
Marching-Primitives (CVPR 2023) and EMS (CVPR 2022) recover them from a distance field:

1. The hull is brought to a coarse grid (:data:`WORK_VOXELS` on its longest side) and its *thick part*
   kept (:func:`thick_part`: opened by a few percent of its size; thin parts stay curves).
2. The thick part is split into parts where it narrows: a watershed of its distance to the outside, from
   the h-maxima of that distance (a body and a head meet at a neck, a leg at a narrowing).
3. One superquadric per part, from the part's principal axes, is fitted to the occupancy around it: the
   part's voxels inside, the empty voxels outside, the other parts' voxels weakly outside (overlap is
   allowed, a blob over two parts is not). The occupancy of a point is a sigmoid of its *radial distance*
   ``|x| (1 − f^(−ε₁/2))`` to the surface, which is metric (a voxel is a voxel whatever the shape).
   A part one superquadric explains poorly (under :data:`RESPLIT_BELOW`) is split again where it narrows
   less (:func:`finer_piece`): its largest piece is taken instead when one superquadric explains it clearly
   better (a ball resting on a box, their contact a shallow neck on a hull carved from automatic masks).
   A part its plain superquadric explains poorly (under :data:`DEFORM_BELOW`) is fitted again tapered and
   bent (Barr's deformations, :mod:`doodle.strokes.deform`; each of its axes as the deformation's axis), and
   the deformed fit kept beside the plain one when it leaves at most :data:`DEFORM_RESIDUAL` of what the
   plain one left unexplained.
4. Parts are taken largest first while each adds at least ``min_gain`` of the thick part's volume to the
   union's IoU (the count is chosen by the volume, not given); a superquadric that explains its own part
   poorly (IoU under :data:`MIN_PART_IOU`) is left out, and its part is left to the curves. The plain fits
   decide, so the parts are the plain abstraction's, and each deformed one has a plain fit to fall back on
   (:attr:`Abstraction.plain`): the views judge which draws the part better
   (:func:`~doodle.fit.volume.outlines.abstraction_outlines`), part by part.
5. The kept ones are refined together on the union's occupancy (a soft maximum over them), at the full
   grid's voxels near the thick part's surface: the parts are found on a coarse grid, the outline is
   placed on the fine one.
6. Refined together, one may give up what its part's own fit covered (a body over a character's torso and
   feet, where the watershed found no neck between them, keeps the torso). What the refined union leaves
   goes through step 4 once more (plain fits, the parts tried before not tried again), and the new ones
   are refined among the others, which stay as they are.

Everything is numpy in, numpy out; torch does the fitting (CPU, about a second on a cow).
"""

from __future__ import annotations

import copy
from collections.abc import Iterator
from contextlib import AbstractContextManager, contextmanager
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import torch
from scipy import ndimage

from ...strokes.model import SuperquadricSet
from ...strokes.superquadric import (bounding_radius, canonical, deformation_of, log_inside_outside,
                                     matrix_to_quaternion, quaternion_to_matrix)
from ...workers import cpu_count
from ..adam import Adam
from ..beside import stopped
from ..gradient.params import SuperquadricParams
from .carve import coarsen
from .plates import thin_plates

#: Voxels along the longest side of the grid the superquadrics are fitted on.
WORK_VOXELS = 96
#: A superquadric whose IoU with its own part is below this does not draw it (curves do).
MIN_PART_IOU = 0.55
#: Two neighbouring parts are one when a single superquadric explains them with at least this IoU.
MERGE_IOU = 0.9
#: A part keeps the start its fit's loss favours unless another explains it by at least this much more IoU
#: (:func:`_fit_parts`): on a few hundred voxels a boxier start gains a few by the voxels' steps (Cheburashka's
#: feet: +0.004 and +0.009 for ε 0.67 against a ball's 0.85, whose round outline draws them in one piece).
START_MARGIN = 0.02
#: A part one superquadric explains with an IoU below this is split again at the finer ``h`` :data:`RESPLIT_H`
#: (:func:`finer_piece`), and its largest piece taken instead when its own fit's IoU is at least
#: :data:`RESPLIT_GAIN` higher. The split's ``h`` of 0.1 is borderline where two bodies touch over a wide
#: contact: a carpet parcel's ball on its box, 15 voxels deep with a neck of 13, is one part on the hull of its
#: automatic masks (IoU 0.813) and two on its true ones; split again, the box alone is explained 0.920.
RESPLIT_BELOW = 0.85
RESPLIT_H = 0.05
RESPLIT_GAIN = 0.05
#: A piece of a part split again is one when it holds at least this share of the part's voxels.
RESPLIT_MIN_SHARE = 0.05
#: Weight of the other parts' voxels as "outside" for a part's own superquadric (overlap is cheap).
OTHER_PART_WEIGHT = 0.1
#: A part the abstraction keeps whose plain superquadric explains less than this IoU of it is tried tapered
#: and bent (Barr's deformations, :mod:`doodle.strokes.deform`), and the deformed one kept when it leaves at most
#: :data:`DEFORM_RESIDUAL` of what the plain one left unexplained (a cone: 0.28 → 0.11; a ball on a coarse
#: grid gains a few voxels by any extra freedom, 0.40 → 0.37, and stays plain).
DEFORM_BELOW = 0.8
DEFORM_RESIDUAL = 2 / 3
#: Parts smaller than this (working-grid voxels) stay plain: a few dozen voxels are an ear or a knob at a
#: few voxels across, where any extra freedom fits the voxels' steps.
DEFORM_MIN_VOXELS = 200
#: The shape of the deformed fits' flat-ended starts (a cylinder's).
FLAT_ENDS = np.array([0.25, 1.0])
#: The starts of each part's superquadric: shape ``(ε₁, ε₂)``, frame (the part's principal axes, or the grid's,
#: which are fitted to the object's box: a square plate's principal axes are any two in its plane) and the
#: factor from a variance along an axis to the half-size (5 for a ball, 3 for a box).
STARTS = (((1.0, 1.0), "principal", 5.0), ((0.25, 1.0), "principal", 4.0), ((0.25, 0.25), "principal", 3.0),
          ((0.25, 0.25), "grid", 3.0), ((0.25, 1.0), "grid", 4.0))


@dataclass
class Abstraction:
    """The superquadrics of a volume and how well they explain it."""

    superquadrics: SuperquadricSet
    iou: float
    """IoU of the union with the thick part, on the working grid."""
    parts: int
    """Parts the thick part was split into (some may be left to curves)."""
    thick_share: float
    """Share of the hull's volume in its thick part."""
    plain: SuperquadricSet | None = None
    """Where some are tapered or bent: the same set with each deformed one's plain fit in its place (refined
    the same way), for a judge that sees the views to choose part by part; ``None`` otherwise."""
    plates: SuperquadricSet = field(default_factory=SuperquadricSet)
    """Flat boxes over the thin part's plates (:mod:`.plates`), to be offered as occluders; none drawn."""


def ball(r: int) -> np.ndarray:
    """A digital ball of radius ``r`` voxels, ``bool (2r + 1,) * 3``: the structuring element of the openings."""
    return np.linalg.norm(np.mgrid[-r:r + 1, -r:r + 1, -r:r + 1], axis=0) <= r + 0.5


def thick_part(occupied: np.ndarray, radius: int) -> np.ndarray:
    """The thick part of a voxel volume: opened by a ball of ``radius`` voxels, with the small pieces the
    opening took back when they are slivers of a thick part (they touch it: a box keeps its corners) or small
    compact parts of their own (at least ``radius / 2`` deep: a knob, a bulb), whose outlines no curve draws.
    A thin part seen at a few pixels across carves into loose fragments, each small: those stay out.
    """
    r = max(int(radius), 1)
    opened = ndimage.binary_opening(occupied, structure=ball(r))
    labels, _ = ndimage.label(occupied & ~opened)
    depth = ndimage.distance_transform_edt(occupied)
    kept = opened.copy()
    for k, box in enumerate(ndimage.find_objects(labels), start=1):
        if box is None or np.linalg.norm([b.stop - b.start for b in box]) >= 6 * r:
            continue
        near = tuple(slice(max(b.start - 1, 0), b.stop + 1) for b in box)
        piece = labels[near] == k
        if (ndimage.binary_dilation(piece) & kept[near]).any() or depth[near][piece].max() >= 0.5 * r:
            opened[near] |= piece
    return opened


def split_parts(thick: np.ndarray, h: float = 0.1) -> np.ndarray:
    """Labels ``int (X, Y, Z)`` (0 outside) of the parts of ``thick``: a watershed of the distance to the
    outside from its h-maxima (maxima standing at least ``h`` × the largest distance, and a voxel, above their
    surroundings), so parts meet where the volume narrows by that much. Splitting too little costs nothing
    (what one superquadric leaves is split again); splitting too much draws a seam across a body (a mug's
    body in two stacked halves at ``h`` of a voxel)."""
    from skimage.morphology import h_maxima
    from skimage.segmentation import watershed

    labels = np.zeros(thick.shape, np.int32)
    if not thick.any():
        return labels
    # on the parts' box alone (the same labels: the distance to the outside of a voxel inside is reached within
    # a voxel of its box, and labels are numbered in the same raster order): h-maxima sort every voxel they get
    box = ndimage.find_objects(thick.astype(np.int8))[0]
    part = thick[box]
    dist = ndimage.distance_transform_edt(np.pad(part, 1))[1:-1, 1:-1, 1:-1]
    markers, _ = ndimage.label(h_maxima(dist, max(1.0, h * float(dist.max()))) & part)
    if markers.max() == 0:
        markers, _ = ndimage.label(part)
    labels[box] = watershed(-dist, markers, mask=part)
    return labels


def finer_piece(part: np.ndarray, h: float = RESPLIT_H, min_share: float = RESPLIT_MIN_SHARE) -> np.ndarray | None:
    """The largest piece of ``part`` (``bool (X, Y, Z)``) split again at the finer ``h`` (:func:`split_parts`),
    or ``None`` when that split leaves fewer than two pieces of at least ``min_share`` of its voxels."""
    labels = split_parts(part, h)
    sizes = np.bincount(labels.ravel())[1:]
    if (sizes >= min_share * part.sum()).sum() < 2:
        return None
    return labels == int(np.argmax(sizes)) + 1


def _initial(points: np.ndarray, frame: np.ndarray | None, factor: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Scale, quaternion and centre of a shape with the points' second moments along ``frame`` (columns: its
    axes; ``None``: the principal axes). A solid ellipsoid's variance along a half-axis ``a`` is ``a²/5``, a
    box's ``a²/3``: ``factor``."""
    c = points.mean(axis=0)
    if frame is None:
        cov = np.cov((points - c).T) + 1e-9 * np.eye(3)
        frame = np.linalg.eigh(cov)[1]
    frame = frame.copy()
    if np.linalg.det(frame) < 0:
        frame[:, 0] = -frame[:, 0]
    var = (((points - c) @ frame) ** 2).mean(axis=0)
    return np.sqrt(np.maximum(var, 1e-12) * factor), matrix_to_quaternion(frame), c


def radial_distance(points: torch.Tensor, scale, shape, rotation, translation,
                    deformation: tuple | None = None) -> torch.Tensor:
    """Approximate signed distance ``(M, P)`` of world points ``(P, 3)`` (or ``(M, P, 3)``, each superquadric
    its own points) to each superquadric: along the ray from its centre, ``|x| (1 − f^(−ε₁/2))`` (negative
    inside). Exact for a sphere; for others it errs by the angle between the ray and the normal, and for a
    tapered or bent one (measured in its canonical frame) by the deformation's stretch."""
    x = canonical(points, scale, rotation, translation, deformation)
    lf = log_inside_outside(x, scale, shape)
    r = x.norm(dim=-1)
    return r * (1 - torch.exp((-0.5 * shape[:, None, 0] * lf).clamp(max=30.0)))


#: Inside voxels farther than this many voxels outside a superquadric stop pulling on it: a part's own
#: superquadric is not dragged over a leg the part's split left attached (EMS's outliers, in one line).
TRUNCATE_VOXELS = 3.0


def _loss(d: torch.Tensor, target: torch.Tensor, weight: torch.Tensor, tau: float) -> torch.Tensor:
    """Class-balanced logistic loss of signed distances ``d`` (per row: inside and outside weigh the same, so
    a thin part is not shrunk away), with the inside term truncated at :data:`TRUNCATE_VOXELS`."""
    sp = torch.nn.functional.softplus
    inside = sp(d / tau).clamp(max=float(np.log1p(np.exp(TRUNCATE_VOXELS * 0.5 / 0.5))))
    outside = sp(-d / tau)
    pos, neg = weight * target, weight * (1 - target)
    lp = (pos * inside).sum(-1) / pos.sum(-1).clamp_min(1e-6)
    ln = (neg * outside).sum(-1) / neg.sum(-1).clamp_min(1e-6)
    return lp + ln


def _optimise(params: SuperquadricParams | list[SuperquadricParams], loss_fn: Callable[[], torch.Tensor], steps: int,
              lr: float) -> None:
    """Adam with a cosine schedule; the translation's rate in units of the set's mean size. A list of sets is
    optimised at once (one loss over all their rows), each with its own translation rate: the same steps as
    one by one, at one set's cost in torch's per-operation overhead."""
    groups = []
    for p in params if isinstance(params, list) else [params]:
        groups += [{"params": [p.log_scale, p.raw_shape, p.rotation], "lr": lr},
                   {"params": [p.translation], "lr": lr * float(p.log_scale.detach().exp().mean())}]
        if p.deformable:
            groups.append({"params": [p.raw_taper, p.raw_bend, p.bend_direction], "lr": lr})
    opt = Adam(groups)
    base = [g["lr"] for g in opt.param_groups]
    for step in range(steps):
        stopped()  # a fit that ended without this abstraction (it runs beside discovery) stops it here
        for g, lr0 in zip(opt.param_groups, base):
            g["lr"] = lr0 * (0.1 + 0.9 * 0.5 * (1 + np.cos(np.pi * step / steps)))  # cosine to 10 %
        opt.zero_grad()
        loss = loss_fn().sum()  # rows are independent problems
        loss.backward()
        opt.step()


def _distance(points: np.ndarray, sq: SuperquadricSet) -> np.ndarray:
    """:func:`radial_distance` ``(M, P)`` of world points ``(P, 3)`` to a superquadric set, in numpy."""
    with torch.no_grad():
        t = [torch.from_numpy(np.asarray(a, np.float32)) for a in (sq.scale, sq.shape, sq.rotation, sq.translation)]
        deformation = deformation_of(sq)
        if deformation is not None:
            deformation = tuple(torch.from_numpy(np.asarray(a, np.float32)) for a in deformation)
        return radial_distance(torch.from_numpy(points.astype(np.float32)), *t, deformation).numpy()


def _within(points: np.ndarray, sq: SuperquadricSet, reach: float) -> np.ndarray:
    """``bool (M, P)``: ``_distance(points, sq) <= reach``. For a plain set each superquadric's distances are
    computed only at the points within ``reach`` of its bounding sphere: along a ray from its centre the radial
    distance is ``|x| − r_s`` (``f`` is homogeneous of degree ``2/ε₁``), and ``r_s ≤ |a|`` (ε ≤ 2 keeps the surface
    in its box), so farther points are farther than ``reach``. On the working grid most of the thick part's
    voxels are far from any one part's superquadric (the skull's: 8 superquadrics over 0.8 M voxels)."""
    if not len(sq) or sq.deformed.any():
        return _distance(points, sq) <= reach
    out = np.zeros((len(sq), len(points)), bool)
    bound = bounding_radius(sq) * 1.001 + reach + 1e-6  # the margin: float32 rounding at the sphere
    for m in range(len(sq)):
        near = np.flatnonzero(((points - sq.translation[m]) ** 2).sum(1) <= bound[m] ** 2)
        out[m, near] = _distance(points[near], sq.subset(np.array([m])))[0] <= reach
    return out


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum() / max((a | b).sum(), 1))


def abstract_volume(origin: np.ndarray, voxel: float, axes: np.ndarray, occupied: np.ndarray, thin: float = 0.06,
                    max_count: int = 8, min_gain: float = 0.01, steps: int = 100, seed: int = 0,
                    deform: bool = True, log: Callable[[str], None] = lambda m: None) -> Abstraction:
    """Superquadrics that abstract the volume ``occupied`` (see the module doc).

    Args:
        origin, voxel, axes: the grid (voxel ``(i, j, k)``'s centre is ``origin + (i, j, k)·voxel @ axes``).
        occupied: ``bool (X, Y, Z)``, the visual hull.
        thin: parts thinner than this share of the volume's box diagonal are left to curves.
        max_count: at most this many superquadrics.
        min_gain: a superquadric is kept when it raises the union's IoU with the thick part by this much.
        steps: Adam steps of each fit (per part, then together).
        deform: also fit tapered and bent superquadrics where a plain one explains its part poorly.
    """
    with one_torch_thread():
        return _abstract(origin, voxel, axes, occupied, thin, max_count, min_gain, steps, seed, deform, log)


@contextmanager
def torch_threads(count: int) -> Iterator[None]:
    """torch on ``count`` threads while inside."""
    threads = torch.get_num_threads()
    torch.set_num_threads(count)
    try:
        yield
    finally:
        torch.set_num_threads(threads)


def one_torch_thread() -> AbstractContextManager[None]:
    """torch on one thread while inside: the parts' problems are small (a few rows of at most 2,000 points),
    and a second thread's hand-offs cost more than it computes (the procedural cow's superquadric stage
    16.3 → 12.4 s on two cores, the same superquadrics). The union's refinement takes the cores back
    (:func:`_refine_union`)."""
    return torch_threads(1)


def _abstract(origin: np.ndarray, voxel: float, axes: np.ndarray, occupied: np.ndarray, thin: float, max_count: int,
              min_gain: float, steps: int, seed: int, deform: bool, log: Callable[[str], None]) -> Abstraction:
    rng = np.random.default_rng(seed)
    torch.manual_seed(seed)
    coarse, k = coarsen(occupied, WORK_VOXELS)
    cvox = voxel * k
    c_origin = origin + ((k - 1) / 2 * voxel) * axes.sum(axis=0)
    ijk_all = np.argwhere(coarse)
    if len(ijk_all) < 8:
        return Abstraction(SuperquadricSet(), 0.0, 0, 0.0)
    diag = cvox * float(np.linalg.norm(ijk_all.max(axis=0) - ijk_all.min(axis=0) + 1))
    radius = max(1, int(round(0.5 * thin * diag / cvox)))
    thick = thick_part(coarse, radius)
    thick_share = float(thick.sum() / max(coarse.sum(), 1))
    plates = thin_plates(coarse & ~thick, c_origin, cvox, axes, radius, max_count, int(coarse.sum()))
    if thick.sum() < 8:
        log("superquadrics: the volume has no thick part; curves only")
        return Abstraction(SuperquadricSet(), 0.0, 0, thick_share, plates=plates)
    care = ~(coarse & ~thick)  # thin parts are nobody's: neither inside nor outside
    cells = np.argwhere(care)
    centres = c_origin + (cells * cvox) @ axes
    in_thick = thick[tuple(cells.T)]
    # A part's worth is the share of the thick part's surface it explains, not of its volume: a spout or a
    # knob holds 1-2 % of a teapot's volume and draws a good part of its outline.
    shell = (thick & ~ndimage.binary_erosion(thick))[tuple(cells.T)]
    tau = 0.5 * cvox
    take = _PartTaker(thick, care, cells, centres, shell, c_origin, cvox, axes, tau, radius, steps, rng,
                      max_count, min_gain, deform, log)
    take.parts_of(np.zeros(len(cells), bool))
    if not take.found:
        return Abstraction(SuperquadricSet(), 0.0, take.parts, thick_share, plates=plates)
    sq = SuperquadricSet.concatenate(take.found)
    # The parts are found on the working grid; the union is refined on the full one, near its surface, where
    # a voxel of the working grid is more than the 2 px a line may stray (the cow's held-out line precision
    # 0.878 refined on the working grid, 0.941 fitted on the full one, 2.5 times slower).
    points, inside = _surface_samples(occupied, thick, k, origin, voxel, axes, rng)
    far = rng.choice(len(centres), min(len(centres), 4000), replace=False)  # and some of everything else
    points, inside = np.concatenate([points, centres[far]]), np.concatenate([inside, in_thick[far]])
    plain = None
    if sq.deformed.any():
        # the plain abstraction, refined as without deformations; then the deformed ones put in their plain
        # fits' places and refined among the others, which stay as they are
        plain = _refine_union(SuperquadricSet.concatenate(take.plains), points, inside, 0.5 * voxel, steps,
                              copy.deepcopy(rng))
        bent = sq.deformed
        sq = _refine_union(sq.where(bent, plain), points, inside, 0.5 * voxel, steps // 2, rng, only=bent)
    else:
        sq = _refine_union(sq, points, inside, 0.5 * voxel, steps, rng)
    # What the refined union leaves (step 6 of the module doc): Cheburashka's feet, the body's superquadric
    # gave up to fit its torso (the volume's IoU 0.81 → 0.92); the rim of the lamp's shade, over the hull's
    # bulge under it (held-out F 0.921 → 0.938).
    decided = sq if plain is None else plain
    before = len(take.found)
    take.parts_of(_within(centres, decided, cvox).any(axis=0), deform=False)
    if len(take.found) > before:
        added = SuperquadricSet.concatenate(take.found[before:])
        new = np.arange(len(decided) + len(added)) >= len(decided)
        grown = _refine_union(SuperquadricSet.concatenate([decided, added]), points, inside, 0.5 * voxel, steps,
                              rng, only=new)
        added = grown.subset(np.flatnonzero(new))
        sq = SuperquadricSet.concatenate([sq, added])
        plain = None if plain is None else grown
        log(f"superquadrics: {len(added)} more for what the refined union left")
    iou = _iou(_within(centres, sq, 0.0).any(axis=0), in_thick)
    log(f"superquadrics: {len(sq)} abstract the volume (IoU {iou:.3f} with its thick part, {thick_share:.0%} of "
        "the hull)")
    return Abstraction(sq, iou, take.parts, thick_share, plain, plates)


@dataclass
class _PartTaker:
    """Marching-Primitives' loop on the working grid: split what is not yet explained into parts, fit the
    largest, keep it while it explains enough, repeat. ``found`` holds the kept superquadrics (deformed where
    that explains the part better), ``plains`` each one's plain fit; ``parts`` counts the parts tried, and
    ``tried`` holds the parts left to curves (never tried again)."""

    thick: np.ndarray
    """``bool (X, Y, Z)``: the thick part, on the working grid."""
    care: np.ndarray
    """``bool (X, Y, Z)``: the voxels a fit sees (thin parts are neither inside nor outside)."""
    cells: np.ndarray
    """``(C, 3)`` voxel indices of ``care``; ``centres`` their world centres, ``shell`` whether each is on the
    thick part's surface."""
    centres: np.ndarray
    shell: np.ndarray
    origin: np.ndarray
    voxel: float
    axes: np.ndarray
    tau: float
    radius: int
    steps: int
    rng: np.random.Generator
    max_count: int
    min_gain: float
    deform: bool
    log: Callable[[str], None]
    found: list[SuperquadricSet] = field(default_factory=list)
    plains: list[SuperquadricSet] = field(default_factory=list)
    parts: int = 0

    def __post_init__(self) -> None:
        self.tried = np.zeros(self.thick.shape, bool)
        # what one superquadric leaves beside another (a ring at a neck, a rim along a seam) is no part: a
        # residual is opened by half the thin parts' radius
        self.sliver = ball(max(1, self.radius // 2))

    def parts_of(self, union: np.ndarray, deform: bool = True) -> None:
        """Take parts of what ``union`` (``(C,)`` bool over ``cells``: within a voxel of the superquadrics
        so far) leaves. ``deform``: also try each kept part tapered and bent (with the ``deform`` option)."""
        thick, cells, shell, cvox = self.thick, self.cells, self.shell, self.voxel
        best = float((union & shell).sum() / max(shell.sum(), 1))
        while len(self.found) < self.max_count and self.parts < 2 * self.max_count:
            covered = np.zeros(thick.shape, bool)
            covered[tuple(cells[union].T)] = True
            residual = thick & ~covered & ~self.tried
            residual = ndimage.binary_opening(residual, structure=self.sliver)  # slivers along a surface are no part
            if residual.sum() < 8:
                break
            labels = split_parts(residual)
            sizes = np.bincount(labels.ravel())[1:]
            part = int(np.argmax(sizes)) + 1
            self.parts += 1
            mine = labels == part
            # The split may cut one body in two (a mug's, at a bulge of its hull): one superquadric over the part
            # and its largest neighbour wins when it explains both about as well as the part's own does one.
            touching = np.unique(labels[ndimage.binary_dilation(mine) & ~mine])
            touching = touching[touching > 0]
            tries = [mine] + ([mine | (labels == touching[np.argmax(sizes[touching - 1])])] if len(touching) else [])
            fits = _fit_parts(tries, thick, covered, self.care, self.origin, cvox, self.axes, self.tau, self.radius,
                              self.steps, self.rng)
            plain, own_iou, deformed = fits[0]
            if len(fits) > 1 and fits[1][1] >= max(MERGE_IOU, own_iou - 0.02):
                (plain, own_iou, deformed), mine = fits[1], tries[1]
            elif own_iou < RESPLIT_BELOW and (piece := finer_piece(mine)) is not None:
                # what the piece leaves of the part stays in the residual, for the next round
                fit = _fit_parts([piece], thick, covered, self.care, self.origin, cvox, self.axes, self.tau,
                                 self.radius, self.steps, self.rng)[0]
                if fit[1] >= own_iou + RESPLIT_GAIN:
                    self.log(f"superquadrics: a part of {int(mine.sum())} voxels split again where it narrows "
                             f"less (one superquadric explains {own_iou:.0%} of it, {fit[1]:.0%} of its largest "
                             "piece)")
                    (plain, own_iou, deformed), mine = fit, piece
            trial = union | _within(self.centres, plain, cvox)[0]  # the plain fits decide (deformed: the views)
            gain = (trial & shell).sum() / max(shell.sum(), 1) - best
            if own_iou < MIN_PART_IOU or gain < self.min_gain:
                self.log(f"superquadrics: a part of {int(mine.sum())} voxels left to curves (its superquadric "
                         + (f"explains {own_iou:.0%} of it)" if own_iou < MIN_PART_IOU
                            else f"adds {gain:.1%} of the surface)"))
                self.tried |= mine
                continue
            # A kept part its plain fit explains poorly is also fitted tapered and bent
            poor = deform and self.deform and own_iou < DEFORM_BELOW and mine.sum() >= DEFORM_MIN_VOXELS
            better = deformed() if poor else None
            self.found.append(plain if better is None else better)
            self.plains.append(plain)
            union, best = trial, best + gain


def _fit_parts(masks: list[np.ndarray], thick: np.ndarray, covered: np.ndarray, care: np.ndarray,
               origin: np.ndarray, voxel: float, axes: np.ndarray, tau: float, grow: int, steps: int,
               rng: np.random.Generator) -> list[tuple[SuperquadricSet, float, Callable[[], SuperquadricSet | None]]]:
    """One superquadric for each part in ``masks`` (:class:`_Part`), fitted at once: each part's starts are rows
    of one optimisation (its points padded to the longest part's with zero weight), each part with its own
    learning rates, so the fits are each part's own at the cost of one (a part and the part merged with its
    neighbour, in :meth:`_PartTaker.parts_of`). Returns, per part, what :meth:`_Part.chosen` gives: its
    superquadric, its IoU with the part and the function that fits it again tapered and bent."""
    parts = [_Part.of(m, thick, covered, care, origin, voxel, axes, grow, rng) for m in masks]
    n = max(len(p.target) for p in parts)
    P = torch.stack([torch.cat([p.points, p.points[:1].expand(n - len(p.points), 3)]) for p in parts for _ in STARTS])
    T, W = (torch.stack([torch.nn.functional.pad(getattr(p, a), (0, n - len(p.target))) for p in parts for _ in STARTS])
            for a in ("target", "weight"))
    sets = [p.params for p in parts]

    def loss() -> torch.Tensor:
        values = [torch.cat(v) for v in zip(*(q.values() for q in sets))]
        return _loss(radial_distance(P, *values), T, W, tau)

    _optimise(sets, loss, steps, 0.03)
    # The start kept is the loss's choice unless another explains the part clearly better (:data:`START_MARGIN`),
    # by its IoU with all the part's voxels: the loss sees 2,000 of them, weighted, and which start it favours
    # changed with the sample (a carpet cow's body with its legs, one part: IoU 0.707-0.750 over six seeds,
    # its abstraction 0.896-0.944).
    with torch.no_grad():
        by_loss = loss().reshape(len(parts), len(STARTS)).argmin(1).tolist()
    best = []
    for p, k in zip(parts, by_loss):
        ious = p.iou(p.params.to_set())
        best.append(int(np.argmax(ious)) if ious.max() >= ious[k] + START_MARGIN else int(k))
    return [p.chosen(k, tau, steps) for p, k in zip(parts, best)]


@dataclass
class _Part:
    """One part's fit (Marching-Primitives' step, :func:`_fit_parts`): its voxels inside, the empty voxels around
    it outside, the rest of the thick part weakly outside, what is already explained and thin parts not at
    all; at most ``max_points`` of them. Adam does not square a rounded cross-section by itself (a mug's body
    fitted from a ball comes out as two stacked pills): each part starts as a ball, a cylinder and a box
    (:data:`STARTS`), fitted at once, and the loss's best is kept unless another explains the part clearly
    better (:meth:`iou`, :data:`START_MARGIN`)."""

    points: torch.Tensor
    """``(P, 3)`` world points the fit sees, with ``target`` (inside or not) and ``weight`` ``(P,)``."""
    target: torch.Tensor
    weight: torch.Tensor
    params: SuperquadricParams
    """The starts, one row each."""
    inside_pts: np.ndarray
    """``(I, 3)`` the part's voxels, and ``spill_pts`` the empty voxels in its box, for its IoU."""
    spill_pts: np.ndarray

    @classmethod
    def of(cls, mine: np.ndarray, thick: np.ndarray, covered: np.ndarray, care: np.ndarray, origin: np.ndarray,
           voxel: float, axes: np.ndarray, grow: int, rng: np.random.Generator, max_points: int = 2000) -> _Part:
        ijk = np.argwhere(mine)
        lo = np.maximum(ijk.min(axis=0) - 2 * grow, 0)
        hi = np.minimum(ijk.max(axis=0) + 2 * grow + 1, mine.shape)
        box = tuple(slice(a, b) for a, b in zip(lo, hi))
        sub = np.argwhere(care[box] & ~(covered[box] & ~mine[box])) + lo
        at = tuple(sub.T)
        target = mine[at].astype(np.float32)
        weight = np.where(mine[at], 1.0, np.where(thick[at], OTHER_PART_WEIGHT, 1.0)).astype(np.float32)
        if len(sub) > max_points:
            pick = rng.choice(len(sub), max_points, replace=False)
            sub, target, weight = sub[pick], target[pick], weight[pick]
        to_world = lambda a: origin + (a * voxel) @ axes  # noqa: E731
        pts = to_world(ijk.astype(np.float64))
        starts = [_initial(pts, axes.T if frame == "grid" else None, factor) for _, frame, factor in STARTS]
        params = SuperquadricParams(np.array([a for a, _, _ in starts]), np.array([e for e, _, _ in STARTS]),
                                    np.array([q for _, q, _ in starts]), np.array([c for _, _, c in starts]))
        return cls(torch.from_numpy(to_world(sub.astype(np.float64)).astype(np.float32)), torch.from_numpy(target),
                   torch.from_numpy(weight), params, pts, to_world(np.argwhere(~thick[box] & care[box]) + lo))

    def iou(self, s: SuperquadricSet) -> np.ndarray:
        """``(M,)``: each of ``s``'s IoU with the part (what it holds of it, over the part and the empty voxels
        it spills into)."""
        held = (_distance(self.inside_pts, s) <= 0).sum(1)
        return held / (len(self.inside_pts) + (_distance(self.spill_pts, s) <= 0).sum(1))

    def chosen(self, best: int, tau: float, steps: int
               ) -> tuple[SuperquadricSet, float, Callable[[], SuperquadricSet | None]]:
        """The fitted start ``best``, its IoU with the part, and a function that fits the part again tapered and
        bent, giving the deformed superquadric or ``None`` when it explains the part too little better
        (:data:`DEFORM_RESIDUAL`): called only for parts the abstraction keeps. The parts and their count are
        chosen by the plain fits, so a judge that turns every deformed one back to its plain fit gets the
        plain abstraction."""
        sq = self.params.to_set().subset(np.array([best]))
        iou = float(self.iou(sq)[0])
        P, T, W = self.points, self.target[None], self.weight[None]

        def deformed() -> SuperquadricSet | None:
            # A cone-like or curved part: the plain one's fit, tapered and bent along each of its axes in turn
            # (the deformations act along the local z: a squat cone's axis is its shortest). A bend's plane gets
            # no gradient while it is unbent, so each axis starts bending in two perpendicular planes.
            deformable = SuperquadricParams.from_set(_deformed_starts(sq), deformable=True)
            _optimise(deformable, lambda: _loss(radial_distance(P, *deformable.values(), deformable.deformation()),
                                                T, W, tau), steps, 0.03)
            tries = deformable.to_set()
            scores = self.iou(tries)
            k = int(np.argmax(scores))
            return tries.subset(np.array([k])) if 1 - scores[k] <= DEFORM_RESIDUAL * (1 - iou) else None

        return sq, iou, deformed


def _deformed_starts(sq: SuperquadricSet) -> SuperquadricSet:
    """Nine starts of a deformed fit from one plain superquadric: its frame turned so that each of its axes is
    the local z in turn (a cyclic permutation of the axes), with flat ends (a cone is a tapered cylinder)
    slightly bent toward the new x and toward the new y, and with the plain one's shape (a spout with a round
    tip: flat-ended fits of the teapot's come out box-like, ε₁ 0.3, and draw no outline)."""
    R = quaternion_to_matrix(sq.rotation[0])
    rows = []
    for shift in range(3):
        order = np.roll(np.arange(3), -shift)
        q = matrix_to_quaternion(R[:, order])
        for shape, bend in ((FLAT_ENDS, (1e-3, 0.0)), (FLAT_ENDS, (0.0, 1e-3)), (sq.shape[0], (1e-3, 0.0))):
            rows.append((sq.scale[0][order], shape, q, sq.translation[0], bend))
    return SuperquadricSet(*(np.array([r[k] for r in rows]) for k in range(4))).with_deformation(
        np.zeros((len(rows), 2)), np.array([r[4] for r in rows]))


def _surface_samples(occupied: np.ndarray, thick: np.ndarray, k: int, origin: np.ndarray, voxel: float,
                     axes: np.ndarray, rng: np.random.Generator, count: int = 8000, band: int = 2
                     ) -> tuple[np.ndarray, np.ndarray]:
    """World centres of full-grid voxels within ``band`` voxels of the thick part's surface, ``count`` inside
    and ``count`` outside it, and whether each is inside. ``thick`` is on the working grid, ``k`` times
    coarser; on the full grid the thick part is its blocks' occupied voxels (thin parts are left out)."""
    up = np.repeat(np.repeat(np.repeat(thick, k, 0), k, 1), k, 2)[tuple(slice(0, n) for n in occupied.shape)]
    pad = [(0, n - m) for n, m in zip(occupied.shape, up.shape)]
    fine = np.pad(up, pad) & occupied
    near = fine & ~ndimage.binary_erosion(fine, iterations=band)
    far = ndimage.binary_dilation(fine, iterations=band) & ~fine & ~(occupied & ~fine)
    out_pts, out_in = [], []
    for region, flag in ((near, True), (far, False)):
        ijk = np.argwhere(region)
        if len(ijk) > count:
            ijk = ijk[rng.choice(len(ijk), count, replace=False)]
        out_pts.append(origin + (ijk * voxel) @ axes)
        out_in.append(np.full(len(ijk), flag))
    return np.concatenate(out_pts), np.concatenate(out_in)


def _refine_union(sq: SuperquadricSet, centres: np.ndarray, in_thick: np.ndarray, tau: float, steps: int,
                  rng: np.random.Generator, max_points: int = 20000, only: np.ndarray | None = None
                  ) -> SuperquadricSet:
    """All superquadrics together on the union's occupancy against the thick part, at points ``centres``;
    with ``only`` (``(M,)`` bool), only those move (the others hide and explain as they are)."""
    sel = rng.choice(len(centres), min(len(centres), max_points), replace=False)
    C = torch.from_numpy(centres[sel].astype(np.float32))
    Y = torch.from_numpy(in_thick[sel].astype(np.float32))[None]
    deformed = sq.deformed
    joint = SuperquadricParams.from_set(sq, deformable=bool(deformed.any()))
    moving = {}
    if joint.deformable:  # the plain ones stay plain
        for tensor in (joint.raw_taper, joint.raw_bend, joint.bend_direction):
            moving[tensor] = deformed
    if only is not None:
        for tensor in (joint.log_scale, joint.raw_shape, joint.rotation, joint.translation):
            moving[tensor] = only
    for tensor, rows in moving.items():
        keep = torch.from_numpy(np.asarray(rows, np.float32))
        tensor.register_hook(lambda g, keep=keep: g * keep.reshape(-1, *([1] * (g.dim() - 1))))

    def loss() -> torch.Tensor:
        d = radial_distance(C, *joint.values(), joint.deformation())  # (M, P)
        soft_min = -tau * torch.logsumexp(-d / tau, dim=0)  # the union's distance, smoothly
        return _loss(soft_min[None], Y, torch.ones_like(Y), tau).sum()

    # M × 20,000 points: large enough for every core (the skull's 7 superquadrics: 44 → 27 ms a step on two)
    with torch_threads(cpu_count()):
        _optimise(joint, loss, steps, 0.01)
    return joint.to_set()
