"""Features people draw inside the outline: painted boundaries chosen by salience, not by pixels."""

from __future__ import annotations

import math

import numpy as np
import pytest

from doodle.evaluate import boundary_recall
from doodle.fit.discovery.discover import choose_curves, find_candidates
from doodle.fit.discovery.salience import (MIN_STEP, Feature, albedo_steps, choose_features, closure, duplicates,
                                           feature_cubics, group_features, score_features, symmetry_planes,
                                           within_reach)
from doodle.fit.volume.carve import VoxelGrid
from doodle.samples import load_ground_truth, painted_boundaries, sample_cameras, write_sample
from doodle.samples.primitives import Sphere
from doodle.scenes import load_scene
from doodle.strokes import CurveSet, StrokeSet
from doodle.strokes.bezier import bezier_points
from doodle.strokes.fitcurve import fit_cubics_many


def _ring(radius=1.0, centre=(0.0, 0.0, 0.0), start=0.0, stop=2 * math.pi, n=64) -> np.ndarray:
    a = np.linspace(start, stop, n)
    return np.stack([radius * np.cos(a), radius * np.sin(a), np.zeros(n)], -1) + np.asarray(centre)


def _feature(points, size, closed, contrast=0.5, isolation=1.0, members=(0,)) -> Feature:
    return Feature(np.asarray(members), contrast, closed, size, isolation, np.asarray(points, float))


class TestShape:
    def test_closure_is_how_far_round_a_feature_goes(self):
        assert closure(_ring()) == 1.0
        assert 0.4 <= closure(_ring(stop=math.pi)) <= 0.6
        assert closure(_ring(stop=1.6 * math.pi)) >= 0.75  # an eye whose far side the evidence left out
        line = np.stack([np.linspace(0, 1, 40), np.zeros(40), np.zeros(40)], -1)
        assert closure(line) <= 0.15

    def test_pieces_that_meet_end_to_end_are_one_feature(self):
        arcs = fit_cubics_many([_ring(stop=math.pi), _ring(start=math.pi, stop=2 * math.pi)], 0.01)
        far = fit_cubics_many([_ring(centre=(5.0, 0.0, 0.0))], 0.01)[0]
        controls = np.concatenate(arcs + [far])
        groups = group_features(controls, np.arange(len(controls)), 0.05)
        assert sorted(len(g) for g in groups) == sorted([len(arcs[0]) + len(arcs[1]), len(far)])

    def test_a_ring_with_a_gap_is_drawn_closed(self):
        pts = _ring(stop=1.7 * math.pi) + np.random.default_rng(0).normal(0, 0.01, (64, 3))
        f = _feature(pts, 0.1, closure(pts))
        cubics = feature_cubics(f, np.zeros((1, 4, 3)), 0.05)
        assert np.allclose(cubics[0, 0], cubics[-1, 3])  # closed
        drawn = bezier_points(cubics, np.linspace(0, 1, 16)).reshape(-1, 3)
        r = np.linalg.norm(drawn[:, :2], axis=1)
        assert np.abs(r - 1).max() < 0.12  # the gap is closed along the circle, not by a chord
        angles = np.arctan2(drawn[:, 1], drawn[:, 0])
        assert ((angles > -0.25 * math.pi) & (angles < -0.05 * math.pi)).sum() >= 3  # drawn across the gap

    def test_an_open_mark_keeps_its_traced_cubics(self):
        controls = fit_cubics_many([_ring(stop=0.5 * math.pi)], 0.01)[0]
        f = _feature(bezier_points(controls, np.linspace(0, 1, 12)).reshape(-1, 3), 0.1, 0.25,
                     members=np.arange(len(controls)))
        assert np.array_equal(feature_cubics(f, controls, 0.05), controls)


class TestSymmetry:
    def test_planes_the_hull_is_mirror_symmetric_about(self):
        occupied = np.zeros((48, 48, 48), bool)
        i, j, k = np.indices(occupied.shape)
        occupied |= ((i - 24) / 18.0) ** 2 + ((j - 24) / 10.0) ** 2 + ((k - 24) / 7.0) ** 2 <= 1
        grid = VoxelGrid(np.zeros(3), 1.0, occupied.shape)
        assert len(symmetry_planes(occupied, grid, np.random.default_rng(0))) == 3
        cow = np.zeros_like(occupied)  # a body and a head raised at one end: only left and right mirror
        cow |= ((i - 20) / 14.0) ** 2 + ((j - 24) / 8.0) ** 2 + ((k - 20) / 6.0) ** 2 <= 1
        cow |= (i - 36) ** 2 + (j - 24) ** 2 + (k - 30) ** 2 <= 7**2
        normals = np.array([n for _, n in symmetry_planes(cow, grid, np.random.default_rng(0))])
        assert len(normals) == 1 and abs(normals[0, 1]) > 0.99

    @pytest.mark.parametrize("reach", [1, 2, 3])
    def test_within_reach_reads_the_distance_transform_at_the_voxels_asked(self, reach):
        """The mirror test reads "within two voxels of the surface" at a few thousand voxels, not by a distance
        transform of the whole grid: the same answers, at the grid's edges too."""
        from scipy import ndimage

        rng = np.random.default_rng(reach)
        mask = rng.random((30, 25, 20)) < 0.06 / reach**3  # about half the voxels near one
        at = np.argwhere(np.ones(mask.shape, bool))
        expected = (ndimage.distance_transform_edt(~mask) <= reach)[tuple(at.T)]
        assert 0.1 < expected.mean() < 0.9
        np.testing.assert_array_equal(within_reach(mask, at, reach), expected)


class TestChoice:
    def test_two_small_eyes_beat_a_long_patch_edge_when_the_budget_is_small(self):
        eyes = [_feature(_ring(0.05, (1.0, s * 0.2, 0.0)), 0.03, 0.9, contrast=0.5, isolation=0.6) for s in (-1, 1)]
        for e in eyes:
            e.paired = True
        edge = _feature(np.stack([np.linspace(-1, 1, 60), np.zeros(60), np.zeros(60)], -1), 0.2, 0.05,
                        contrast=0.8, isolation=1.0)
        taken = choose_features([edge, *eyes], budget=2, reach=0.01)
        assert taken == eyes or taken == eyes[::-1]
        assert choose_features([edge, *eyes], budget=3, reach=0.01)[-1] is edge  # a larger budget draws it too
        assert edge not in choose_features([edge, *eyes], budget=3, reach=0.01, open_features=False)  # rings only
        assert choose_features([edge, *eyes], budget=0, reach=0.01) == []

    def test_a_feature_along_one_taken_is_not_taken_twice(self):
        a = _feature(_ring(0.1), 0.05, 1.0)
        b = _feature(_ring(0.1) + 0.001, 0.05, 1.0, contrast=0.4)
        assert choose_features([a, b], budget=5, reach=0.01) == [a]

    def test_a_ring_crossing_one_taken_is_not_taken_but_a_ring_inside_one_is(self):
        """Crossing rings read as a scribble (a checkered ball's dark squares seen as overlapping dark regions);
        a pupil inside an eye, or rings apart, are drawn each."""
        eye = _feature(_ring(0.1), 0.05, 1.0, contrast=0.8)
        crosses = _feature(_ring(0.1, (0.12, 0.0, 0.0)), 0.05, 1.0, contrast=0.5)
        pupil = _feature(_ring(0.03, (0.02, 0.0, 0.0)), 0.02, 1.0, contrast=0.5)
        apart = _feature(_ring(0.1, (0.5, 0.0, 0.0)), 0.05, 1.0, contrast=0.4)
        taken = choose_features([eye, crosses, pupil, apart], budget=5, reach=0.01)
        assert eye in taken and pupil in taken and apart in taken and crosses not in taken
        # alone, the crossing ring is drawn: only a ring taken before it bars it
        assert choose_features([crosses], budget=5, reach=0.01) == [crosses]

    def test_curves_along_a_feature_give_way_to_it(self):
        f = _feature(_ring(0.1), 0.05, 1.0)
        along = fit_cubics_many([_ring(0.1, stop=math.pi)], 0.001)[0]
        elsewhere = fit_cubics_many([_ring(0.1, (1.0, 0.0, 0.0))], 0.001)[0]
        dup = duplicates(np.concatenate([along, elsewhere]), [f], 0.01)
        assert dup[: len(along)].all() and not dup[len(along):].any()


def test_paint_is_a_step_in_the_images_and_shading_a_ramp():
    """A line on the object seen by a camera: across it the image steps (paint: half as bright) or ramps
    (shading, as steep at the line); only the step counts, and not across the outline."""
    cam = sample_cameras("test", 1, 96)[0]
    H, W = cam.height, cam.width
    o, d = cam.rays_at(np.full(9, W / 2), np.linspace(30, 66, 9))
    line = o + 3.0 * d  # a vertical line on the screen, at depth 3
    controls = fit_cubics_many([line], 1e-4)[0][:1]
    x = np.arange(W)[None, :].repeat(H, 0)
    step = np.where(x < W / 2, 200, 100).astype(np.uint8)[..., None].repeat(3, -1)
    ramp = np.clip(150 + (x - W / 2) * 12, 0, 255).astype(np.uint8)[..., None].repeat(3, -1)
    inside, outline = np.ones((H, W), bool), x < W / 2
    depth = [np.full((H, W), np.inf)]
    measure = lambda img, mask: albedo_steps(controls, [cam], [img], [mask], depth, 0.01)[0]
    assert abs(measure(step, inside) - math.log(2)) < 0.05
    assert measure(ramp, inside) == 0.0
    assert measure(step, outline) == 0.0  # one side is the background
    # a line darker than both its sides (a seam, a drawn stroke, the gap between teeth) counts as much as a
    # step of its darkness, and a pixel off the curve still as paint; a broad trough of shading, darker still
    # farther out, not
    seam = lambda at: np.where(np.abs(x + 0.5 - at) < 1.0, 100, 200).astype(np.uint8)[..., None].repeat(3, -1)
    assert abs(measure(seam(W / 2), inside) - math.log(2)) < 0.05
    assert measure(seam(W / 2 + 1), inside) >= MIN_STEP
    trough = np.clip(100 + np.abs(x + 0.5 - W / 2) * 12, 0, 255).astype(np.uint8)[..., None].repeat(3, -1)
    assert measure(trough, inside) == 0.0


def test_painted_boundaries_are_where_the_print_meets_the_bare_surface():
    cam = sample_cameras("test", 1, 96)[0]
    plain = painted_boundaries([Sphere(np.zeros(3), radius=0.6)], cam)
    assert not plain.any()  # the silhouette is no painted boundary
    face = painted_boundaries([Sphere(np.zeros(3), radius=0.6, print="face")], cam)
    assert 20 < face.sum() < 0.2 * 96 * 96


@pytest.fixture(scope="module")
def calf(tmp_path_factory):
    d = write_sample("calf", tmp_path_factory.mktemp("calf") / "calf", n_test=3)  # eyes ~10 px across: as small as a ring is traced
    return load_scene(d), load_scene(d, split="test"), load_ground_truth(d)


def test_the_calfs_eyes_and_patches_are_drawn_when_features_are_chosen_by_salience(calf):
    """Discovery on a small render of the painted cow: the structural choice alone (paint counts only for the
    outline) draws few painted boundaries; the features chosen by salience draw most of them; with a budget
    of two, they are the two eyes (small, closed, a mirror pair on the head), not the patches' longer edges."""
    scene, test, gt = calf
    cand = find_candidates(scene, 192)
    truth = [painted_boundaries(gt["primitives"], cam) for cam in test.cameras]
    recall = {}
    for budget in (0, 8):
        found = choose_curves(cand, 40, 0.0015, features=budget)
        sketch = StrokeSet(scene.frame, CurveSet(found.control_points, normals=found.normals, contour=found.contour))
        recall[budget] = boundary_recall(sketch, test.cameras, truth)
    assert recall[8] > recall[0] + 0.15 and recall[8] > 0.6, recall

    ev = cand.evidence
    structural = choose_curves(cand, 40, 0.0015, polish=False)
    members = np.flatnonzero(cand.smooth & (cand.gates == 0))
    scored = score_features(cand.controls, members, structural.control_points, ev.score, ev.grid, ev.occupied)
    two = choose_features(scored, 2, 2 * ev.grid.voxel, open_features=False)
    head = gt["primitives"][1]
    assert len(two) == 2 and all(head.contains(f.points, 0.05).mean() > 0.9 for f in two)
    assert all(f.paired for f in two)
    assert np.sign(two[0].points[:, 1].mean()) != np.sign(two[1].points[:, 1].mean())  # left and right
