"""Where the views see into the visual hull: free space along the sight lines of curves the images show.

The visual hull fills every concavity that no view looks into from outside its silhouettes: the space
above Lego's plate beside its tracks, where the tracks' lower edges lie 8 voxels inside the hull in every
view. The vote finds such edges anyway (its depth maps leak, see :func:`.evidence.depth_maps`), but the
hull then hides them from the choice of strokes and from the exported drawings, and the tracks are drawn
without their lower edges.

The images know better. A feature candidate that the hull hides in a view, yet whose projection lies on
that view's lines along nearly all of its length, is seen there: a whole curve does not fall onto a line
of the image by chance. So the sight lines from that view's eye to the curve are empty, and so are the
hull voxels on them. A candidate must be seen so in at least two views, and only voxels near the hull's
surface are cleared (no deeper than the vote's candidates lie), so one false match cannot tunnel through
the object. This is the visibility constraint of multi-view stereo, applied to the strokes' own evidence.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from ..volume.carve import project_points
from .evidence import Evidence, curve_samples

MIN_ON_LINES = 0.9
"""A hidden candidate is seen in a view when at least this share of its samples lies within a pixel of the
view's lines. On Lego's cached candidates, before :data:`MAX_EXPLAINED`: 0.8 cleared 28 % of the hull (held-out
F 0.823 → 0.824), 0.9 cleared 17 % (F 0.827) with the same tracks' lower edges drawn. The whole fit, with
every rule: 6 % cleared, F 0.825, the tracks' loops closed."""

MAX_EXPLAINED = 0.25
"""A hidden candidate is not seen in a view when more than this share of its samples lies within a pixel of
another candidate's visible samples: a thin plate's far rim runs a pixel from its near one all along (the
chair's seat: 20 % of its hull cleared without this rule, held-out F 0.891 → 0.885). A piece of the same edge
that touches it at an end is no objection (with no share allowed, Lego's clearing stopped)."""

MIN_VIEWS = 2
"""Views that must see a hidden candidate before its sight lines are cleared (3, on Lego's cached candidates
before :data:`MAX_EXPLAINED` and at 0.8 on the lines: 26 % cleared, F 0.825)."""


def seen_through(controls: np.ndarray, ev: Evidence, max_depth: int = 12, min_on: float = MIN_ON_LINES,
                 min_views: int = MIN_VIEWS, spacing_px: float = 0.7,
                 outlines: list[np.ndarray] | None = None) -> np.ndarray:
    """``bool`` like ``ev.occupied``: the hull voxels on the sight lines of the feature candidates ``controls``
    ``(N, 4, 3)`` that views see although the hull hides them (see the module docstring).

    A candidate is judged in a view when it lies wholly in the frame and the hull hides at least half of it
    (its samples more than ``ev.margin`` behind the hull's depth); it is seen there when ``min_on`` of its
    samples lie within one pixel (3 × 3) of the view's lines, not counting ``outlines`` (per view, the masks'
    boundaries, ``bool (H, W)``), and at most ``MAX_EXPLAINED`` of them within a pixel of another candidate's
    visible samples. ``max_depth``: voxels deeper than this under the hull's surface are never cleared.
    """
    free = np.zeros(ev.occupied.shape, bool)
    if len(controls) == 0:
        return free
    h = ev.grid.voxel
    P, _, owner, n_samples = curve_samples(controls, h, spacing_px)
    seen_in = np.zeros(len(controls), int)
    sightings = []  # (view, sample ids, their depths, their hull depths)
    for v, cam in enumerate(ev.cameras):
        lines = ev.lines[v]
        H, W = lines.shape
        u, w, z = project_points(cam, P)
        ok = (z > 1e-6) & (u >= 1) & (w >= 1) & (u < W - 1) & (w < H - 1)
        idx = np.flatnonzero(ok)
        zb = np.full(len(P), np.inf, np.float32)
        zb[idx] = ev.depth[v][w[idx], u[idx]]
        hidden = ok & (z > zb + ev.margin)
        if not hidden.any():
            continue
        # The lines a hidden curve may claim are those nothing else in sight explains: not the outline, and
        # mostly not within a pixel of another candidate's visible samples (a thin plate's far rim lies a
        # pixel from its near one). Which candidate is in sight at a pixel: one of them, the last written.
        shown_by = np.full((H, W), -1)
        shown = np.flatnonzero(ok & ~hidden)
        shown_by[w[shown], u[shown]] = owner[shown]
        open_lines = lines & ~outlines[v] if outlines is not None else lines
        on = np.zeros(len(P), bool)
        by_other = np.zeros(len(P), bool)
        for dy in (-1, 0, 1):  # the 3 × 3 neighbourhood (samples keep a pixel off the border)
            for dx in (-1, 0, 1):
                on[idx] |= open_lines[w[idx] + dy, u[idx] + dx]
                there = shown_by[w[idx] + dy, u[idx] + dx]
                by_other[idx] |= (there >= 0) & (there != owner[idx])
        count = lambda m: np.bincount(owner, m, len(controls))  # noqa: E731
        seen = (count(ok) >= 0.95 * n_samples) & (count(hidden) >= 0.5 * n_samples) & (count(on) >= min_on * n_samples) \
            & (count(by_other) <= MAX_EXPLAINED * n_samples)
        if seen.any():
            seen_in += seen
            rows = np.flatnonzero(seen[owner] & hidden)
            sightings.append((v, rows, z[rows], zb[rows]))
    believed = seen_in >= min_views
    if not believed.any():
        return free
    for v, rows, z, zb in sightings:
        keep = believed[owner[rows]]
        rows, z, zb = rows[keep], z[keep], zb[keep]
        if not len(rows):
            continue
        eye = ev.cameras[v].center.astype(np.float32)
        # the sight line from where it enters the hull to two voxels short of the curve, every half voxel
        span = np.maximum(z - 2 * h - (zb - h), 0.0)
        steps = np.ceil(span / (0.5 * h)).astype(int) + 1
        s = np.repeat(np.arange(len(rows)), steps)
        k = np.arange(len(s)) - np.repeat(np.cumsum(steps) - steps, steps)
        depth = (zb - h)[s] + np.minimum(k * 0.5 * h, span[s])
        pts = eye + (P[rows][s] - eye) * (depth / z[s])[:, None]
        ijk = ev.grid.index(pts)
        inside = np.all((ijk >= 0) & (ijk < np.array(free.shape)), axis=1)
        free[tuple(ijk[inside].T)] = True
    # how deep under the hull's surface: the distance to the nearest empty voxel beside the hull, asked of
    # the cleared voxels alone (the whole grid's distance transform took 0.5 s on Lego)
    ijk = np.argwhere(free & ev.occupied)
    shell = np.argwhere(ndimage.binary_dilation(ev.occupied) & ~ev.occupied)
    if not len(ijk) or not len(shell):
        return free & ev.occupied
    depth_in = cKDTree(shell).query(ijk)[0]
    out = np.zeros(free.shape, bool)
    out[tuple(ijk[depth_in <= max_depth].T)] = True
    return out
