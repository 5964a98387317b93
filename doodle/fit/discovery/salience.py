"""Salient features: the lines inside the outline a person draws first — eyes, a muzzle, buttons, patches.

The structural choice (:func:`.discover.select_strokes`) ranks strokes by the line pixels they newly explain,
and a stroke on a smooth face of the object (:mod:`.texture`: paint, not structure) counts there only for the
outline it draws. Ranked by pixels, paint would bring the longest patch edge first and two small eyes never.
Here the candidates on smooth faces are grouped into **features** (cubics that meet end to end) and ranked by
what they tell a viewer:

- **contrast**: the evidence along the feature, how surely every view sees it as a line, and the step in
  the images across it (:func:`albedo_steps`): paint is a step in reflectance, the same ratio of
  brightness on both sides whatever the light; a shading terminator, which also stays put on the surface
  under a fixed light, is a slope;
- **closure**: a closed boundary (an eye, a button, a nostril) reads as a thing, an open one as a mark;
- **size** relative to the object: a small, compact feature says more per stroke than a long edge;
- **isolation**: a feature on a part with no other line (a face) tells more than one beside drawn lines;
- **symmetry**: a feature whose mirror image across a plane the object is symmetric about is also a feature
  (two eyes, two buttons) is one of a pair a viewer expects.

:func:`choose_features` takes rings first, the most salient first, each only while at least half of it lies
away from the features taken, up to the detail level's budget (``DetailLevel.features``): ``low`` draws the
few most salient rings, ``medium`` open marks (seams) after them, ``high`` up to 24.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from ...strokes.bezier import bezier_points
from ...strokes.fitcurve import fit_cubics_many

#: The size (share of the object's box diagonal) at which a feature's size halves its salience, which falls
#: with the square of the size beyond: an eye on a toy (0.05) keeps 0.6, a patch (0.15) 0.14, an edge across
#: the whole object (0.4) 0.02. Linear falloff (1 / (1 + s / 0.1)) ranked the calf's patches, of a better
#: contrast and closure, above its second eye.
SIZE_HALF = 0.06
#: The distance (share of the object's size) from the strokes already drawn beyond which a feature is alone
#: on its part.
ISOLATION_REACH = 0.08
#: A feature's mirror partner lifts it by this factor when the hull is symmetric about their bisecting plane.
PAIR_BONUS = 1.3
#: The share of the hull's surface samples whose mirror image lies on its surface for a plane to be one the
#: object is symmetric about.
SYMMETRIC = 0.9
#: What an open feature (a mark, or a piece of a boundary the tracing broke) counts against a closed one.
OPEN_WEIGHT = 0.35
#: Pieces of one boundary are grouped into a feature when their ends lie within this many voxels: the
#: tracing breaks a small boundary where the evidence dips.
GROUP_VOXELS = 2.5
#: The step in log brightness across a feature (:func:`albedo_steps`) at which it counts fully, and under
#: which it is not paint at all: ink at 0.3 of the surface's brightness is a step of 1.2 (the calf's eyes
#: and patches measured 0.75–1.14).
STEP_FULL = 0.5
MIN_STEP = 0.15
#: Across a step edge the brightness differs as much at twice the offset as at the offset; across a ramp
#: (shading) twice as much. A sample whose difference at the offset is under this share of that at twice it
#: counts no step. The plain teapot's glaze gave three rings of steps 0.3–1.3 before this test and the
#: outline's (one side the background) — shading where a light's clamp meets its cosine, fixed on the
#: surface — which as features cost it 0.011 of line precision; after it, none.
RAMP = 0.75
#: What a line darker than both its sides (:func:`albedo_steps`) counts as a step.
LINE_WEIGHT = 1.0
#: A feature going this far round (:func:`closure`) is drawn as a closed loop (:func:`feature_cubics`).
CLOSE_LOOP = 0.6
#: A feature is taken only while at least this share of it is not drawn yet (see :func:`choose_features`).
MIN_NOVELTY = 0.5
#: Two rings cross (neither holds the other, and they are not apart) when their centres lie farther apart than
#: the difference of their radii plus this share of the smaller radius, and nearer than the sum of their radii
#: less this share of it (see :func:`crossing`).
CROSS_MARGIN = 0.1
#: Least salience of a feature: a patch as large as a third of the object is not drawn.
MIN_SALIENCE = 0.01
#: Least contrast (mean evidence: the share of the views that see it as a line) of a feature. Paint stays
#: on the surface, so every view that sees it agrees (the calf's eyes 0.45–0.64, its patches 0.65–0.69);
#: what the plain cow left on smooth faces (the hull's facets, shading) agrees less (a ring of 0.27 on its
#: flank cost line precision 0.946 → 0.918).
MIN_CONTRAST = 0.35
_SAMPLES = 12


@dataclass
class Feature:
    """One candidate feature: its cubics (indices into the candidates) and what its salience is made of."""

    members: np.ndarray
    contrast: float
    closed: float
    """How much of a loop it goes round (:func:`closure`, 0 to 1)."""
    size: float
    """Its extent (box diagonal) over the object's."""
    isolation: float
    points: np.ndarray
    """``(P, 3)`` samples along its cubics."""
    paired: bool = False
    step: float = STEP_FULL
    """The step in log brightness across it (:func:`albedo_steps`; a hollow's: how much darker it is)."""
    cubics: np.ndarray | None = None
    """``(K, 4, 3)`` its own drawing (a hollow's ring, :mod:`.hollows`); ``None``: drawn from its members."""
    hollow: "Hollow | None" = None
    """The hollow (:mod:`.hollows`) whose ring this is; ``None``: a feature of traced cubics."""

    @property
    def salience(self) -> float:
        return (min(self.step / STEP_FULL, 1.0) * self.contrast * (OPEN_WEIGHT + (1 - OPEN_WEIGHT) * self.closed)
                / (1.0 + (self.size / SIZE_HALF) ** 2)
                * (0.5 + 0.5 * self.isolation) * (PAIR_BONUS if self.paired else 1.0))


def group_features(controls: np.ndarray, members: np.ndarray, touch: float) -> list[np.ndarray]:
    """The cubics ``members`` (indices into ``controls (N, 4, 3)``) grouped into chains whose ends meet within
    ``touch``: the pieces of one traced boundary."""
    if not len(members):
        return []
    ends = np.concatenate([controls[members, 0], controls[members, 3]])
    n = len(members)
    pairs = cKDTree(ends).query_pairs(touch, output_type="ndarray")
    a, b = (pairs[:, 0] % n, pairs[:, 1] % n) if len(pairs) else (np.zeros(0, int), np.zeros(0, int))
    graph = coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    return [members[label == k] for k in range(label.max() + 1)]


def _about_circle(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The samples ``(P, 3)`` about the circle that fits them best in their best-fitting plane: ``(angles (P,),
    radii (P,), offsets off the plane (P,))`` and the frame ``(4, 3)`` (the circle's centre, the plane's two
    axes and its normal). Kåsa's least squares (x² + y² + D x + E y + F = 0): for an arc the centre is its
    circle's, not the centroid (which lies inside its chord and sees it go three quarters round); a straight
    mark's circle is far away and sees it in a sector or two."""
    mean = points.mean(0)
    c = points - mean
    _, _, vt = np.linalg.svd(c, full_matrices=False)
    uvw = c @ vt.T
    A = np.c_[uvw[:, :2], np.ones(len(uvw))]
    (d, e, _), *_ = np.linalg.lstsq(A, -(uvw[:, :2] ** 2).sum(1), rcond=None)
    centre = -0.5 * np.array([d, e])
    rel = uvw[:, :2] - centre
    frame = np.stack([mean + centre @ vt[:2], vt[0], vt[1], vt[2]])
    return np.arctan2(rel[:, 1], rel[:, 0]), np.linalg.norm(rel, axis=1), uvw[:, 2], frame


def closure(points: np.ndarray, bins: int = 24) -> float:
    """How much of a loop the samples ``(P, 3)`` of a feature go round: the share of directions about their
    best-fitting circle's centre (:func:`_about_circle`) that they cover (``bins`` sectors). A traced circle
    gives 1, a small eye whose far side the evidence left out about 0.8, a semicircle 0.5, a straight mark
    under 0.15. No gap threshold: a loop broken into pieces is as closed as one traced whole."""
    if len(points) < 3:
        return 0.0
    angle, radius, _, _ = _about_circle(points)
    away = radius >= 0.25 * np.median(radius)  # samples at the centre have no direction
    sector = ((angle[away] + np.pi) / (2 * np.pi) * bins).astype(int) % bins
    return len(np.unique(sector)) / bins


def symmetry_planes(occupied: np.ndarray, grid, rng: np.random.Generator, samples: int = 4000
                    ) -> list[tuple[np.ndarray, np.ndarray]]:
    """The planes ``(point, unit normal)`` the hull ``occupied`` is mirror-symmetric about, among those through
    its centroid normal to its principal axes (a cow's, a mouse's, a face's plane of symmetry is one of them):
    at least :data:`SYMMETRIC` of its surface samples mirror onto its surface (within two voxels, as a voxel
    hull's stairs differ side to side; onto the surface, not into the volume: a cow's head mirrored to its
    tail lands inside its body)."""
    ijk = np.argwhere(occupied)
    if len(ijk) < 8:
        return []
    pts = grid.centres(ijk.astype(np.float64))
    centre = pts.mean(0)
    _, _, axes = np.linalg.svd(pts - centre, full_matrices=False)
    shell = occupied & ~ndimage.binary_erosion(occupied)
    boundary = np.argwhere(shell)
    if len(boundary) > samples:
        boundary = boundary[rng.choice(len(boundary), samples, replace=False)]
    surface = grid.centres(boundary.astype(np.float64))
    planes = []
    for n in axes:
        mirrored = surface - 2.0 * ((surface - centre) @ n)[:, None] * n
        q = np.round(grid.coordinates(mirrored)).astype(int)
        ok = ((q >= 0) & (q < np.array(occupied.shape))).all(1)
        on = np.zeros(len(q), bool)
        on[ok] = within_reach(shell, q[ok], 2)
        if on.mean() >= SYMMETRIC:
            planes.append((centre, n))
    return planes


def within_reach(mask: np.ndarray, at: np.ndarray, reach: int) -> np.ndarray:
    """``(K,)``: whether a voxel of ``mask`` ``(X, Y, Z)`` lies within ``reach`` voxels (Euclidean, centre to
    centre) of each voxel ``at`` ``(K, 3)``: ``distance_transform_edt(~mask)[at] <= reach``, read at the K voxels
    alone (the transform of a whole 192³ grid took 2 s of a DTU skull's fit)."""
    r = np.arange(-reach, reach + 1)
    offsets = np.stack(np.meshgrid(r, r, r, indexing="ij"), -1).reshape(-1, 3)
    offsets = offsets[(offsets**2).sum(1) <= reach**2]
    out = np.zeros(len(at), bool)
    shape = np.array(mask.shape)
    for o in offsets:
        q = at + o
        inside = ((q >= 0) & (q < shape)).all(1)
        out[inside] |= mask[tuple(q[inside].T)]
    return out


def _sides(field: np.ndarray, at: np.ndarray, across: np.ndarray, reach: float, order: int = 1
           ) -> tuple[np.ndarray, np.ndarray]:
    """``field`` ``(H, W)`` read at pixel positions ``at`` ``(P, 2)`` (x, y; pixel centres at .5) moved ``reach``
    px along ``across`` ``(P, 2)`` (unit) and against it."""
    def read(q: np.ndarray) -> np.ndarray:
        return ndimage.map_coordinates(field, [q[:, 1] - 0.5, q[:, 0] - 0.5], order=order, mode="nearest")

    return read(at + reach * across), read(at - reach * across)


def albedo_steps(controls: np.ndarray, cameras: list, images: list[np.ndarray], masks: list[np.ndarray],
                 depth: list[np.ndarray], margin: float, offset_px: float = 2.0, samples: int = 12) -> np.ndarray:
    """``(N,)`` for each cubic ``(N, 4, 3)``, the median over the views (``cameras`` with their ``images``,
    ``masks`` and the hull's ``depth`` maps, hidden beyond ``margin``) and its visible samples of the step in
    log brightness across it: ``|log I(x + o n) − log I(x − o n)|`` with ``n`` the projected curve's normal
    and ``o = offset_px``, where both sides are the object's (across the outline the step is the
    background's). Paint is a step in reflectance, the same whatever the light (ink at 0.3: 1.2); shading
    changes slowly across a few pixels (a terminator: under 0.1). ``0`` where no view sees the cubic."""
    if not len(controls):
        return np.zeros(0)
    t = np.linspace(0, 1, samples)
    pts = bezier_points(controls, t).reshape(-1, 3)
    owner = np.repeat(np.arange(len(controls)), samples)
    ahead = bezier_points(controls, np.clip(t + 0.02, 0, 1)).reshape(-1, 3)
    behind = bezier_points(controls, np.clip(t - 0.02, 0, 1)).reshape(-1, 3)
    steps: list[list[np.ndarray]] = [[] for _ in range(len(controls))]
    for cam, image, mask, deep in zip(cameras, images, masks, depth):
        gray = np.log(np.asarray(image, np.float32)[..., :3].mean(-1) / 255.0 + 0.02)
        H, W = gray.shape
        uv, z = cam.project(pts)
        a, _ = cam.project(ahead)
        b, _ = cam.project(behind)
        tangent = a - b
        normal = np.stack([-tangent[:, 1], tangent[:, 0]], 1)
        normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-9)
        inside = (z > 1e-6) & (uv[:, 0] >= 3) & (uv[:, 1] >= 3) & (uv[:, 0] < W - 3) & (uv[:, 1] < H - 3)
        ui, vi = np.clip(uv[:, 0].astype(int), 0, W - 1), np.clip(uv[:, 1].astype(int), 0, H - 1)
        seen = inside & (z <= deep[vi, ui] + margin)
        if not seen.any():
            continue
        at, across = uv[seen], normal[seen]
        # both sides on the object, a pixel beyond the offset too (the outline's antialiasing)
        ahead_in, behind_in = _sides(mask.astype(np.float32), at, across, offset_px + 1, order=0)
        on = (ahead_in > 0.5) & (behind_in > 0.5)
        near_a, near_b = _sides(gray, at, across, offset_px)
        far_a, far_b = _sides(gray, at, across, 2 * offset_px)
        step, wide = np.abs(near_a - near_b)[on], np.abs(far_a - far_b)[on]
        # a step is as high two offsets out as one; a slope (shading) twice as high: count a step's height only
        step = np.where(step >= RAMP * wide, step, 0.0)
        # a line (a seam, a painted stroke, the gap between two teeth) is darker than both its sides, which are
        # alike: its darkest pixel within a pixel of the curve against the lighter side's, when as dark two
        # offsets out (a broad trough of shading is darker still farther out)
        centre = np.min([side for d in (0.0, 0.5, 1.0) for side in _sides(gray, at, across, d)], 0)[on]
        line = np.minimum(near_a, near_b)[on] - centre
        line_wide = np.minimum(far_a, far_b)[on] - centre
        line = np.where((line > 0) & (line >= RAMP * line_wide), line, 0.0)
        step = np.maximum(step, LINE_WEIGHT * line)
        who = owner[seen][on]
        for k in np.unique(who):
            steps[k].append(step[who == k])
    return np.array([float(np.median(np.concatenate(s))) if s else 0.0 for s in steps])


def score_features(controls: np.ndarray, members: np.ndarray, drawn: np.ndarray, score: np.ndarray, grid,
                   occupied: np.ndarray, rng: np.random.Generator | None = None,
                   steps: np.ndarray | None = None, hollows: list | None = None) -> list[Feature]:
    """Group the cubics ``members`` into features, add the ``hollows``' rings (:mod:`.hollows`) and score each
    (see the module docstring). A hollow's contrast is the share of the views that see it dark, its step how
    much darker it is.

    Args:
        controls: ``(N, 4, 3)`` candidate cubics.
        members: indices of the candidates that may be features (on smooth faces).
        drawn: ``(D, 4, 3)`` the cubics already chosen, for isolation.
        score: the evidence ``(X, Y, Z)`` on ``grid``; ``occupied`` the carved hull, for symmetry.
        steps: ``(N,)`` each candidate's step in the images (:func:`albedo_steps`; ``None``: not measured).
    """
    h = grid.voxel
    size = h * float(np.linalg.norm(occupied.shape))
    touch = GROUP_VOXELS * h
    groups = group_features(controls, members, touch)
    hollows = hollows or []
    if not groups and not hollows:
        return []
    smooth = ndimage.gaussian_filter(score.astype(np.float32), 0.7)
    near = cKDTree(bezier_points(drawn, np.linspace(0, 1, _SAMPLES)).reshape(-1, 3)) if len(drawn) else None

    def shape(pts: np.ndarray) -> tuple[float, float, float]:
        """Closure, size (share of the object's) and isolation of a feature's samples."""
        extent = float(np.linalg.norm(pts.max(0) - pts.min(0)))
        iso = 1.0 if near is None else float(np.clip(near.query(pts)[0].mean() / (ISOLATION_REACH * size), 0, 1))
        return closure(pts), extent / size, iso

    out = []
    for g in groups:
        pts = bezier_points(controls[g], np.linspace(0, 1, _SAMPLES)).reshape(-1, 3)
        contrast = float(ndimage.map_coordinates(smooth, grid.coordinates(pts).T, order=1, cval=0.0).mean())
        step = STEP_FULL if steps is None else float(np.mean(steps[g]))
        out.append(Feature(g, contrast, *shape(pts), pts, step=step))
    for hollow in hollows:
        out.append(Feature(np.zeros(0, int), hollow.share, *shape(hollow.points), hollow.points,
                           step=hollow.darkness, cubics=hollow.cubics, hollow=hollow))
    _pair_up(out, size, grid, occupied, rng or np.random.default_rng(0))
    return out


def _pair_up(features: list[Feature], size: float, grid, occupied: np.ndarray, rng: np.random.Generator) -> None:
    """Mark the features that have a mirror partner: the mirror image of its centre across a plane the hull is
    symmetric about (:func:`symmetry_planes`) lies within half its extent of another feature's centre, and the
    two are of a similar size (not closure: the tracing may leave one of two eyes open). ``size``: the object's
    size, which the features' sizes are shares of."""
    if len(features) < 2:
        return
    planes = symmetry_planes(occupied, grid, rng)
    if not planes:
        return
    centres = np.array([f.points.mean(0) for f in features])
    extent = np.array([f.size for f in features]) * size
    tree = cKDTree(centres)
    for point, n in planes:
        mirrored = centres - 2.0 * ((centres - point) @ n)[:, None] * n
        for a, m in enumerate(mirrored):
            if np.linalg.norm(m - centres[a]) <= extent[a]:  # on the plane: its own mirror image
                continue
            for b in tree.query_ball_point(m, 0.5 * extent[a]):
                if b != a and max(extent[a], extent[b]) <= 1.5 * min(extent[a], extent[b]):
                    features[a].paired = features[b].paired = True


def choose_features(features: list[Feature], budget: int, reach: float, open_features: bool = True,
                    min_salience: float = MIN_SALIENCE) -> list[Feature]:
    """The most salient ``features`` first, up to ``budget``, down to ``min_salience``, of at least
    :data:`MIN_CONTRAST` and :data:`MIN_STEP`, each while at
    least :data:`MIN_NOVELTY` of its samples lie farther than ``reach`` from the features taken before it.
    Rings (going round at least :data:`CLOSE_LOOP`) come first, none crossing a ring taken before it
    (:func:`crossing`); open marks only with ``open_features`` and after every ring (on an object without
    paint, the open marks left on smooth faces are shading and fragments, and cost precision; on a painted one
    they are the secondary lines).
    Structural curves do not bar a feature: where one runs along it (a rough trace of an eye taken for the
    pixels it explains), the feature is the better drawing and the curve gives way (:func:`duplicates`)."""
    if budget <= 0 or not features:
        return []
    taken: list[Feature] = []
    near = None  # the samples of the features taken
    rings = [f for f in features if f.closed >= CLOSE_LOOP]
    marks = [f for f in features if f.closed < CLOSE_LOOP] if open_features else []
    for f in sorted(rings, key=lambda f: -f.salience) + sorted(marks, key=lambda f: -f.salience):
        if len(taken) >= budget:
            break
        if f.salience < min_salience or f.contrast < MIN_CONTRAST or f.step < MIN_STEP:
            continue
        if near is not None and (near.query(f.points)[0] > reach).mean() < MIN_NOVELTY:
            continue
        if f.closed >= CLOSE_LOOP and any(crossing(f, t) for t in taken if t.closed >= CLOSE_LOOP):
            continue
        taken.append(f)
        near = cKDTree(np.concatenate([t.points for t in taken]))
    return taken


def crossing(a: Feature, b: Feature) -> bool:
    """Whether rings ``a`` and ``b`` cross: neither holds the other (a pupil in an eye, a button in its well
    are drawn both) and they are not apart. Crossing rings read as a scribble, not as two marks: the dark
    squares of a checkered ball, seen in noisy photos as overlapping dark regions, gave rings through one
    another. Each ring is taken as a circle: its samples' centroid and mean distance from it."""
    ca, cb = a.points.mean(0), b.points.mean(0)
    ra = float(np.linalg.norm(a.points - ca, axis=1).mean())
    rb = float(np.linalg.norm(b.points - cb, axis=1).mean())
    d = float(np.linalg.norm(ca - cb))
    return abs(ra - rb) + CROSS_MARGIN * min(ra, rb) < d < (1.0 - CROSS_MARGIN) * (ra + rb)


def duplicates(controls: np.ndarray, features: list[Feature], reach: float, share: float = 0.6) -> np.ndarray:
    """``(N,)`` bool: the cubics ``(N, 4, 3)`` with at least ``share`` of their samples within ``reach`` of the
    ``features``' (the same line, drawn by the feature)."""
    if not len(controls) or not features:
        return np.zeros(len(controls), bool)
    tree = cKDTree(np.concatenate([f.points for f in features]))
    pts = bezier_points(controls, np.linspace(0, 1, _SAMPLES))
    d = tree.query(pts.reshape(-1, 3))[0].reshape(len(controls), -1)
    return (d <= reach).mean(axis=1) >= share


def feature_cubics(feature: Feature, controls: np.ndarray, tolerance: float, samples: int = 48) -> np.ndarray:
    """The cubics ``(K, 4, 3)`` that draw ``feature``: for one going round at least :data:`CLOSE_LOOP`, a ring
    through its samples about their circle (:func:`_about_circle`; radius and height off the plane
    interpolated round the angle, so a gap the evidence left is closed along the feature's own curve, not by a
    chord), smoothed and fitted as one closed chain within ``tolerance``; otherwise its traced cubics
    (``controls[feature.members]``). A hollow's ring is its own (``feature.cubics``)."""
    if feature.cubics is not None:
        return feature.cubics
    if feature.closed < CLOSE_LOOP or len(feature.points) < 8:
        return controls[feature.members]
    angle, radius, height, (centre, u, v, n) = _about_circle(feature.points)
    order = np.argsort(angle)
    at = np.linspace(-np.pi, np.pi, samples, endpoint=False)
    r = np.interp(at, angle[order], radius[order], period=2 * np.pi)
    w = np.interp(at, angle[order], height[order], period=2 * np.pi)
    ring = centre + (r * np.cos(at))[:, None] * u + (r * np.sin(at))[:, None] * v + w[:, None] * n
    ring = ndimage.uniform_filter1d(ring, 3, axis=0, mode="wrap")
    return fit_cubics_many([ring], tolerance, [True])[0]
