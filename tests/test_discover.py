"""Stroke discovery: edge evidence, ridge tracing, stroke choice, joins, face normals, thin parts, roles."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from doodle.exporters import DrawOptions, draw
from doodle.exporters.drawing import back_facing
from doodle.fit.discovery.discover import (OUTLINE_OPEN, choose_curves, complete_outline, find_candidates,
                                          select_strokes, snap_ends)
from doodle.fit.discovery.evidence import edge_evidence, object_lines, thin_parts
from doodle.fit.volume.carve import VoxelGrid, carve_hull, fit_axes
from doodle.fit.discovery.facing import curve_normals
from doodle.fit.discovery.ridges import RidgePoints, _bridge, link_ridges, split_at_corners
from doodle.scenes import working_scene
from doodle.samples import load_ground_truth
from doodle.scenes import load_scene
from doodle.strokes import CurveSet, SceneFrame, StrokeSet, SuperquadricSet

from helpers_geometry import edge_scores, sample_segments


@pytest.fixture(scope="module")
def chair(chair_dir):
    scene = load_scene(chair_dir)
    return scene, load_ground_truth(chair_dir)


def _turn_z(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


def _turned_scene(scene, Q: np.ndarray):
    """The scene with its world turned by ``Q`` about the frame's centre (cameras and frame move along)."""
    from dataclasses import replace

    c = scene.frame.center
    cams = [replace(cam, R=cam.R @ Q.T, t=cam.t + cam.R @ c - cam.R @ Q.T @ c) for cam in scene.cameras]
    frame = replace(scene.frame, up=Q @ scene.frame.up)
    return replace(scene, cameras=cams, frame=frame)


class TestLines:
    def test_shading_noise_is_not_a_line_but_a_step_is(self):
        rng = np.random.default_rng(0)
        img = np.full((96, 96, 3), 128.0) + rng.normal(0, 2.0, (96, 96, 1))  # rendering noise
        img[:, 48:] += 40  # a crease between two faces
        mask = np.zeros((96, 96), bool)
        mask[10:86, 10:86] = True
        lines = object_lines(np.clip(img, 0, 255).astype(np.uint8), mask)
        inside = lines[14:82, 14:82]
        assert inside[:, 32:36].any(axis=1).mean() > 0.9  # the step, all along
        assert inside[:, :28].sum() + inside[:, 40:].sum() == 0  # no noise edges on the faces

    def test_thin_parts_give_their_axis(self):
        mask = np.zeros((120, 120), bool)
        yy, xx = np.mgrid[:120, :120]
        mask |= (yy - 40) ** 2 + (xx - 40) ** 2 < 30**2  # a thick disc
        mask[36:40, 60:115] = True  # a 4-px wire leaving it
        axes, region = thin_parts(mask, thin=0.06)
        assert region[36:40, 80:110].all() and not region[30:50, 20:50].any()
        ys, xs = np.nonzero(axes)
        assert len(ys) > 30 and np.all((ys >= 36) & (ys < 40)) and xs.min() >= 60

    def test_a_thin_part_wide_in_the_image_is_drawn_by_its_rims_not_its_axis(self):
        """Two thin parts off a disc on a 256 px image: a 4-px wire (its axis is a line: one stroke draws both
        rims) and a 10-px leg (wider than 2 % of the image: its rims are lines, its middle is not)."""
        mask = np.zeros((256, 256), bool)
        yy, xx = np.mgrid[:256, :256]
        mask |= (yy - 100) ** 2 + (xx - 80) ** 2 < 60**2
        mask[60:64, 130:240] = True  # the wire
        mask[150:160, 130:240] = True  # the leg
        region = thin_parts(mask, thin=0.06)[1]
        assert region[60:64, 170:230].all() and region[150:160, 170:230].all()  # both are thin parts
        lines = object_lines(np.full((256, 256, 3), 128, np.uint8), mask)
        assert lines[61:63, 170:230].any(axis=0).all()  # the wire's axis
        assert not lines[153:157, 150:230].any()  # nothing down the leg's middle ...
        assert lines[150, 170:230].all() and lines[159, 170:230].all()  # ... its rims

    def test_a_thin_part_keeps_its_whole_axis_or_none_of_it(self):
        """A pole tapering from 2 to 7 px (median width under the 5 px limit at 256 px) keeps its axis all
        along, where it is 7 px wide too; the same pole from 4 to 9 px (median over the limit) has none."""
        from doodle.fit.discovery.evidence import narrow_axes

        def pole(w0: float, w1: float) -> np.ndarray:
            mask = np.zeros((256, 256), bool)
            yy, xx = np.mgrid[:256, :256]
            mask |= (yy - 100) ** 2 + (xx - 80) ** 2 < 60**2
            half = (w0 + (w1 - w0) * (xx - 130) / 110) / 2
            mask |= (xx >= 130) & (xx < 240) & (np.abs(yy - 120 + 0.5) <= half)
            return mask

        tapered = narrow_axes(pole(2, 7), 0.06, None, 5.12)
        assert tapered[110:131, 160:180].any(axis=0).all() and tapered[110:131, 215:232].any(axis=0).all()
        assert not narrow_axes(pole(4, 9), 0.06, None, 5.12)[110:131, 140:240].any()


def test_line_maps_on_the_objects_box_equal_those_on_the_whole_frame(chair, monkeypatch):
    from doodle.fit.discovery import evidence

    scene, _ = chair
    # a busy background: the crop's border must not make lines of it
    rng = np.random.default_rng(1)
    backdrop = rng.integers(0, 255, scene.images[0].shape, dtype=np.uint8)
    views = [(np.where(m[..., None], im, backdrop), m) for im, m in zip(scene.images[:4], scene.masks[:4])]
    cropped = [evidence.view_maps(im, m) for im, m in views]
    cropped_lines = [object_lines(im, m) for im, m in views]
    assert evidence._object_box(views[0][1]) != (slice(None), slice(None))  # the test crops something
    monkeypatch.setattr(evidence, "CROP_PAD", 10_000)  # the box is the whole frame
    for (im, m), c, lines in zip(views, cropped, cropped_lines):
        full = evidence.view_maps(im, m)
        assert full.lines.any() and np.array_equal(full.lines, c.lines) and np.array_equal(lines, object_lines(im, m))
        np.testing.assert_array_equal(full.response, c.response)
        np.testing.assert_array_equal(full.sdf, c.sdf)
        near = full.response > 0.05  # where the vote reads the directions
        np.testing.assert_array_equal(full.directions[near], c.directions[near])


class TestEvidence:
    def test_hull_holds_the_chair(self, chair):
        scene, gt = chair
        grid, occupied = carve_hull(scene, 64)
        pts = grid.centres(np.argwhere(occupied))
        inside = np.zeros(len(pts), bool)
        for p in gt["primitives"]:
            inside |= p.contains(pts, margin=1.5 * grid.voxel)
        assert inside.mean() > 0.6  # a hull from 12 views over-approximates, but hugs the chair
        edge_pts, _ = sample_segments(gt["feature_edges"], grid.voxel)
        ijk = np.clip(grid.index(edge_pts), 0, np.array(grid.shape) - 1)
        from scipy import ndimage

        near = ndimage.binary_dilation(occupied, iterations=2)[tuple(ijk.T)]
        assert near.mean() > 0.95  # every feature edge lies on (or next to) the hull

    def test_a_tolerant_hull_keeps_what_one_tight_mask_would_carve(self, chair, monkeypatch):
        # automatic masks are a pixel or two off, differently in each photo: one mask too tight carves a
        # strict hull for every view, while allowing a share of the views to disagree keeps the object
        from dataclasses import replace

        scene, _ = chair
        grid, clean = carve_hull(scene, 48)
        masks = [m.copy() for m in scene.masks]
        masks[3] = ndimage.binary_erosion(masks[3], iterations=4)
        masks[3][:, : masks[3].shape[1] // 2] = False  # and half of the object gone
        tight = replace(scene, masks=masks)
        strict = carve_hull(tight, 48)[1]
        tolerant = carve_hull(tight, 48, disagree=0.1)[1]  # one view of 12 may disagree
        assert strict.sum() < 0.8 * clean.sum()
        assert (tolerant & clean).sum() > 0.97 * clean.sum()
        assert tolerant.sum() < 1.5 * clean.sum()  # and it does not swell where the masks agree
        assert np.array_equal(carve_hull(scene, 48, disagree=0.0)[1], clean)
        # by default only automatic masks get the tolerance (3 %: none of 12 views, so raised here)
        from doodle.fit.volume import carve

        monkeypatch.setattr(carve, "HULL_DISAGREE", 0.1)
        assert np.array_equal(carve_hull(tight, 48)[1], strict)
        assert np.array_equal(carve_hull(replace(tight, masks_automatic=True), 48)[1], tolerant)

    def test_grid_turns_with_an_object_posed_at_an_angle(self, chair):
        # structure from motion poses an object at any angle to the world's axes: the grid turns with it, so
        # its voxels are as fine as for the object upright, and discovery still finds the edges
        scene, gt = chair
        Q = _turn_z(np.radians(35))
        turned = _turned_scene(scene, Q)
        grid, _ = carve_hull(scene, 64)
        grid_t, occupied_t = carve_hull(turned, 64)
        assert np.allclose(grid.axes, np.eye(3))  # upright: the world's axes, exactly
        assert grid_t.voxel < 1.05 * grid.voxel, (grid_t.voxel, grid.voxel)
        assert np.prod(grid_t.shape) < 1.15 * np.prod(grid.shape), (grid_t.shape, grid.shape)  # world-aligned: 1.6 ×
        ijk = np.argwhere(occupied_t)[:50]
        assert np.allclose(grid_t.coordinates(grid_t.centres(ijk)), ijk)
        c = scene.frame.center
        edges = np.einsum("ij,ekj->eki", Q, gt["feature_edges"] - c) + c
        found = choose_curves(find_candidates(working_scene(turned, 128), 96), 64)
        p, r = edge_scores(found.control_points, edges, 0.04 * scene.frame.radius)
        assert p > 0.75 and r > 0.5, (p, r)

    def test_fit_axes_keeps_the_world_unless_a_turn_is_much_smaller(self):
        rng = np.random.default_rng(0)
        box = rng.uniform(-1, 1, (2000, 3)) * [2.0, 1.0, 0.5]
        assert np.allclose(fit_axes(box, np.array([0, 0, 1.0])), np.eye(3))
        Q = _turn_z(np.radians(30))
        axes = fit_axes(box @ Q.T, np.array([0, 0, 1.0]))
        assert abs(abs(axes[0] @ Q[:, 0]) - 1) < 0.01 or abs(abs(axes[1] @ Q[:, 0]) - 1) < 0.01, axes
        assert np.allclose(axes[2], [0, 0, 1]) and np.allclose(axes @ axes.T, np.eye(3))

    def test_votes_peak_on_feature_edges(self, chair):
        scene, gt = chair
        ev = edge_evidence(scene, 96)
        edge_pts, _ = sample_segments(gt["feature_edges"], ev.grid.voxel)
        ijk = ev.grid.index(edge_pts)
        ok = np.all((ijk >= 0) & (ijk < np.array(ev.grid.shape)), axis=1)
        from scipy import ndimage

        peak = ndimage.maximum_filter(ev.score, size=3)
        on_edges = peak[tuple(ijk[ok].T)]
        voted = ev.score[ev.score > 0]
        assert np.median(on_edges) > 2.5 * np.median(voted), (np.median(on_edges), np.median(voted))


def _ridge_line(n: int, duplicate: float, rng) -> RidgePoints:
    t = np.linspace(0, 1, n)
    pts = np.stack([t, 0.2 * np.sin(3 * t), 0 * t], 1)
    tan = np.gradient(pts, axis=0)
    tan /= np.linalg.norm(tan, axis=1, keepdims=True)
    # the parallel duplicates a ridge leaves in neighbouring voxels
    dup = pts + rng.normal(0, duplicate, pts.shape)
    return RidgePoints(np.vstack([pts, dup]), np.vstack([tan, tan]), np.r_[np.ones(n), 0.8 * np.ones(n)])


class TestRidges:
    def test_one_ridge_with_duplicates_is_one_polyline(self):
        rp = _ridge_line(200, 0.002, np.random.default_rng(1))
        polys = link_ridges(rp, voxel=0.005, corner_deg=60)
        lengths = sorted(np.linalg.norm(np.diff(p, axis=0), axis=1).sum() for p in polys)
        assert lengths[-1] > 0.9 * 1.1  # the whole wavy line (length ≈ 1.16)
        assert sum(lengths[:-1]) < 0.05

    def test_corner_splits(self):
        a = np.stack([np.linspace(0, 1, 50), np.zeros(50), np.zeros(50)], 1)
        b = np.stack([np.ones(50), np.linspace(0, 1, 50), np.zeros(50)], 1)
        pieces = split_at_corners(np.vstack([a, b[1:]]), 40, 0.06)
        assert len(pieces) == 2 and np.allclose(pieces[0][-1], [1, 0, 0]) and np.allclose(pieces[1][0], [1, 0, 0])

    def test_bridge_joins_facing_ends_only(self):
        x = np.linspace(0, 1, 20)[:, None]
        left = np.hstack([x, 0 * x, 0 * x])
        right = left + [1.05, 0, 0]
        across = np.hstack([0 * x + 1.025, x + 0.05, 0 * x])  # perpendicular, its end 0.05 from the gap
        out = _bridge([left, right, across], max_gap=0.1, max_angle_deg=35)
        assert len(out) == 2 and max(len(p) for p in out) == 40


class TestChoice:
    def test_duplicates_are_never_both_chosen_and_the_count_stops(self):
        a = np.arange(0, 100)
        covers = [a, a.copy(), np.arange(100, 160), np.arange(160, 162)]
        chosen, gains = select_strokes(covers, np.zeros(4), max_strokes=10, min_gain=5)
        assert sorted(chosen) in ([0, 2], [1, 2]) and gains == sorted(gains, reverse=True)

    def test_taken_pixels_count_as_drawn(self):
        covers = [np.arange(0, 100), np.arange(100, 150)]
        chosen, _ = select_strokes(covers, np.zeros(2), 10, 5, taken=np.arange(0, 90))
        assert chosen == [1]

    def test_a_rim_along_an_outline_in_half_the_views_is_still_chosen(self):
        """A cylinder's rim: its pixels in the views from behind lie on the superquadric's drawn outline
        (taken), those in the views from the front are a line of their own. 40 % new is enough against an
        outline; against a chosen stroke it takes half."""
        rim, other = np.arange(0, 100), np.arange(100, 160)
        chosen, _ = select_strokes([rim, other], np.zeros(2), 10, 5, taken=np.arange(0, 60))
        assert sorted(chosen) == [0, 1]
        longer = np.arange(100, 220)
        along = np.concatenate([np.arange(100, 160), np.arange(0, 40)])  # 60 % along the stroke `longer`
        chosen, _ = select_strokes([longer, along], np.zeros(2), 10, 5)
        assert chosen == [0]

    def test_ink_off_the_lines_costs(self):
        covers = [np.arange(0, 40), np.arange(40, 100)]
        chosen, _ = select_strokes(covers, np.array([0.0, 200.0]), 10, 5)
        assert chosen == [0]

    def test_the_outline_is_completed_by_strokes_for_it_alone(self):
        """After the choice, only outline pixels count: a stroke along the inside lines gains nothing, one
        along the outline is taken even though an inside stroke explains more pixels, pixels already drawn
        count for nothing, off-line ink still costs, and a stroke mostly inside is no outline stroke."""
        outline = np.arange(0, 100)
        covers = [np.arange(100, 400),  # inside lines only
                  np.arange(0, 60),  # the outline's first 60 pixels: chosen before
                  np.arange(40, 90),  # 30 new outline pixels
                  np.arange(90, 95),  # 5 new, but much ink off the lines
                  np.r_[np.arange(95, 100), np.arange(400, 600)],  # 5 new outline pixels among many inside ones
                  np.r_[np.arange(95, 100), np.arange(600, 607)]]  # 5 new outline pixels, a few inside ones
        more, gains = complete_outline(covers, np.array([0, 0, 0, 100.0, 0, 0]), [1], outline, 700, 10, 3)
        assert more == [2, 5] and gains == [30.0, 5.0]
        more, _ = complete_outline(covers, np.zeros(6), [1], outline, 700, 1, 3)
        assert more == [2]  # at most max_strokes

    def test_meeting_ends_snap_together(self):
        c = np.array([[[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]],
                      [[3.05, 0, 0], [3.05, 1, 0], [3.05, 2, 0], [3.05, 3, 0]]], float)
        s = snap_ends(c, 0.1)
        assert np.allclose(s[0, 3], s[1, 0]) and np.allclose(s[0, 3], [3.025, 0, 0])
        assert np.allclose(s[1, 1] - s[1, 0], c[1, 1] - c[1, 0])  # tangents keep their direction

    def test_chair_discovery_finds_the_edges(self, chair):
        scene, gt = chair
        cand = find_candidates(working_scene(scene, 128), 96)
        found = choose_curves(cand, 64)
        assert 10 <= len(found.control_points) <= 64
        p, r = edge_scores(found.control_points, gt["feature_edges"], 0.04 * scene.frame.radius)
        assert p > 0.75 and r > 0.5, (p, r)  # 12 views at 128 px: coarse; the full-size bars are in bench_fit
        assert found.normals.shape == (len(found.control_points), 2, 2, 3)
        # the outline budget is spent once the curves' is, while the outline drawn is under OUTLINE_OPEN, or
        # always (``--detail high``): the chair's 64 were not all chosen, and they draw under 0.9 of its outline
        plain = choose_curves(cand, 64, polish=False)
        opened = choose_curves(cand, 64, outline_curves=24, polish=False)
        always = choose_curves(cand, 64, outline_curves=24, outline_always=True, polish=False)
        assert len(plain.control_points) < 64 and plain.outline_drawn < OUTLINE_OPEN
        assert len(opened.control_points) > len(plain.control_points) and opened.outline_drawn > plain.outline_drawn
        assert len(always.control_points) > len(plain.control_points) and always.outline_drawn > plain.outline_drawn
        # where the outline is drawn already (the superquadrics'), an unspent budget adds nothing for it
        whole = choose_curves(cand, 64, outline_curves=24, taken=cand.rim, polish=False)
        np.testing.assert_array_equal(whole.control_points,
                                      choose_curves(cand, 64, taken=cand.rim, polish=False).control_points)


class TestFacing:
    def test_back_facing_rule(self):
        pts = np.zeros((4, 3))
        up, side, zero = [0, 0, 1.0], [1.0, 0, 0], [0, 0, 0]
        normals = np.array([[[up, up]] * 2, [[up, side]] * 2, [[zero, zero]] * 2, [[up, up]] * 2])
        eyes = np.array([[0, 0, -5.0], [-5.0, 0, -5.0], [0, 0, -5.0], [5.0, 0, 0.2]])
        hidden = back_facing(pts, np.full(4, 0.5), normals, eyes, np.zeros((4, 3)), np.zeros(4, bool))
        # below a face: hidden; below and behind both: hidden; unknown: shown; near edge-on: shown (outline)
        assert hidden.tolist() == [True, True, False, False]

    def test_box_edge_gets_its_two_faces(self):
        occupied = np.zeros((40, 40, 40), bool)
        occupied[10:30, 10:30, 10:30] = True
        grid = VoxelGrid(np.zeros(3), 0.1, occupied.shape)
        edge = np.array([[[1.0, 2.95, 2.95], [1.6, 2.95, 2.95], [2.3, 2.95, 2.95], [2.9, 2.95, 2.95]]])  # +y/+z edge
        n = curve_normals(edge, grid, occupied)[0]
        for end in n:
            best = [max(float(f @ face) for f in end) for face in ([0, 1.0, 0], [0, 0, 1.0])]
            assert min(best) > np.cos(np.radians(10)), end  # each face's normal, within 10°

    def test_fitted_faces_keep_a_margin_for_views_between(self):
        # a probe seen from every view within 95° of +z (a rim); hull normals every 20° in the x-z plane, none
        # exactly +z (a voxel hull's normals are only that accurate)
        from doodle.fit.discovery.facing import FIT_GRAZING, _best_pair

        angle = lambda a: np.stack([np.sin(a), np.zeros_like(a), np.cos(a)], -1)
        normals = angle(np.radians(np.arange(-170, 180, 20.0)))
        views = np.radians(np.arange(-175, 180, 10.0))
        seen = (np.abs(views) <= np.radians(95)).astype(np.int8)
        pair = _best_pair(normals, seen, angle(views), FIT_GRAZING)

        def hidden(degrees: np.ndarray) -> np.ndarray:  # as the exporters draw it from novel views
            n = len(degrees)
            eyes = 10 * angle(np.radians(degrees))
            return back_facing(np.zeros((n, 3)), np.zeros(n), np.broadcast_to(pair, (n, 2, 2, 3)), eyes,
                               np.zeros_like(eyes), np.zeros(n, bool))

        assert not hidden(np.arange(-100, 101, 1.0)).any()  # up to 5° beyond the last views that see it
        assert hidden(np.arange(130, 231, 5.0)).all()  # well behind: hidden

    def test_exporter_hides_back_edges_with_normals(self):
        # the top and bottom front edges of a unit cube seen from above the front: the bottom-back one hides
        edges = np.array([[[-1, -1, 1], [-0.3, -1, 1], [0.3, -1, 1], [1, -1, 1]],   # top front: faces +z, -y
                          [[-1, 1, -1], [-0.3, 1, -1], [0.3, 1, -1], [1, 1, -1]]], float)  # bottom back: -z, +y
        normals = np.array([[[[0, 0, 1], [0, -1, 0]]] * 2, [[[0, 0, -1], [0, 1, 0]]] * 2], float)
        from doodle.cameras import look_at
        from doodle.cameras.camera import Camera

        R, t = look_at(np.array([0, -6.0, 4.0]), np.zeros(3), np.array([0, 0, 1.0]))
        cam = Camera(300, 300, 128, 128, 256, 256, R, t)
        s = StrokeSet(SceneFrame(radius=2.0), CurveSet(edges, 1.5, normals))
        hide = [op.id for op in draw(s, cam, DrawOptions(hidden="hide")).layer("curves")]
        show = [op.id for op in draw(s, cam, DrawOptions(hidden="show")).layer("curves")]
        assert hide == ["curve-000"] and show == ["curve-000", "curve-001"]


class TestOccluders:
    def test_occluder_hides_but_draws_nothing(self):
        from doodle.cameras import look_at
        from doodle.cameras.camera import Camera

        sq = SuperquadricSet(np.array([[0.5, 0.5, 0.5]]), np.array([[1.0, 1.0]]), np.array([[1.0, 0, 0, 0]]),
                             np.zeros((1, 3)), outline=np.array([False]))
        behind = np.array([[[-1, 2, 0], [-0.3, 2, 0], [0.3, 2, 0], [1, 2, 0.0]]])  # behind the ball
        R, t = look_at(np.array([0, -6.0, 0.0]), np.zeros(3), np.array([0, 0, 1.0]))
        cam = Camera(300, 300, 128, 128, 256, 256, R, t)
        d = draw(StrokeSet(SceneFrame(radius=2.0), CurveSet(behind), sq), cam, DrawOptions(hidden="dash"))
        assert d.layer("silhouettes") == [] and d.layer("hidden") and d.layer("curves")  # split around the ball
        sq.outline = None
        assert draw(StrokeSet(SceneFrame(radius=2.0), CurveSet(behind), sq), cam).layer("silhouettes")


ABC = __import__("pathlib").Path(__file__).resolve().parents[2] / "shared" / "data" / "abc-nef" / "00000006"


def test_cad_part_edges_match_the_ground_truth():
    """ABC-NEF 00000006 (a hex nut): the discovered curves alone meet the issue's bars for the default fit
    (3D precision ≥ 0.9 and recall ≥ 0.85 at 0.02 for the feature curves, at most 48 curves with the contour
    curves); benchmarks/bench_fit.py runs the whole default fit."""
    if not (ABC / "transforms_train.json").exists():
        pytest.skip("ABC-NEF data (../shared/data/abc-nef) not present")
    from doodle.curvemetrics import curve_metrics, read_abc_ground_truth
    from doodle.scenes import load_scene_at_size

    scene = load_scene_at_size(ABC, "train", 512)
    found = choose_curves(find_candidates(scene), 96)
    m = curve_metrics(found.control_points[found.contour == 0], read_abc_ground_truth(ABC / "ground_truth"))
    assert len(found.control_points) <= 48 and m["precision"] >= 0.9 and m["recall"] >= 0.85, (len(found.control_points), m)


def test_outline_reach_claims_lines_beside_a_drawn_outline():
    """Line pixels 2 px beside a superquadric's drawn outline count as drawn with a reach of 3 (1.5 working
    px at the default evidence size), not with 1: otherwise a curve is chosen for them, a tick along the rim."""
    from types import SimpleNamespace

    from doodle.fit.discovery.discover import Candidates

    lines = np.zeros((20, 20), bool)
    lines[:, 12] = True  # an image line two pixels right of the outline at x = 10
    cand = SimpleNamespace(views=[0], evidence=SimpleNamespace(lines=[lines]))
    outline = [np.array([[10.5, y + 0.5] for y in range(20)])]
    assert len(Candidates.pixel_ids(cand, outline, 1)) == 0
    assert len(Candidates.pixel_ids(cand, outline, 3)) == 20
