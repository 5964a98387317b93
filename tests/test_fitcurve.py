"""The batched Schneider fitter used for silhouettes, and the occlusion test's culling shortcuts."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from doodle.strokes.fitcurve import fit_cubics, fit_cubics_many
from doodle.exporters.visibility import segments_blocked
from doodle.strokes import SuperquadricSet
from doodle.strokes.bezier import bezier_points
from doodle.strokes.superquadric import log_inside_outside, world_to_local


def _superellipse(n: int, e: float, a: float, b: float, phase: float) -> np.ndarray:
    """``n`` points evenly spaced by arc length (as contour vertices are), the loop not repeated at its end."""
    t = np.linspace(0, 2 * np.pi, 40001) + phase
    c, s = np.cos(t), np.sin(t)
    dense = np.stack([a * np.sign(c) * np.abs(c) ** e, b * np.sign(s) * np.abs(s) ** e], 1) + 256
    arc = np.r_[0, np.cumsum(np.linalg.norm(np.diff(dense, axis=0), axis=1))]
    return dense[np.searchsorted(arc, np.linspace(0, arc[-1], n, endpoint=False))]


def _wiggle(n: int, rng) -> np.ndarray:
    t = np.linspace(0, 1, n)
    k = rng.uniform(1, 4, 2)
    return np.stack([400 * t, 60 * np.sin(k[0] * np.pi * t) + 20 * np.cos(k[1] * np.pi * t ** 2)], 1) + 50


def _samples(cubics: np.ndarray, spacing: float = 0.01) -> np.ndarray:
    """Points on the cubics at most ``spacing`` apart (so a nearest-sample distance is the curve distance)."""
    per = [int(np.abs(np.diff(c, axis=0)).sum() / spacing) + 2 for c in cubics]
    return np.concatenate([bezier_points(c, np.linspace(0, 1, n)) for c, n in zip(cubics, per)])


def _cases(seed: int):
    rng = np.random.default_rng(seed)
    polys = [_superellipse(int(rng.integers(200, 600)), e, rng.uniform(40, 200), rng.uniform(40, 200), rng.uniform(0, 6))
             for e in (0.15, 0.6, 1.0, 1.7)]
    return polys + [_wiggle(int(rng.integers(100, 400)), rng) for _ in range(3)], [True] * 4 + [False] * 3


@pytest.mark.parametrize("seed", range(4))
def test_every_point_within_tolerance_and_no_detours(seed):
    polys, closed = _cases(seed)
    tol = 0.05
    for poly, is_closed, cubics in zip(polys, closed, fit_cubics_many(polys, tol, closed)):
        dense = _samples(cubics)
        d_points, _ = cKDTree(dense).query(poly)
        assert d_points.max() <= tol + 1e-3  # every input point is on the drawing
        # ...and the drawing never leaves the polyline (a long handle would loop away between points).
        loop = np.vstack([poly, poly[:1]]) if is_closed else poly
        fine = np.concatenate([np.linspace(a, b, int(np.linalg.norm(b - a) / 0.02) + 2) for a, b in zip(loop[:-1], loop[1:])])
        d_curve, _ = cKDTree(fine).query(dense)
        assert d_curve.max() <= 0.25
        # consecutive pieces meet, and with tangent continuity (G1) at every split
        assert np.allclose(cubics[1:, 0], cubics[:-1, 3])
        out_dir, in_dir = cubics[1:, 1] - cubics[1:, 0], cubics[:-1, 3] - cubics[:-1, 2]
        cos = np.einsum("ij,ij->i", out_dir, in_dir) / (np.linalg.norm(out_dir, axis=1) * np.linalg.norm(in_dir, axis=1))
        assert cos.min() > 1 - 1e-9
        if is_closed:
            assert np.allclose(cubics[0, 0], cubics[-1, 3])
        else:
            assert np.allclose(cubics[0, 0], poly[0]) and np.allclose(cubics[-1, 3], poly[-1])


def test_batch_equals_one_by_one_and_is_economical():
    polys, closed = _cases(7)
    # a long polyline first: what precedes a polyline in a batch must not change a bit of its fit (a
    # running arc length over the batch once did, and draw_many's outlines then differed from draw's)
    long = np.stack([np.linspace(0, 1e4, 300), np.sin(np.linspace(0, 40, 300)), np.zeros(300)], 1)[:, :2]
    batch = fit_cubics_many([long, *polys], 0.05, [False, *closed])[1:]
    single = [fit_cubics(p, 0.05, c) for p, c in zip(polys, closed)]
    assert all(np.array_equal(a, b) for a, b in zip(batch, single))
    # A circle of radius 100 px needs a handful of cubics at 0.05 px, not one per input point.
    circle = fit_cubics(_superellipse(400, 1.0, 100, 100, 0.3), 0.05, closed=True)
    assert 6 <= len(circle) <= 16


def test_exact_tangents_are_used_in_either_sign():
    t = np.linspace(0, np.pi, 200)
    arc = np.stack([100 * np.cos(t), 100 * np.sin(t)], 1)
    exact = np.stack([-np.sin(t), np.cos(t)], 1) * np.where(np.arange(200) % 2, 1, -1)[:, None]  # random signs
    cubics = fit_cubics(arc, 0.05, tangents=exact)
    start_dir = (cubics[0, 1] - cubics[0, 0]) / np.linalg.norm(cubics[0, 1] - cubics[0, 0])
    assert np.allclose(start_dir, [0, 1], atol=1e-9)  # the exact tangent at the start, pointing along the arc


def test_degenerate_inputs():
    assert fit_cubics(np.array([[1.0, 2.0]]), 0.1).shape == (1, 4, 2)
    two = fit_cubics(np.array([[0.0, 0.0], [3.0, 0.0]]), 0.1)
    assert np.allclose(two[0], [[0, 0], [1, 0], [2, 0], [3, 0]])
    repeated = fit_cubics(np.array([[0.0, 0.0]] * 5 + [[1.0, 1.0]] * 5), 0.1)
    assert np.isfinite(repeated).all() and np.allclose(repeated[-1, -1], [1, 1])


@pytest.mark.parametrize("seed", range(3))
def test_occlusion_culling_agrees_with_a_dense_march(seed):
    """Box culling and the inscribed ellipsoid/octahedron shortcuts give the answer of a brute-force march."""
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(5, 4))
    sq = SuperquadricSet(rng.uniform(0.1, 0.5, (5, 3)), rng.uniform(0.1, 1.9, (5, 2)),
                         q / np.linalg.norm(q, axis=1, keepdims=True), rng.uniform(-0.5, 0.5, (5, 3)))
    o = rng.normal(size=(1500, 3))
    o = 3 * o / np.linalg.norm(o, axis=1, keepdims=True)
    ends = rng.uniform(-0.8, 0.8, (1500, 3))
    exclude = rng.integers(-1, 5, 1500)
    got = segments_blocked(o, ends, sq, samples=32, exclude=exclude)
    t = np.linspace(0, 1, 1500)  # 2 mm steps along 3-unit segments (4,000 found the same blocked rays)
    lf = np.stack([log_inside_outside(world_to_local(o[k] + t[:, None] * (ends[k] - o[k]), sq.rotation, sq.translation),
                                      sq.scale, sq.shape) for k in range(len(o))])  # (P, M, T)
    lf[np.arange(len(o))[exclude >= 0], exclude[exclude >= 0]] = np.inf
    depth = lf.min(axis=(1, 2))
    clear = np.abs(depth) > 0.05  # grazing rays may go either way at 32 samples
    assert clear.mean() > 0.8 and (depth < 0).sum() > 150
    assert np.array_equal(got[clear], depth[clear] < 0)


@pytest.mark.parametrize("e", [0.15, 1.0, 1.9])
def test_exact_tangents_at_near_corners_make_no_loops(e):
    """Exact tangents that turn sharply near corners (pinched or box-like outlines): the fit stays on the
    outline (the drawn superquadric case is in test_exporters' silhouette accuracy tests)."""
    t = np.linspace(0, 2 * np.pi, 300, endpoint=False) + 0.1
    c, s = np.cos(t), np.sin(t)
    pts = np.stack([150 * np.sign(c) * np.abs(c) ** e, 90 * np.sign(s) * np.abs(s) ** e], 1) + 256
    tangent = np.stack([-150 * np.abs(c) ** (e - 1) * s, 90 * np.abs(s) ** (e - 1) * c], 1)
    cubics = fit_cubics(pts, 0.05, closed=True, tangents=tangent)
    loop = np.vstack([pts, pts[:1]])
    fine = np.concatenate([np.linspace(a, b, int(np.linalg.norm(b - a) / 0.02) + 2) for a, b in zip(loop[:-1], loop[1:])])
    assert cKDTree(fine).query(_samples(cubics))[0].max() <= 0.5
    assert cKDTree(_samples(cubics)).query(pts)[0].max() <= 0.05 + 1e-3
