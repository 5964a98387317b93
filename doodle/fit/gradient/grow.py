"""Superquadrics grown against the silhouettes, one move at a time: the gradient path's superquadric fit (with
``--outline hull``, and without discovery), where the compact default fits them to the volume in 3D instead
(:mod:`doodle.fit.volume.abstraction`)."""

from __future__ import annotations

from dataclasses import replace
from typing import Callable

import numpy as np
import torch

from ...scenes import Scene
from ...strokes.model import SceneFrame, SuperquadricSet
from .silhouettes import silhouette_scores
from .params import SuperquadricParams

FLAT_END = 0.3
"""ε₁ from which a superquadric is tried with flat ends (a cylinder's, a plate's) after it is grown."""


def grow_superquadrics(interior: np.ndarray, work: Scene, frame: SceneFrame, limit: int, iterations: int,
                       sq_stage: Callable[..., bool], device: torch.device, say: Callable[[str], None],
                       min_gain: float = 0.01, gen: torch.Generator | None = None) -> tuple[SuperquadricParams, bool]:
    """Fit as few superquadrics (at most ``limit``) as the silhouettes of ``work`` need; ``sq_stage(params, steps)``
    runs the silhouette objective's Adam stage on them (``iterations`` steps in all for a round's trials) and
    says whether it was interrupted. Returns the superquadrics and whether a stage was interrupted.

    Start with one; each round tries up to three moves — add one at the densest cluster of visual-hull voxels
    the union does not cover, split the largest one in two along its longest axis, or square the largest
    rounded one (ε₁ = ε₂ = :data:`FLAT_END`: a box) — fits briefly, and keeps the best if the silhouette score
    (mean of mask IoU and boundary F-score) improves by ``min_gain``.
    Then each one is tried once with flat ends (ε₁ = :data:`FLAT_END`), kept if the score improves by
    ``min_gain / 2``. A final joint refinement follows. (Fitting many at once and pruning leaves a ball split
    into overlapping pieces whose inner contours show in every view.) ``gen``, the stages' view sampler, is
    rewound after each box trial, so that a box that loses changes nothing else the growth draws.
    """
    from scipy.spatial import cKDTree

    from ...strokes.superquadric import quaternion_to_matrix, union_log_inside_outside

    def score(p: SuperquadricParams) -> float:
        return float(np.mean(silhouette_scores(p.to_set(), work.cameras, work.masks)))

    round_steps = max(20, iterations // 5)
    center = interior.mean(axis=0)
    extent = np.clip(interior.std(axis=0) * 1.7, 0.05 * frame.radius, frame.radius)
    params = SuperquadricParams.from_set(SuperquadricSet(extent[None], np.array([[0.9, 0.9]]),
                                                         np.array([[1.0, 0, 0, 0]]), center[None])).to(device)
    if sq_stage(params, round_steps):
        return params, True
    best = score(params)
    while len(params) < limit:
        current = params.to_set()
        candidates = []
        lf = union_log_inside_outside(interior, current.scale, current.shape, current.rotation, current.translation)
        uncovered = interior[lf > 0]
        if len(uncovered) >= 0.02 * len(interior):
            counts = cKDTree(uncovered).query_ball_point(uncovered, 0.15 * frame.radius, return_length=True)
            seed = uncovered[int(np.argmax(counts))]
            near = uncovered[np.linalg.norm(uncovered - seed, axis=1) < 0.3 * frame.radius]
            ext = np.clip(near.std(axis=0) * 1.7, 0.05 * frame.radius, 0.35 * frame.radius)
            candidates.append(("add", SuperquadricSet(
                np.vstack([current.scale, ext]), np.vstack([current.shape, [0.9, 0.9]]),
                np.vstack([current.rotation, [1.0, 0, 0, 0]]), np.vstack([current.translation, near.mean(0)]))))
        big = int(np.argmax(current.scale.max(axis=1)))
        axis = int(np.argmax(current.scale[big]))
        R = quaternion_to_matrix(current.rotation[big])
        offset = R[:, axis] * current.scale[big, axis] * 0.5
        half = current.scale[big].copy()
        half[axis] *= 0.5
        keep = [k for k in range(len(current)) if k != big]
        candidates.append(("split", SuperquadricSet(
            np.vstack([current.scale[keep], half, half]), np.vstack([current.shape[keep], current.shape[big], current.shape[big]]),
            np.vstack([current.rotation[keep], current.rotation[big], current.rotation[big]]),
            np.vstack([current.translation[keep], current.translation[big] + offset, current.translation[big] - offset]))))
        # Adam does not square a rounded cross-section either: a box fitted as rounded pills splits in two,
        # side by side, and their outlines meet in a notch. The largest rounded one is tried as a box.
        rounded = [k for k in range(len(current)) if current.shape[k].max() > FLAT_END]
        if rounded:
            boxy = max(rounded, key=lambda k: float(np.prod(current.scale[k])))
            shape = current.shape.copy()
            shape[boxy] = FLAT_END
            candidates.append(("box", replace(current, shape=shape)))
        results = []
        for move, cand in candidates:
            drawn_before = gen.get_state() if move == "box" and gen is not None else None
            trial = SuperquadricParams.from_set(cand).to(device)
            if sq_stage(trial, round_steps):
                return trial, True
            if drawn_before is not None:
                gen.set_state(drawn_before)
            results.append((score(trial), move, trial))
        top, move, trial = max(results, key=lambda r: r[0])
        if top - best < min_gain:
            break
        if move == "box":
            say(f"superquadrics: one is a box (score {best:.3f} → {top:.3f})")
        params, best = trial, top
    # Adam does not flatten a rounded end by itself (the mug's body: two stacked pills). Each one is tried
    # once with flat ends and kept so when the silhouettes agree better.
    for i in range(len(params)):
        current = params.to_set()
        if current.shape[i, 0] <= FLAT_END:
            continue
        shape = current.shape.copy()
        shape[i, 0] = FLAT_END
        trial = SuperquadricParams.from_set(replace(current, shape=shape)).to(device)
        if sq_stage(trial, round_steps):
            return trial, True
        if (top := score(trial)) >= best + min_gain / 2:
            say(f"superquadrics: one has flat ends (score {best:.3f} → {top:.3f})")
            params, best = trial, top
    say(f"superquadrics: {len(params)} explain the silhouettes (score {best:.3f}); refining")
    return params, sq_stage(params, max(20, iterations // 2), "superquadrics (refine)")
