"""Stroke discovery: 3D feature curves found from multi-view edge evidence, and how many to keep.

1. **Evidence** (:mod:`.evidence`): every voxel near the visual hull votes with the views that see it.
2. **Curves** (:mod:`.ridges`): ridge points of the evidence are linked into 3D polylines, split at corners
   and fitted with cubic Béziers to a 3D tolerance (a straight edge is one cubic, a circle four).
3. **Choice** (:func:`select_strokes`): candidates are taken greedily by how many line pixels they newly
   explain across the views, minus the ink they put where no line is; the count is automatic — selection
   stops when the best remaining stroke would newly explain less than ``min_gain`` (0.1 %) of all line
   pixels — and ``max_curves`` only bounds it. A stroke that runs along one already chosen explains nothing new, so
   duplicates are never taken. When ``max_curves`` cut the choice short, up to ``outline_curves`` more are
   chosen for the masks' outline alone (:func:`complete_outline`). A candidate lying on a smooth face of the
   hull (:mod:`.texture`: print, not structure) counts only the outline pixels it explains.
4. **Joins**: stroke ends that meet (within two voxels) are snapped to one point, so edges meet at corners.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from ...arrays import silhouette_boundary, spread_indices
from ...scenes import Scene
from ...strokes.bezier import bezier_points
from ...strokes.fitcurve import fit_cubics_many
from ..volume.carve import VoxelGrid, project_points
from .evidence import Evidence, curve_samples, depth_maps, edge_evidence
from .facing import curve_normals
from .hollows import Hollow, clear_of, find_hollows
from .ridges import _bridge, link_ridges, ridge_points
from .rims import CONTOUR_GATES, Rims, find_rims
from .salience import MIN_SALIENCE, albedo_steps, choose_features, duplicates, feature_cubics, score_features
from .sightlines import seen_through
from .texture import SMOOTH_SHARE, on_smooth_faces, smooth_shares
from .tubes import SIDES, Tube, find_tubes, in_tubes


@dataclass
class Discovery:
    """What discovery found: chosen cubics ``(N, 4, 3)`` and the numbers behind the choice."""

    control_points: np.ndarray
    normals: np.ndarray
    """``(N, 2, 2, 3)`` face normals of each cubic (see :class:`~doodle.strokes.model.CurveSet`)."""
    candidates: int
    polylines: int
    coverage: float
    """Share of all line pixels (over the views) that the chosen strokes explain."""
    outline: float
    """Share of the masks' boundary pixels (the silhouettes) that the chosen strokes explain."""
    gains: list[float] = field(default_factory=list)
    voxel: float = 0.0
    seconds: dict[str, float] = field(default_factory=dict)
    contour: np.ndarray = field(default_factory=lambda: np.zeros(0))
    """``(N,)`` each cubic's contour gate (see :class:`~doodle.strokes.model.CurveSet`; ``0``: a feature curve)."""
    source: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    """``(N,)`` the view a contour curve was traced in (``-1`` for feature curves): judged elsewhere only."""
    outline_drawn: float = 0.0
    """Share of the silhouettes' pixels drawn by the chosen strokes together with what was ``taken`` (the
    superquadrics' outlines): how whole the sketch's outline is."""


#: 3D fitting tolerance of the cubics, in voxels.
TOLERANCE_VOXELS = 2.0
#: A stroke shorter than this share of the object's size that touches no other stroke is dropped.
STRAY_LENGTH = 0.02
#: A contour curve's gain counts this much against a feature curve's: where both draw a line (a sharp edge on
#: the outline), the feature curve, which every view sees, is the one to keep.
CONTOUR_WEIGHT = 0.7
#: Each contour curve is also offered as a feature curve, drawn from every side its faces allow: where the
#: outline runs along a crease, the view's trace of it is the crease itself, often longer and cleaner than
#: the evidence's ridges there.
RIM_FEATURES = True
#: A pixel of the masks' outline counts this much in a stroke's gain against one of the lines inside: the
#: outline is what makes an object recognisable, and inside the lines are busy (studs, print, shading).
OUTLINE_WEIGHT = 1.5
#: Once the choice is cut short by its budget (or leaves the outline open, :data:`OUTLINE_OPEN`), strokes for
#: the outline alone are chosen while each newly explains at least this share of the outline pixels (see
#: :func:`choose_curves`).
OUTLINE_MIN_GAIN = 0.000125
#: A curved thin part (a handle) is offered as its two sides in its plane, in place of the evidence's pieces
#: and the views' traces along it (:mod:`.tubes`): the teapot's handle, a tangle of 13 pieces, is two arcs.
TUBES = True
#: The level's outline strokes are chosen whenever the strokes chosen (with the superquadrics' outlines) draw
#: less than this share of the outline pixels, not only once the curve budget is spent: an outline open where
#: the budget was not spent stayed open (the tripod's head and legs' ends: held-out F 0.924 → 0.934; the carpet
#: parcel's box, 0.915 → 0.919).
OUTLINE_OPEN = 0.9
#: How near (px, at the evidence size) a stroke must pass an outline pixel of automatic masks to explain it.
#: Such a boundary, and the SfM pose it is seen from, may be a pixel or two off, differently in each photo,
#: so the views' outlines of one 3D edge seldom agree to the pixel that drawn lines are held to (1 px, below).
#: ``doodle eval`` allows 2 px at 256, which is 4 px here. On the Lego photos (94 registered), with a 1 px
#: reach the 128 strokes chosen drew 47 % of the outline pixels here and 0.731 of the true outline in eval.
AUTOMATIC_OUTLINE_REACH = 2
#: Views (evenly spread) in which the step across each candidate on a smooth face is measured.
STEP_VIEWS = 12
#: A feature chosen by salience (:mod:`.salience`) has at least this share of its samples on smooth faces of
#: the hull: paint lies on a face; a ring half on a crease is where two parts meet (the plain cow's leg tops,
#: shares 0.3–0.7, cost line precision 0.948 → 0.914 as features; the calf's eyes and patches: 0.94–1).
PAINT_SHARE = 0.8
#: How far (share of the object's size) a hollow's ring may be moved out of the superquadrics that bulge over it.
CLEAR_REACH = 0.1
#: The ridge threshold's evidence level; a bridge across a gap needs half of it on average.
BRIDGE_EVIDENCE = 0.15
# the line pixels a stroke sample explains: its 3 × 3 neighbourhood (within 1.5 px)
_NEIGHBOURS = np.array([(dy, dx) for dy in (-1, 0, 1) for dx in (-1, 0, 1)])


def _disc_offsets(reach: int) -> np.ndarray:
    """``(K, 2)`` (dy, dx) offsets within ``reach + 0.5`` px: the pixels a stroke sample explains on an outline."""
    r = np.arange(-reach, reach + 1)
    dy, dx = np.meshgrid(r, r, indexing="ij")
    keep = dy**2 + dx**2 <= (reach + 0.5) ** 2
    return np.stack([dy[keep], dx[keep]], axis=1)


def stroke_coverage(controls: np.ndarray, ev: Evidence, views: list[int], spacing_px: float = 0.7,
                    gates: np.ndarray | None = None, contour_normals: np.ndarray | None = None,
                    source: np.ndarray | None = None, outlines: dict[int, np.ndarray] | None = None,
                    outline_reach: int = 1) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
    """For each cubic: the line pixels it explains (global ids over ``views``), its off-line ink and its ink.

    A cubic is sampled about ``spacing_px`` apart in the views; a sample counts in a view when the hull does
    not hide it and, for a contour curve (``gates (N,)`` above 0, with its ``contour_normals (N, 2, 3)`` at
    start and end), when the view grazes its surface there (as the exporters draw it); it explains the line
    pixels of its 3 × 3 neighbourhood (within 1.5 px), and is off-line ink when there are none. A contour
    curve is not counted in the view it was traced in (``source (N,)``, an index into the evidence's views;
    ``-1``: none): there it lies on the outline by construction, and what it is worth is how well it draws
    the outline of the others. ``outlines`` (per view of ``views``, a bool map like ``ev.lines``: the masks'
    boundaries) with ``outline_reach`` above 1: a sample also explains the outline pixels within
    ``outline_reach + 0.5`` px (:data:`AUTOMATIC_OUTLINE_REACH`).
    """
    wide = _disc_offsets(outline_reach) if outlines is not None and outline_reach > 1 else None
    P, T, owner, _ = curve_samples(controls, ev.grid.voxel, spacing_px)
    gated = None
    if gates is not None and (gates > 0).any():
        gated = np.flatnonzero(gates[owner] > 0)
        n = contour_normals[owner[gated]]
        Ng = ((1 - T[gated])[:, None] * n[:, 0] + T[gated][:, None] * n[:, 1]).astype(np.float32)
        Ng /= np.maximum(np.linalg.norm(Ng, axis=1, keepdims=True), 1e-12)
        Pg, Gg = P[gated], gates[owner[gated]]
        Probes = Pg + 2 * ev.grid.voxel * Ng
        is_gated = np.zeros(len(P), bool)
        is_gated[gated] = True
        rank = np.zeros(len(P), int)
        rank[gated] = np.arange(len(gated))
    off = np.zeros(len(controls))
    ink = np.zeros(len(controls))
    hit_owner, hit_pix = [], []
    offset = 0
    for v in views:
        cam, lines = ev.cameras[v], ev.lines[v]
        H, W = lines.shape
        u, w, z = project_points(cam, P)
        ok = (z > 1e-6) & (u >= 1) & (w >= 1) & (u < W - 1) & (w < H - 1)
        if gated is not None:
            to_eye = cam.center.astype(np.float32) - Pg
            cos = (Ng * to_eye).sum(1) / np.maximum(np.linalg.norm(to_eye, axis=1), 1e-12)
            ok[gated[np.abs(cos) > Gg]] = False
        if source is not None:
            ok[source[owner] == v] = False
        idx = np.flatnonzero(ok)
        visible = z[idx] <= ev.depth[v][w[idx], u[idx]] + ev.margin
        if gated is not None:
            # a contour point's ray grazes the hull, whose depth there is the far side of a long chord: it is
            # tested a couple of voxels out along its normal, as the exporters test it against superquadrics
            pu, pw, pz = project_points(cam, Probes)
            g = is_gated[idx]
            j = rank[idx[g]]
            inside = (pu[j] >= 0) & (pw[j] >= 0) & (pu[j] < W) & (pw[j] < H)
            seen = np.ones(len(j), bool)
            seen[inside] = pz[j][inside] <= ev.depth[v][pw[j][inside], pu[j][inside]] + ev.margin
            visible[g] = seen
        idx = idx[visible]
        hit = np.zeros(len(idx), bool)
        # the lines within the 3 × 3 neighbourhood (always inside: samples keep a pixel off the border), and
        # with a wider outline reach the outline pixels within it
        for img, near in [(lines, _NEIGHBOURS)] + ([(outlines[v], wide)] if wide is not None else []):
            ny = np.clip(w[idx, None] + near[None, :, 0], 0, H - 1)
            nx = np.clip(u[idx, None] + near[None, :, 1], 0, W - 1)
            on = img[ny, nx]  # (samples, neighbours)
            hit |= on.any(axis=1)
            r, c = np.nonzero(on)
            hit_owner.append(owner[idx[r]])
            hit_pix.append((ny[r, c] * W + nx[r, c]).astype(np.int64) + offset)
        np.add.at(ink, owner[idx], 1.0)
        np.add.at(off, owner[idx[~hit]], 1.0)
        offset += lines.size
    ho, hp = np.concatenate(hit_owner), np.concatenate(hit_pix)
    order = np.lexsort((hp, ho))
    ho, hp = ho[order], hp[order]
    bounds = np.searchsorted(ho, np.arange(len(controls) + 1))
    sets = [np.unique(hp[bounds[k]:bounds[k + 1]]) for k in range(len(controls))]
    return sets, off, ink


def select_strokes(covers: list[np.ndarray], off: np.ndarray, max_strokes: int, min_gain: float,
                   min_novelty: float = 0.5, off_weight: float = 0.5, taken: np.ndarray | None = None,
                   weight: np.ndarray | None = None, pixel_weight: np.ndarray | None = None,
                   smooth: np.ndarray | None = None, outline: np.ndarray | None = None
                   ) -> tuple[list[int], list[float]]:
    """Greedy set cover: the stroke that newly explains the most line pixels (minus ``off_weight`` × its
    off-line ink) first.

    A stroke is taken while its gain is at least ``min_gain`` pixels and at least ``min_novelty`` of the
    line pixels it explains are not explained by the strokes chosen before it (a stroke along one already
    chosen is a duplicate). At most ``max_strokes``. ``taken``: pixel ids explained before any stroke is
    chosen (superquadric outlines); they count fully against the gain but only half against the novelty
    (at least ``min_novelty / 2`` of a stroke's pixels must be new overall): a cylinder's rim runs along its
    superquadric's outline in the views from behind it and is a line of its own in the others (judged as
    against a stroke, the mug's rim was a duplicate and went undrawn once its top was a drawn outline),
    while a stroke mostly along an outline would be a tick beside it. Lazy evaluation (gains only shrink as
    strokes are chosen) keeps it fast.

    ``smooth`` ``(N,)`` bool marks strokes on a smooth face of the object (:mod:`.texture`): of the pixels
    such a stroke explains only the ``outline`` ones (global ids) count, and the novelty test then asks that
    its new outline, as the gain weighs it, be at least a quarter of its pixels. Where a smooth face turns
    away from a view, a line on it is the outline; anywhere else it is paint.

    Returns:
        The chosen indices in order, and each one's gain in pixels.
    """
    import heapq

    size = max((int(c.max()) + 1 for c in covers if len(c)), default=1)
    done = np.zeros(size, bool)
    if taken is not None and len(taken):
        done[taken[taken < size]] = True
    taken = done
    by_curves = np.zeros(size, bool)  # novelty is judged against the strokes chosen here, not ``taken``

    pw = None
    if pixel_weight is not None:
        pw = np.ones(size)
        pw[: min(size, len(pixel_weight))] = pixel_weight[:size]
    ow = None  # what a pixel counts for a stroke on a smooth face: only the outline's
    if smooth is not None and smooth.any():
        ow = np.zeros(size)
        ids = outline[outline < size] if outline is not None else np.zeros(0, np.int64)
        ow[ids] = 1.0 if pw is None else pw[ids]

    def gain(k: int) -> tuple[float, float]:
        w = ow if ow is not None and smooth[k] else pw
        new = float((~taken[covers[k]]).sum()) if w is None else float(w[covers[k]][~taken[covers[k]]].sum())
        n = max(len(covers[k]), 1)
        novelty = min(float((~by_curves[covers[k]]).sum()) / n, 2 * new / n)  # see the docstring
        g = new - off_weight * off[k]
        return (g * weight[k] if weight is not None and g > 0 else g), novelty

    heap = [(-gain(k)[0], k) for k in range(len(covers))]
    heapq.heapify(heap)
    chosen, gains = [], []
    while heap and len(chosen) < max_strokes:
        neg, k = heapq.heappop(heap)
        if -neg < min_gain:
            break
        g, novelty = gain(k)
        if heap and g < -heap[0][0]:  # stale: re-queue with the fresh gain
            heapq.heappush(heap, (-g, k))
            continue
        if g < min_gain:
            break
        if novelty < min_novelty:
            continue  # mostly a duplicate; never better later
        chosen.append(k)
        gains.append(g)
        taken[covers[k]] = True
        by_curves[covers[k]] = True
    return chosen, gains


def complete_outline(covers: list[np.ndarray], off: np.ndarray, chosen: list[int], outline: np.ndarray, pixels: int,
                     max_strokes: int, min_gain: float, taken: np.ndarray | None = None,
                     weight: np.ndarray | None = None) -> tuple[list[int], list[float]]:
    """Strokes chosen after ``chosen`` for the outline alone: :func:`select_strokes` with only the ``outline``
    pixels (global ids, of ``pixels`` in all) counting in the gain, those ``chosen`` (and ``taken``) explain
    counting as drawn, off-line ink costing as before. The novelty test of :func:`select_strokes` then asks
    that at least a quarter of a stroke's pixels be new outline: one mostly along the inside lines is no
    outline stroke, however many outline pixels it also meets. Returns the new indices and their gains."""
    drawn = [covers[k] for k in chosen] + ([taken] if taken is not None else [])
    on_outline = np.zeros(pixels)
    on_outline[outline] = 1.0
    return select_strokes(covers, off, max_strokes, min_gain, taken=np.unique(np.concatenate(drawn)) if drawn else None,
                          weight=weight, pixel_weight=on_outline)


def refine_on_evidence(controls: np.ndarray, ev: Evidence, steps: int = 60, samples: int = 24,
                       smooth: float = 0.7, lr_voxels: float = 0.05) -> np.ndarray:
    """Pull cubics onto the evidence's ridges: maximise the mean (smoothed) evidence along each curve.

    The evidence is one 3D field voting with all views at once, at the evidence resolution, so this polishes
    the few-voxel error of the cubic fit without the working images' coarser pixels. Adam on the control
    points, trilinear lookups; a small penalty on the control polygon's second differences keeps the curves
    from kinking.
    """
    import torch

    from ..adam import Adam

    if len(controls) == 0 or steps <= 0:
        return controls
    S = ndimage.gaussian_filter(ev.score.astype(np.float32), smooth)
    vol = torch.from_numpy(S)[None, None]  # (1, 1, X, Y, Z)
    shape = torch.tensor(S.shape, dtype=torch.float32)
    c = torch.tensor(ev.grid.coordinates(controls), dtype=torch.float32, requires_grad=True)  # voxel units
    t = torch.linspace(0, 1, samples)[:, None]
    basis = torch.cat([(1 - t) ** 3, 3 * t * (1 - t) ** 2, 3 * t**2 * (1 - t), t**3], -1)
    opt = Adam([c], lr=lr_voxels)
    start = c.detach().clone()
    for _ in range(steps):
        pts = torch.einsum("tk,nkd->ntd", basis, c)  # (N, T, 3) voxel coordinates
        # grid_sample wants (z, y, x) order in [-1, 1] for a (D, H, W) = (X, Y, Z) volume
        g = (pts / (shape - 1) * 2 - 1).flip(-1)[None, None]
        val = torch.nn.functional.grid_sample(vol, g, align_corners=True, padding_mode="zeros")[0, 0, 0]
        second = c[:, :2] - 2 * c[:, 1:3] + c[:, 2:]
        loss = -val.mean() + 1e-3 * second.pow(2).sum(-1).mean() + 1e-3 * (c - start).pow(2).sum(-1).mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
    return ev.grid.centres(c.detach().numpy().astype(np.float64))


def bridge_gaps(controls: np.ndarray, ev: Evidence, max_gap: float, min_evidence: float,
                max_angle_deg: float = 30.0) -> np.ndarray:
    """Cubics ``(B, 4, 3)`` closing gaps between chosen strokes whose ends face each other.

    Two ends at most ``max_gap`` apart, each pointing at the other within ``max_angle_deg`` and roughly
    opposite, are joined by the Hermite cubic matching both end tangents when the (smoothed) evidence along
    it averages at least ``min_evidence``: an edge that the ridges left in dashes is drawn whole.
    """
    if len(controls) < 2:
        return np.zeros((0, 4, 3))
    ends = np.concatenate([controls[:, 0], controls[:, 3]])
    out_dir = np.concatenate([controls[:, 0] - controls[:, 1], controls[:, 3] - controls[:, 2]])
    out_dir /= np.maximum(np.linalg.norm(out_dir, axis=1, keepdims=True), 1e-12)
    pairs = cKDTree(ends).query_pairs(max_gap, output_type="ndarray")
    if len(pairs) == 0:
        return np.zeros((0, 4, 3))
    n = len(controls)
    a, b = pairs[:, 0], pairs[:, 1]
    gap = ends[b] - ends[a]
    dist = np.linalg.norm(gap, axis=1)
    cos_max = np.cos(np.radians(max_angle_deg))
    safe = np.maximum(dist, 1e-12)
    ok = (a % n != b % n) & (dist > 0.5 * ev.grid.voxel)
    ok &= ((gap * out_dir[a]).sum(1) / safe >= cos_max) & ((-gap * out_dir[b]).sum(1) / safe >= cos_max)
    S = ndimage.gaussian_filter(ev.score.astype(np.float32), 0.7)
    used = np.zeros(len(ends), bool)
    bridges = []
    for i in np.flatnonzero(ok)[np.argsort(dist[ok])]:
        ea, eb = a[i], b[i]
        if used[ea] or used[eb]:
            continue
        third = dist[i] / 3
        c = np.stack([ends[ea], ends[ea] + third * out_dir[ea], ends[eb] + third * out_dir[eb], ends[eb]])
        ijk = np.clip(ev.grid.index(bezier_points(c, np.linspace(0, 1, 9))), 0, np.array(S.shape) - 1)
        if S[tuple(ijk.T)].mean() >= min_evidence:
            bridges.append(c)
            used[ea] = used[eb] = True
    return np.array(bridges) if bridges else np.zeros((0, 4, 3))


def join_strokes(controls: np.ndarray, voxel: float, tolerance: float, max_angle_deg: float = 25.0,
                 samples_per_voxel: float = 1.0) -> np.ndarray:
    """Merge cubics that continue each other (ends within a voxel and a half, tangents within
    ``max_angle_deg``) into chains and refit each chain within ``tolerance``: a straight edge left in
    pieces becomes one cubic again, a circle four."""
    if len(controls) < 2:
        return controls
    polys = []
    for c in controls:
        rough = bezier_points(c, np.linspace(0, 1, 9))
        n = max(4, int(np.linalg.norm(np.diff(rough, axis=0), axis=1).sum() / voxel * samples_per_voxel))
        polys.append(bezier_points(c, np.linspace(0, 1, n)))
    chains = _bridge(polys, 1.5 * voxel, max_angle_deg, touch=1.5 * voxel)
    if len(chains) == len(polys):
        return controls
    pieces = fit_cubics_many(chains, tolerance, [bool(np.linalg.norm(p[0] - p[-1]) < 1e-9) for p in chains])
    return np.concatenate(pieces)


def drop_stray(controls: np.ndarray, min_length: float, touch: float) -> np.ndarray:
    """Drop strokes shorter than ``min_length`` that touch no other stroke at either end: alone, they read as
    ticks and dots; at a corner or in a chain they are part of a line."""
    if len(controls) == 0:
        return controls
    length = np.linalg.norm(np.diff(bezier_points(controls, np.linspace(0, 1, 17)), axis=1), axis=2).sum(1)
    ends = np.concatenate([controls[:, 0], controls[:, 3]])
    n = len(controls)
    touching = np.zeros(n, bool)
    for a, b in cKDTree(ends).query_pairs(touch, output_type="ndarray"):
        if a % n != b % n:
            touching[a % n] = touching[b % n] = True
    return controls[(length >= min_length) | touching]


def snap_ends(controls: np.ndarray, radius: float) -> np.ndarray:
    """Move stroke end points that lie within ``radius`` of each other onto their common mean (corners meet).

    The inner control points move with their end point, so tangents keep their directions.
    """
    if len(controls) < 2:
        return controls
    out = controls.copy()
    ends = np.concatenate([out[:, 0], out[:, 3]])
    pairs = cKDTree(ends).query_pairs(radius, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(ends), len(ends)))
    _, roots = connected_components(graph, directed=False)
    n = len(controls)
    for r in np.unique(roots):
        members = np.flatnonzero(roots == r)
        if len(members) < 2:
            continue
        target = ends[members].mean(axis=0)
        for m in members:
            k, at = m % n, (0 if m < n else 3)
            shift = target - out[k, at]
            out[k, at] += shift
            out[k, 1 if at == 0 else 2] += shift
    return out


@dataclass
class Traces:
    """What discovery traces before it offers anything (:func:`trace_candidates`): the same whichever outline
    the fit draws, so a fit that runs twice (``--outline auto`` falling back to the hull) traces once."""

    evidence: Evidence
    """With the sight lines' ``free`` voxels and the depth maps that leave them out."""
    controls: np.ndarray
    """``(N, 4, 3)`` the feature cubics."""
    shares: np.ndarray | None
    """``(N,)`` each feature cubic's share on smooth faces of the hull (:func:`.texture.smooth_shares`;
    ``None``: not judged)."""
    rims: Rims | None
    """The views' contour curves (:func:`.rims.find_rims`), or ``None`` without contours."""
    boundaries: list[np.ndarray]
    """Each view's mask boundary pixels."""
    ridge_points: int
    polylines: int
    seconds: dict[str, float]
    texture: bool
    steps: np.ndarray | None = None
    """``(N,)`` the images' step across each cubic on a smooth face (:func:`.salience.albedo_steps`; 0 for the
    others)."""
    hollows: list[Hollow] = field(default_factory=list)
    """The dark hollows and patches the views agree on (:mod:`.hollows`), each a ring; empty without texture."""
    tubes: list[Tube] = field(default_factory=list)
    """The curved thin parts (:mod:`.tubes`): their sides are offered, not the pieces along them."""
    side_cubics: list[np.ndarray] = field(default_factory=list)
    """The indices into ``controls`` of each tube's sides' cubics: a tube chosen in part is drawn whole."""

    @property
    def smooth(self) -> np.ndarray | None:
        """``(N,)`` the feature cubics on smooth faces of the hull (``None``: not judged)."""
        return None if self.shares is None else self.shares > SMOOTH_SHARE


@dataclass
class Candidates:
    """Candidate cubics and what each explains in the selection views (see :func:`find_candidates`)."""

    controls: np.ndarray
    covers: list[np.ndarray]
    off: np.ndarray
    total: int
    """Line pixels over the selection views."""
    views: list[int]
    rim: np.ndarray
    """Global ids of the masks' boundary pixels over the selection views."""
    evidence: Evidence
    ridge_points: int
    polylines: int
    seconds: dict[str, float]
    gates: np.ndarray = field(default_factory=lambda: np.zeros(0))
    """``(N,)`` each candidate's contour gate (``0``: a feature curve; see :mod:`.rims`)."""
    contour_normals: np.ndarray = field(default_factory=lambda: np.zeros((0, 2, 3)))
    """``(N, 2, 3)`` a contour candidate's surface normals at start and end (zeros for feature curves)."""
    source: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    """``(N,)`` the evidence view a contour candidate was traced in (``-1`` for feature curves)."""
    smooth: np.ndarray | None = None
    """``(N,)`` bool: the feature candidates that lie on a smooth face of the hull, print unless they draw
    the outline (:mod:`.texture`); ``None``: not judged."""
    hull_outline: bool = False
    """The hull's outline is drawn: candidates on smooth faces are not chosen (the outline they would draw is
    drawn). Held-out F beside the hull's outline, against choosing them for the outline as before:
    Cheburashka 0.948 → 0.959 (line precision 0.908 → 0.925), parcel 0.982 → 0.974 with its box's edges drawn
    (feature curves 29 % → 50 % on them), chair 0.907 → 0.904 with 94 % of its edges covered instead of 89 %
    (with the contour curves' traces offered, as here)."""

    traces: Traces | None = None
    """What the candidates were offered from (:func:`trace_candidates`), to offer again."""

    def pixel_ids(self, view_pixels: list[np.ndarray], reach: int = 1) -> np.ndarray:
        """Global ids of the line pixels within ``reach`` pixels (a (2 reach + 1)² square) of given pixels
        ``(P_v, 2)`` (x, y) per selection view."""
        r = np.arange(-reach, reach + 1)
        offsets = np.stack(np.meshgrid(r, r, indexing="ij"), -1).reshape(-1, 2)  # (dy, dx)
        out, offset = [], 0
        for v, px in zip(self.views, view_pixels):
            lines = self.evidence.lines[v]
            H, W = lines.shape
            if len(px):
                x = np.clip(np.floor(px[:, 0]).astype(int)[:, None] + offsets[None, :, 1], 0, W - 1)
                y = np.clip(np.floor(px[:, 1]).astype(int)[:, None] + offsets[None, :, 0], 0, H - 1)
                on = lines[y, x]
                out.append((y[on] * W + x[on]).astype(np.int64) + offset)
            offset += lines.size
        return np.unique(np.concatenate(out)) if out else np.zeros(0, np.int64)


def trace_candidates(scene: Scene, max_voxels: int = 192, threshold: float = 0.15, min_length: float = 0.03,
                     tolerance_voxels: float = TOLERANCE_VOXELS, contours: bool = True, texture: bool = True,
                     carving: tuple[VoxelGrid, np.ndarray] | None = None, hollows: bool = True) -> Traces:
    """Evidence, ridges, polylines, feature cubics, sight lines and contour curves (see :func:`find_candidates`
    for the arguments)."""
    clock = time.perf_counter()
    seconds: dict[str, float] = {}
    ev = edge_evidence(scene, max_voxels, carving=carving)
    seconds["evidence"] = time.perf_counter() - clock
    t = time.perf_counter()
    h = ev.grid.voxel
    # hysteresis, as in Canny: ridges are traced down to half the threshold, and a polyline is kept when
    # some of it reaches the threshold
    ridges = ridge_points(ev.score, ev.grid, 0.5 * threshold)
    size = h * float(np.linalg.norm(ev.grid.shape))
    strong = cKDTree(ridges.points[ridges.strength >= threshold]) if (ridges.strength >= threshold).any() else None
    polys = [p for p in link_ridges(ridges, h) if np.linalg.norm(np.diff(p, axis=0), axis=1).sum() >= min_length * size
             and strong is not None and np.isfinite(strong.query(p, distance_upper_bound=0.5 * h)[0]).any()]
    tubes = find_tubes(ev.grid, ev.occupied) if TUBES else []
    sides = [side for tube in tubes for side in tube.sides]
    if tubes:  # a handle's two sides, each in one piece (:mod:`.tubes`), for the pieces along it
        along = in_tubes(polys, tubes)
        polys = [p for p, a in zip(polys, along) if not a] + sides
    pieces = fit_cubics_many(polys, tolerance_voxels * h) if polys else []
    controls = np.concatenate(pieces) if pieces else np.zeros((0, 4, 3))
    ends = np.cumsum([0] + [len(p) for p in pieces])
    first = len(polys) - len(sides)  # the sides come last, two per tube
    side_cubics = [np.arange(ends[first + SIDES * t], ends[first + SIDES * (t + 1)]) for t in range(len(tubes))]
    shares = smooth_shares(controls, ev.grid, ev.occupied) if texture else None
    smooth = shares > SMOOTH_SHARE if shares is not None else None
    seconds["curves"] = time.perf_counter() - t
    t = time.perf_counter()
    # where the views see feature curves inside the hull, they see through it: its depth maps leave that out
    boundaries = [silhouette_boundary(m) for m in scene.masks]
    free = seen_through(controls, ev, outlines=boundaries)
    ev = replace(ev, free=free, depth=depth_maps(ev.grid, ev.occupied & ~free, ev.cameras) if free.any() else ev.depth)
    seconds["sight lines"] = time.perf_counter() - t
    steps = None
    if smooth is not None and smooth.any():  # paint or shading? the images' step across each (salience.py)
        steps = np.zeros(len(controls))
        views = spread_indices(len(ev.cameras), STEP_VIEWS)
        steps[smooth] = albedo_steps(controls[smooth], [ev.cameras[v] for v in views],
                                     [scene.images[v] for v in views], [scene.masks[v] for v in views],
                                     [ev.depth[v] for v in views], ev.margin)
    rings: list[Hollow] = []
    if texture and hollows:  # eye sockets, a nose, dark paint: rings the salience choice may draw
        t = time.perf_counter()
        rings = find_hollows(ev.grid, ev.occupied if ev.free is None else ev.occupied & ~ev.free, ev.cameras,
                               scene.images, scene.masks, ev.depth, tolerance_voxels * h)
        seconds["hollows"] = time.perf_counter() - t
    rims = None
    if contours:
        t = time.perf_counter()
        f = scene.frame
        rims = find_rims(ev.cameras, scene.masks, ev.grid, ev.occupied, f.center, f.radius, min_length * size,
                         tolerance_voxels * h)
        seconds["contours"] = time.perf_counter() - t
    if rims is not None and tubes:  # the views' traces along a handle too
        along = in_tubes(list(bezier_points(rims.controls, np.linspace(0, 1, 8))), tubes)
        rims = Rims(rims.controls[~along], rims.normals[~along], rims.view[~along])
    return Traces(ev, controls, shares, rims, boundaries, len(ridges.points), len(polys), seconds, texture, steps,
                  rings, tubes, side_cubics)


def find_candidates(scene: Scene, max_voxels: int = 192, threshold: float = 0.15, min_length: float = 0.03,
                    tolerance_voxels: float = TOLERANCE_VOXELS, max_views: int = 48, contours: bool = True,
                    outline_reach: int | None = None, texture: bool = True, hull_outline: bool = False,
                    log: Callable[[str], None] = lambda m: None, traces: Traces | None = None,
                    carving: tuple[VoxelGrid, np.ndarray] | None = None, hollows: bool = True) -> Candidates:
    """Evidence, ridges, polylines and candidate cubics of a posed, masked scene, with their coverage.

    Args:
        scene: images and masks at the evidence resolution (a voxel should project to about a pixel).
        max_voxels: evidence grid voxels along the object's longest side.
        threshold: minimum (smoothed) evidence of a ridge point.
        min_length: polylines shorter than this share of the object's size (its hull box diagonal) are
            dropped: in a sketch they read as ticks and dots.
        tolerance_voxels: 3D fitting tolerance of the cubics.
        max_views: views used to choose strokes (evenly spread).
        contours: also offer every view's contour curves (:mod:`.rims`), the outline of smooth parts.
        outline_reach: how near (px) a stroke must pass an outline pixel to explain it (lines inside: 1 px);
            ``None``: :data:`AUTOMATIC_OUTLINE_REACH` for automatic masks (``scene.masks_automatic``), else 1.
        texture: mark the feature candidates that lie on smooth faces of the hull (``Candidates.smooth``),
            which the choice then takes only for the outline they draw: printed lines are not structure.
        hull_outline: the hull's outline is drawn (:mod:`doodle.exporters.outline`), in every view: contour
            curves are offered only as view-independent curves (where the outline runs along a crease), judged
            by the texture rule too, and the candidates on smooth faces, which the choice would take only for
            the outline they draw, are not taken at all (:attr:`Candidates.hull_outline`).
        traces: what :func:`trace_candidates` made of this scene with these arguments, to offer again
            (``None``: traced here).
        carving: the visual hull ``(grid, occupied)`` carved from this scene with ``max_voxels`` (``None``:
            carved here).
        hollows: with ``texture``, also find the hollows (:mod:`.hollows`); only a choice of features draws them.
    """
    if outline_reach is None:
        outline_reach = AUTOMATIC_OUTLINE_REACH if scene.masks_automatic else 1
    reused = traces is not None
    if traces is None:
        traces = trace_candidates(scene, max_voxels, threshold, min_length, tolerance_voxels, contours, texture,
                                  carving, hollows)
    ev, controls, smooth, rims = traces.evidence, traces.controls, traces.smooth, traces.rims
    seconds = dict(traces.seconds)
    gates, normals, source = np.zeros(len(controls)), np.zeros((len(controls), 2, 3)), np.full(len(controls), -1)
    n_rims = k = 0
    if rims is not None:
        offered = (() if hull_outline else CONTOUR_GATES) + ((0.0,) if RIM_FEATURES else ())
        k = len(offered)  # each contour curve is offered once with every gate
        n_rims = len(rims.controls) * k
        controls = np.concatenate([controls, np.tile(rims.controls, (k, 1, 1))])
        gates = np.r_[gates, np.repeat(offered, len(rims.controls))]
        normals = np.concatenate([normals, np.tile(rims.normals, (k, 1, 1))])
        source = np.r_[source, np.tile(rims.view, k)]
        if smooth is not None:  # contour curves are the outline's own traces: judged only beside the hull's
            smooth = np.r_[smooth, np.tile(on_smooth_faces(rims.controls, ev.grid, ev.occupied) if hull_outline
                                           else np.zeros(len(rims.controls), bool), k)]
    t = time.perf_counter()
    views = list(spread_indices(len(ev.cameras), max_views))
    total = int(sum(ev.lines[v].sum() for v in views))
    outlines = {v: traces.boundaries[v] for v in views}
    covers, off, _ = stroke_coverage(controls, ev, views, gates=gates, contour_normals=normals, source=source,
                                     outlines=outlines, outline_reach=outline_reach) \
        if len(controls) else ([], np.zeros(0), None)
    offsets = np.cumsum([0] + [ev.lines[v].size for v in views])
    rim = np.concatenate([np.flatnonzero(outlines[v]) + o for v, o in zip(views, offsets)])
    seconds["coverage"] = time.perf_counter() - t
    timing = ("traced once, offered again" if reused else
              f"evidence {seconds['evidence']:.1f} s, curves {seconds['curves']:.1f} s, sight lines "
              f"{seconds['sight lines']:.1f} s" + (f", contours {seconds['contours']:.1f} s" if rims is not None else "")
              + (f", hollows {seconds['hollows']:.1f} s" if "hollows" in seconds else ""))
    free = ev.free
    log(f"discovery: {traces.ridge_points} ridge points → {traces.polylines} polylines → {len(controls) - n_rims} "
        f"candidate cubics" + (f" + {n_rims // k} contour cubics (each offered {k} way{'s' * (k > 1)})" if k else "")
        + (f"; {int(smooth.sum())} of the {len(controls)} on smooth faces: "
           + ("not taken, the hull draws their outline" if hull_outline else "outline only") if smooth is not None else "")
        + (f"; {len(traces.hollows)} hollow{'s' * (len(traces.hollows) != 1)} seen dark" if traces.hollows else "")
        + (f"; {len(traces.tubes)} curved thin part{'s' * (len(traces.tubes) != 1)} (a handle) offered as two "
           "sides" if traces.tubes else "")
        + f" ({timing})"
        + (f"; the views see through {free.sum() / max(ev.occupied.sum(), 1):.0%} of the hull"
           if free is not None and free.any() else ""))
    return Candidates(controls, covers, off, total, views, rim, ev, traces.ridge_points, traces.polylines, seconds,
                      gates, normals, source, smooth, hull_outline, traces)


def choose_curves(cand: Candidates, max_curves: int = 96, min_gain: float = 0.0005, taken: np.ndarray | None = None,
                  polish: bool = True, outline_curves: int = 0, outline_always: bool = False,
                  whole_outline: float = 0.0, most_outline: int = 0, features: int = 0, open_features: bool = False,
                  min_salience: float = MIN_SALIENCE, over=None, occluder=None,
                  occlusion_margin: float = 0.0,
                  log: Callable[[str], None] = lambda m: None) -> Discovery:
    """Choose among the candidates (greedy marginal coverage, see :func:`select_strokes`), polish the chosen
    cubics on the evidence and snap their meeting ends (``polish``), and read their face normals off the hull.

    Args:
        min_gain: a stroke is chosen while its marginal gain (newly explained line pixels minus half its
            off-line ink) is at least this share of all line pixels (over the selection views).
        taken: line pixels already drawn (global ids, e.g. superquadric outlines): curves go elsewhere.
        outline_curves: when ``max_curves`` are chosen and strokes still gain (an object with more lines than
            the budget holds: Lego's studs, plates and lattice), when those chosen (with ``taken``) draw less
            than :data:`OUTLINE_OPEN` of the outline pixels, or always with ``outline_always`` (the ``high``
            level's), up to this many more are chosen for the
            outline alone, each while it newly explains :data:`OUTLINE_MIN_GAIN` of the outline pixels (its
            off-line ink counting against it as before): the outline is what makes an object recognisable,
            and the strokes that complete it are the exact ones (contour curves, edges along the silhouette),
            so the sketch is drawn whole without busier insides. On the Lego photos (automatic masks) the
            128 + 128 raised the true outline drawn from 0.750 to 0.822 at line precision 0.867 → 0.870
            (discovery alone, all 94 photos; the whole fit: 0.815 / 0.879, and 0.815 on 12 photos held out).
        whole_outline: when the strokes chosen (with ``taken``) still explain less than this share of the
            outline pixels, outline strokes go on past ``outline_curves``, up to ``most_outline`` in all: an
            object the superquadrics cannot abstract (Lego) is drawn whole, in a larger file.
        features: then up to this many features on smooth faces (eyes, a muzzle, patches, buttons), chosen by
            salience (:mod:`.salience`) down to ``min_salience``, not by pixels: closed ones only, or with
            ``open_features`` open marks
            too.
        over, occluder: the superquadrics (a :class:`~doodle.strokes.model.SuperquadricSet`) and the occluder
            (:class:`~doodle.strokes.model.Voxels`) the drawing hides behind, from behind which the hollows'
            rings are moved (:func:`.hollows.clear_of`, with the drawing's ``occlusion_margin``); ``None``: none.
    """
    t = time.perf_counter()
    ev = cand.evidence
    h = ev.grid.voxel
    if len(cand.controls):
        weight = np.where(cand.gates > 0, CONTOUR_WEIGHT, 1.0) if len(cand.gates) else None
        if cand.hull_outline and cand.smooth is not None:
            weight = (1.0 if weight is None else weight) * ~cand.smooth
        pixel_weight = None
        if OUTLINE_WEIGHT != 1.0 and len(cand.rim):
            pixel_weight = np.ones(int(cand.rim.max()) + 1)
            pixel_weight[cand.rim] = OUTLINE_WEIGHT
        chosen, gains = select_strokes(cand.covers, cand.off, max_curves, min_gain * cand.total, taken=taken,
                                       weight=weight, pixel_weight=pixel_weight, smooth=cand.smooth, outline=cand.rim)
        n_outline = 0  # chosen for the outline alone
        if outline_curves > 0 and len(cand.rim):
            def drawn_share(strokes: list[int]) -> float:
                drawn = [cand.covers[k] for k in strokes] + ([taken] if taken is not None else [])
                return float(np.isin(cand.rim, np.concatenate(drawn)).mean()) if drawn else 0.0

            def for_outline(budget: int) -> tuple[list[int], list[float]]:
                return complete_outline(cand.covers, cand.off, chosen, cand.rim,
                                        sum(ev.lines[v].size for v in cand.views), budget,
                                        OUTLINE_MIN_GAIN * len(cand.rim), taken, weight)

            if len(chosen) == max_curves or outline_always or drawn_share(chosen) < OUTLINE_OPEN:
                more, more_gains = for_outline(outline_curves)
                chosen, gains = chosen + more, gains + more_gains
                n_outline = len(more)
                if whole_outline > 0 and most_outline > len(more) and drawn_share(chosen) < whole_outline:
                    extra, extra_gains = for_outline(most_outline - len(more))  # go on past the budget
                    chosen, gains = chosen + extra, gains + extra_gains
                    outline_curves += len(extra)
                    n_outline += len(extra)
        # a handle is drawn whole, both its sides, as a person draws it, once any piece of them is chosen (the
        # pieces at its ends, where it meets the body, explain little the body's outline does not; on a hull
        # carved from automatic masks the inner side, a pixel or two off, explained too little on its own)
        for tube in cand.traces.side_cubics if cand.traces is not None else []:
            if np.isin(tube, chosen).any():
                more = [int(k) for k in tube if k not in chosen]
                chosen, gains = chosen + more, gains + [0.0] * len(more)
    else:
        chosen, gains, n_outline = [], [], 0
    painted: list = []
    drawings: list[np.ndarray] = []
    painted_controls = np.zeros((0, 4, 3))
    if features > 0 and cand.traces is not None and cand.traces.shares is not None and (
            cand.smooth.any() or cand.traces.hollows):
        painted = _salient(cand, chosen, features, open_features, over, occluder, occlusion_margin, min_salience)
        if painted:
            drawings = [feature_cubics(f, cand.controls, TOLERANCE_VOXELS * h) for f in painted]
            painted_controls = np.concatenate(drawings)
            same = duplicates(cand.controls[chosen], painted, 2.0 * h)
            chosen = [k for k, dup in zip(chosen, same) if not dup]  # drawn by a feature
    n_painted = len(painted_controls)
    drawn_by = chosen + [int(k) for f in painted for k in f.members]
    explained = np.unique(np.concatenate([cand.covers[k] for k in drawn_by])) if drawn_by else np.zeros(0, np.int64)
    outline = float(np.isin(cand.rim, explained).mean()) if len(cand.rim) else 0.0
    drawn_all = explained if taken is None else np.concatenate([explained, taken])
    outline_drawn = float(np.isin(cand.rim, drawn_all).mean()) if len(cand.rim) else 0.0
    chosen = np.asarray(chosen, int)
    is_contour = cand.gates[chosen] > 0 if len(cand.gates) else np.zeros(len(chosen), bool)
    controls = cand.controls[chosen[~is_contour]]
    bridged = 0
    if polish and len(controls):
        controls = refine_on_evidence(controls, ev)
        size = h * float(np.linalg.norm(ev.grid.shape))
        bridges = bridge_gaps(controls, ev, 0.05 * size, 0.5 * BRIDGE_EVIDENCE)
        bridged = len(bridges)
        budget = max_curves + (outline_curves if n_outline else 0) - int(is_contour.sum())
        controls = join_strokes(np.concatenate([controls, bridges]), h, TOLERANCE_VOXELS * h)[:budget]
        controls = snap_ends(drop_stray(controls, STRAY_LENGTH * size, 2.0 * h), 2.0 * h)
    # features are drawn as traced, rings closed: the polish moves each cubic alone, which opens a small ring
    # (an eye's, 3 voxels across, came apart), and joining would chain it to the lines beside it
    controls = np.concatenate([controls, painted_controls])
    normals = curve_normals(controls, ev.grid, ev.occupied, ev.cameras, ev.depth, ev.margin)
    # a hollow's ring faces the views that looked into it (the hull's normals at the surface bridging it are
    # the bridge's)
    at = len(controls) - len(painted_controls)
    for f, d in zip(painted, drawings):
        if f.hollow is not None:
            normals[at:at + len(d)] = f.hollow.facing
        at += len(d)
    # contour curves keep their place and their surface normal (both "faces" are the one smooth surface)
    rims = chosen[is_contour]
    controls = np.concatenate([controls, cand.controls[rims]])
    normals = np.concatenate([normals, np.repeat(cand.contour_normals[rims][:, :, None], 2, axis=2)])
    contour = np.r_[np.zeros(len(controls) - len(rims)), cand.gates[rims]]
    source = np.r_[np.full(len(controls) - len(rims), -1), cand.source[rims]].astype(int)
    seconds = {**cand.seconds, "choice": time.perf_counter() - t}
    coverage = len(explained) / max(cand.total, 1)
    log(f"discovery: {len(chosen)} of {len(cand.controls)} candidate cubics chosen ({len(rims)} contour"
        + (f"; {n_outline} for the outline alone" if n_outline else "")
        + (f"; {len(painted)} features by salience ({n_painted} cubics)" if painted else "") + "), explaining "
        f"{coverage:.0%} of the line pixels and {outline:.0%} of the outlines"
        + (f" ({outline_drawn:.0%} with the superquadrics')" if taken is not None else "") + (
            f"; {bridged} gaps bridged, {len(controls)} cubics after joining" if polish else ""))
    return Discovery(controls, normals, len(cand.controls), cand.polylines, coverage, outline, gains, h, seconds,
                     contour, source, outline_drawn)


def _salient(cand: Candidates, chosen: list[int], budget: int, open_features: bool, over=None, occluder=None,
             occlusion_margin: float = 0.0, min_salience: float = MIN_SALIENCE) -> list:
    """Up to ``budget`` features among the traced cubics wholly on smooth faces and not ``chosen`` and the
    hollows' rings, by salience (closed ones only unless ``open_features``). Contour curves are never features:
    they are the outline's. A hollow's ring is moved out from behind the superquadrics ``over`` and the
    ``occluder`` first, or left out when no view would see it (:func:`.hollows.clear_of`)."""
    ev, traces = cand.evidence, cand.traces
    # wholly on a smooth face, as paint is: a ring round a leg's top, half on a crease, is a junction of parts
    is_feature = traces.shares >= PAINT_SHARE
    is_feature[[k for k in chosen if k < len(is_feature)]] = False  # the traced cubics come first
    scored = score_features(cand.controls, np.flatnonzero(is_feature), cand.controls[chosen], ev.score, ev.grid,
                            ev.occupied, steps=traces.steps, hollows=traces.hollows)
    if over is not None or occluder is not None:
        from ...strokes.model import SuperquadricSet

        over = SuperquadricSet() if over is None else over
        size = ev.grid.voxel * float(np.linalg.norm(ev.grid.shape))
        seen = []
        for f in scored:
            if f.hollow is not None:
                moved = clear_of(f.cubics, f.hollow.facing, over, ev.cameras, CLEAR_REACH * size, ev.grid.voxel,
                                 occlusion_margin, occluder)
                if moved is None:
                    continue
                f.points, f.cubics = f.points + (moved[0, 0] - f.cubics[0, 0]), moved
            seen.append(f)
        scored = seen
    return choose_features(scored, budget, 2.0 * ev.grid.voxel, open_features, min_salience)


def outline_pixel_ids(cand: Candidates, sq, frame, reach: int = 1, occluder=None, hull=None) -> np.ndarray:
    """Line pixels (global ids over the selection views) that the superquadrics' visible outline and the
    ``hull``'s outline draw, within ``reach`` pixels: a smooth part's outline is only as exact as its
    superquadric, and lines beside it are the same outline, not a place for curves (which would read as ticks
    along the rim)."""
    from ...exporters.drawing import DrawOptions, draw_many
    from ...strokes.model import CurveSet, StrokeSet

    cams = [cand.evidence.cameras[v] for v in cand.views]
    drawings = draw_many(StrokeSet(frame, CurveSet(), sq, occluder=occluder, hull=hull), cams,
                         DrawOptions(curves=False, hidden="hide", tolerance=0.5, min_mark=0.0))
    pixels = [np.concatenate([op.points() for op in d.layer("silhouettes")] or [np.zeros((0, 2))]) for d in drawings]
    return cand.pixel_ids(pixels, reach)
