"""Barr's tapering and bending of superquadrics: the math, the files, the drawing, the fit and the judge."""

from dataclasses import replace

import numpy as np
import pytest
import torch
from scipy import ndimage

from doodle.cameras import orbit_cameras
from doodle.errors import DoodleError, StrokeFileError
from doodle.exporters.drawing import check_camera
from doodle.exporters.scene3d import superquadric_mesh
from doodle.exporters.silhouettes import contour_polylines
from doodle.exporters.visibility import occluded, union_mask
from doodle.strokes import binary, fileio
from doodle.strokes.deform import bend, bend_axis, deform, taper, unbend, undeform
from doodle.strokes.model import CurveSet, DefaultCamera, SceneFrame, StrokeSet, SuperquadricSet
from doodle.strokes.superquadric import bounding_radius, canonical, deformation_of, inside_outside

FRAME = SceneFrame(radius=1.0, camera=DefaultCamera(distance=4.0, elevation_deg=20.0, width=128, height=128))
CAMS = orbit_cameras(FRAME, 6)


def _one(scale, shape=(0.5, 1.0), taper_=(0.0, 0.0), bend_=(0.0, 0.0), at=(0.0, 0.0, 0.0)) -> SuperquadricSet:
    return SuperquadricSet(np.array([scale], float), np.array([shape], float), np.array([[1.0, 0, 0, 0]]),
                           np.array([at], float), taper=np.array([taper_], float), bend=np.array([bend_], float))


def test_deform_and_undeform_are_inverses_and_zero_is_the_identity():
    rng = np.random.default_rng(0)
    a = np.array([0.3, 0.4, 1.0])
    x = rng.uniform(-1, 1, (500, 3)) * a
    k, d = bend_axis(np.array([0.6, -0.8]), a)
    t = np.array([0.5, -0.3])
    assert np.abs(undeform(deform(x, a, t, k, d), a, t, k, d) - x).max() < 1e-12
    assert np.array_equal(deform(x, a, np.zeros(2), np.float64(0.0), np.array([1.0, 0.0])), x)
    # tapering scales the cross-section linearly along z
    tip = taper(np.array([[0.3, 0.4, 1.0]]), a, t)
    assert np.allclose(tip, [[0.3 * 1.5, 0.4 * 0.7, 1.0]])


def test_bending_keeps_the_axis_length_and_turns_its_end_by_the_bend():
    a = np.array([0.2, 0.2, 1.0])
    b = np.array([0.0, 0.9])  # bends toward +y by 0.9 rad over the half-length
    k, d = bend_axis(b, a)
    z = np.linspace(-1, 1, 2001)
    axis = bend(np.stack([0 * z, 0 * z, z], 1), k, d)
    assert np.linalg.norm(np.diff(axis, axis=0), axis=1).sum() == pytest.approx(2.0, rel=1e-5)
    end = axis[-1] - axis[-2]
    assert np.degrees(np.arctan2(end[1], end[2])) == pytest.approx(np.degrees(0.9), abs=0.1)
    assert abs(axis[-1, 0]) < 1e-12 and axis[-1, 1] > 0.3  # in the plane of the bend, toward it
    assert np.abs(unbend(axis, k, d) - np.stack([0 * z, 0 * z, z], 1)).max() < 1e-9


def test_gradients_are_finite_for_an_unbent_untapered_start():
    """The fit starts every part unbent: its gradients must exist there (a bend vector's direction has none)."""
    x = torch.randn(200, 3, dtype=torch.float64)
    scale = torch.tensor([0.3, 0.4, 1.0], dtype=torch.float64)
    beta = torch.zeros((), dtype=torch.float64, requires_grad=True)
    alpha = torch.zeros((), dtype=torch.float64, requires_grad=True)
    t = torch.zeros(2, dtype=torch.float64, requires_grad=True)
    direction = torch.stack([torch.cos(alpha), torch.sin(alpha)])
    out = undeform(x, scale, t, beta / scale[2], direction)
    (out ** 2).sum().backward()
    assert all(torch.isfinite(g).all() for g in (beta.grad, alpha.grad, t.grad))
    assert float(beta.grad.abs()) > 0 and float(t.grad.abs().sum()) > 0


def test_files_round_trip_deformations_and_keep_plain_ones_plain():
    sq = SuperquadricSet(np.array([[0.2, 0.3, 0.6], [0.3, 0.3, 0.3]]), np.array([[0.5, 1.0], [1.0, 1.0]]),
                         np.array([[1.0, 0, 0, 0], [1.0, 0, 0, 0]]), np.array([[0, 0, 0], [1.0, 0, 0]]),
                         taper=np.array([[0.5, -0.2], [0.0, 0.0]]), bend=np.array([[0.3, 0.4], [0.0, 0.0]]))
    strokes = StrokeSet(superquadrics=sq)
    text = fileio.loads(fileio.dumps(strokes)).superquadrics
    assert np.array_equal(text.tapers, sq.tapers) and np.array_equal(text.bends, sq.bends)
    packed = binary.decode(binary.encode(strokes)).superquadrics
    assert np.abs(packed.tapers - sq.tapers).max() < 5e-4 and np.abs(packed.bends - sq.bends).max() < 1e-3
    assert packed.deformed.tolist() == [True, False]  # zero is a code of its own
    plain = binary.encode(StrokeSet(superquadrics=replace(sq, taper=None, bend=None)))
    assert len(binary.encode(strokes)) - len(plain) <= 2 * 4 * 12 // 8 + 1  # 6 bytes each
    assert "taper" not in fileio.dumps(StrokeSet(superquadrics=replace(sq, taper=None, bend=None)))


@pytest.mark.parametrize("field, value, message", [
    ("taper", [1.5, 0.0], "superquadrics[0].taper[0]"),
    ("bend", [1.2, 1.2], "superquadrics[0].bend: bends by"),
    ("bend", [0.1], "superquadrics[0].bend"),
])
def test_out_of_range_deformations_are_one_line_errors(field, value, message):
    doc = fileio.stroke_set_to_dict(StrokeSet(superquadrics=_one([0.3, 0.3, 0.5])))
    doc["superquadrics"][0][field] = value
    with pytest.raises(StrokeFileError, match=message.replace("[", r"\[").replace("]", r"\]")) as err:
        fileio.stroke_set_from_dict(doc)
    assert "\n" not in str(err.value)


def test_the_exported_mesh_lies_on_the_deformed_surface():
    sq = _one([0.2, 0.25, 0.7], (0.4, 1.0), (-0.6, 0.3), (0.5, 0.4), (0.1, 0.0, -0.1))
    verts, faces = superquadric_mesh(sq, 0)
    f = inside_outside(canonical(verts, sq.scale, sq.rotation, sq.translation, deformation_of(sq)), sq.scale,
                       sq.shape)
    assert np.allclose(f, 1.0, atol=1e-6)


def test_the_drawn_outline_is_the_deformed_solids_outline(taper_=(0.4, -0.5), bend_=(-0.5, 0.7)):
    """The contour the exporters draw lies on the boundary of the deformed solid's mask (ray marched in its
    canonical frame), in every view: silhouettes, normals and occlusion agree on one shape."""
    sq = _one([0.22, 0.22, 0.7], (0.5, 1.0), taper_, bend_)
    for cam in CAMS[:6:2]:
        mask = union_mask(sq, cam, samples=96)
        edge = mask ^ ndimage.binary_erosion(mask)
        far = ndimage.distance_transform_edt(~edge)
        pts = np.concatenate([p for _, p, _ in contour_polylines(sq, cam)])
        uv, _ = cam.project(pts)
        u, v = np.clip(uv[:, 0].astype(int), 0, 127), np.clip(uv[:, 1].astype(int), 0, 127)
        assert np.percentile(far[v, u], 95) <= 1.5, cam.name
        # and the outline goes all round it: most of the mask's edge has a contour point near it
        drawn = np.zeros_like(mask)
        drawn[v, u] = True
        assert (edge & ndimage.binary_dilation(drawn, iterations=2)).sum() >= 0.85 * edge.sum()


def test_a_bent_part_hides_what_lies_behind_its_bend_and_not_where_it_bent_away():
    """A tube bent toward +x: a point behind where its upper end went is hidden; a point behind where a
    straight tube's end would be is seen."""
    sq = _one([0.15, 0.15, 0.6], (0.5, 1.0), (0.0, 0.0), (1.0, 0.0))
    top = deform(np.array([[0.0, 0.0, 0.55]]), sq.scale[0], sq.tapers[0], *bend_axis(sq.bends[0], sq.scale[0]))[0]
    cam = orbit_cameras(SceneFrame(radius=1.0, camera=DefaultCamera(elevation_deg=0.0, azimuth_deg=-90.0)), 1)[0]
    behind = lambda p: p + 1.0 * (p - cam.center) / np.linalg.norm(p - cam.center)  # noqa: E731
    points = np.array([behind(top), behind(np.array([0.0, 0.0, 0.55]))])
    hidden = occluded(points, np.zeros(2, int), [cam], sq, 0.0)
    assert hidden.tolist() == [True, False]


def _voxel_grid(n=64):
    vox = 2.0 / n
    g = (np.arange(n) - n / 2 + 0.5) * vox
    return np.array([g[0]] * 3), vox, np.meshgrid(g, g, g, indexing="ij")


def _iou(sq, origin, vox, occupied) -> float:
    ijk = np.argwhere(np.ones(occupied.shape, bool))
    x = canonical(origin + ijk * vox, sq.scale, sq.rotation, sq.translation, deformation_of(sq))
    inside = (inside_outside(x, sq.scale, sq.shape) <= 1).any(axis=0).reshape(occupied.shape)
    return float((inside & occupied).sum() / (inside | occupied).sum())


def test_a_cone_is_one_tapered_superquadric_and_a_ball_stays_plain():
    from doodle.fit.volume.abstraction import abstract_volume

    origin, vox, (X, Y, Z) = _voxel_grid()
    h = (Z + 0.35) / 0.7
    cone = (h >= 0) & (h <= 1) & (np.hypot(X, Y) <= 0.5 * (1 - h))
    # at the abstraction's default steps: at 60 the tapered fit stopped short of the bar with numpy 2.4 / scipy
    # 1.17 (IoU 0.741 against the 0.79 it must reach), where it had passed before
    found = abstract_volume(origin, vox, np.eye(3), cone, max_count=1)
    # the plain fits choose the parts (a plain one leaves the tip to a second, not fitted here); the tapered
    # one alone explains the cone
    first = found.superquadrics
    assert first.deformed.all() and np.abs(first.tapers).max() > 0.5
    assert _iou(first, origin, vox, cone) > 0.85 and _iou(found.plain, origin, vox, cone) < 0.7
    assert found.plain is not None and not found.plain.deformed.any()
    ball = np.sqrt(X ** 2 + Y ** 2 + Z ** 2) <= 0.6
    plain = abstract_volume(origin, vox, np.eye(3), ball)
    assert not plain.superquadrics.deformed.any() and plain.plain is None and plain.iou > 0.95


def test_a_curved_horn_is_bent():
    from doodle.fit.volume.abstraction import abstract_volume

    origin, vox, (X, Y, Z) = _voxel_grid()
    rr, ang = np.hypot(X - 0.45, Z + 0.2), np.arctan2(Z + 0.2, X - 0.45)
    horn = ((rr - 0.45) ** 2 + Y ** 2 <= 0.13 ** 2) & (ang > 0.9) & (ang < 2.7)  # a 100° arc of a tube
    found = abstract_volume(origin, vox, np.eye(3), horn, max_count=1, steps=60)
    first = found.superquadrics
    assert np.linalg.norm(first.bends[0]) > 0.5
    assert _iou(first, origin, vox, horn) > 0.8 > _iou(found.plain, origin, vox, horn) + 0.1


def test_the_judge_keeps_a_deformation_only_where_its_outline_is_better():
    """Part by part: the tapered fit of a cone-shaped object draws it; where the object is the plain solid,
    the plain fit takes the deformed one's place."""
    from doodle.fit.volume.outlines import abstraction_outlines

    cone = _one([0.3, 0.3, 0.6], (0.3, 1.0), (-0.85, -0.85))
    plain = _one([0.28, 0.28, 0.6], (0.3, 1.0))
    cams = CAMS[::2]
    for truth, expect in ((cone, True), (plain, False)):
        masks = [union_mask(truth, c) for c in cams]
        lines = [m ^ ndimage.binary_erosion(m) for m in masks]
        messages = []
        judged = abstraction_outlines(cone, CurveSet(), FRAME, cams, lines, masks, log=messages.append, plain=plain)
        assert judged.deformed.tolist() == [expect], messages
        assert judged.drawn.tolist() == [True]
        assert any(("tapered or bent" if expect else "left plain") in m for m in messages)


def test_a_bent_part_hides_its_own_contour_behind_its_bend():
    """A bent superquadric is not convex: seen along its bend, its far arm's contour runs behind its near arm.
    Those contour points are hidden (by their own superquadric, which hides no contour point of a plain one),
    and each of them projects inside the solid's mask, off its outline."""
    from doodle.exporters.drawing import silhouette_hidden
    from doodle.exporters.silhouettes import contour_samples

    sq = _one([0.12, 0.12, 0.7], (0.5, 1.0), (0.0, 0.0), (1.4, 0.0))
    frame = SceneFrame(radius=1.0, camera=DefaultCamera(distance=4.0, elevation_deg=40.0, width=128, height=128))
    cam = orbit_cameras(frame, 8)[4]
    s = contour_samples(sq, cam)
    hidden = silhouette_hidden(s.points, s.normals, s.owner, np.zeros(len(s.points), int), [cam], sq, 0.01)
    plain = replace(sq, bend=None)
    p = contour_samples(plain, cam)
    assert not silhouette_hidden(p.points, p.normals, p.owner, np.zeros(len(p.points), int), [cam], plain, 0.01).any()
    assert hidden.sum() >= 5
    mask = union_mask(sq, cam, samples=96)
    inner = ndimage.binary_erosion(mask)
    uv, _ = cam.project(s.points[hidden])
    assert inner[uv[:, 1].astype(int), uv[:, 0].astype(int)].all()


def test_a_smooth_deformed_part_or_a_round_one_draws_its_outline_beside_crisp_curves_and_a_boxy_one_does_not():
    """The judge's rule: crisp curves that already draw an outline keep it, unless the superquadric is smooth
    and tapered or bent, or plain and round as an ellipsoid, and its outline is on the lines almost everywhere
    (a spout's or a foot's closed outline beats the open lines along it)."""
    from doodle.fit.volume.outlines import _drawn

    shapes = np.array([[0.8, 1.0], [0.6, 1.0], [1.0, 0.2], [0.8, 1.0], [0.9, 1.0], [0.9, 1.0]])
    taper = np.array([[-0.6, -0.6], [0.0, 0.0], [-0.6, -0.6], [-0.6, -0.6], [0.0, 0.0], [0.0, 0.0]])
    sq = SuperquadricSet(np.full((6, 3), 0.3), shapes, np.tile([1.0, 0, 0, 0], (6, 1)), np.zeros((6, 3)), taper=taper)
    precision = np.array([0.95, 0.95, 0.95, 0.8, 0.95, 0.8])
    on_curves = np.full(6, 0.9)  # the crisp curves draw each one's outline
    assert _drawn(sq, precision, on_curves).tolist() == [True, False, False, False, True, False]
    assert _drawn(sq, precision, np.zeros(6)).tolist() == [True] * 6


def test_a_checkpoint_keeps_tapers_and_bends_and_reads_one_from_before_them():
    from doodle.fit.state import _superquadrics, _unsuperquadrics

    sq = _one([0.2, 0.25, 0.7], (0.4, 1.0), (-0.6, 0.3), (0.5, 0.4))
    back = _unsuperquadrics(_superquadrics(sq))
    assert np.array_equal(back.tapers, sq.tapers) and np.array_equal(back.bends, sq.bends)
    old = _unsuperquadrics(_superquadrics(sq)[:6])  # written before tapering and bending
    assert not old.deformed.any() and np.array_equal(old.scale, sq.scale)


def test_a_bent_parts_box_holds_it_closely_and_a_camera_beside_it_may_draw():
    """The strokes' box holds a tapered, bent part's surface within a few percent, where its bending sphere
    reaches three times as far: a DTU skull's training camera 3.4 from the centre was taken as "inside the
    object" at the end of a fit from its automatic masks."""
    sq = _one([0.12, 0.1, 0.6], (0.6, 0.9), (0.5, 0.5), (1.2, 0.3))
    sq = replace(sq, rotation=np.array([[0.9, 0.2, -0.3, 0.1]]))
    strokes = StrokeSet(FRAME, CurveSet(), sq)
    lo, hi = strokes.bounding_box()
    verts, _ = superquadric_mesh(sq, 0)
    assert np.all(verts >= lo) and np.all(verts <= hi)
    extent = verts.max(axis=0) - verts.min(axis=0)
    assert np.all((hi - lo) <= extent + 0.05 * np.linalg.norm(sq.scale)), (hi - lo, extent)
    reach = float(bounding_radius(sq)[0])
    near = orbit_cameras(SceneFrame(radius=0.3, camera=DefaultCamera(distance=0.6 * reach, width=64, height=64)), 4)
    for cam in near:  # within the bending sphere, outside the part's box
        check_camera(strokes, cam)
    inside = orbit_cameras(SceneFrame(radius=1.0, camera=DefaultCamera(distance=0.01, width=64, height=64)), 1)[0]
    with pytest.raises(DoodleError, match="inside the object"):
        check_camera(strokes, inside)
