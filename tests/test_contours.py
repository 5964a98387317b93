"""Contour curves (``doodle.fit.discovery.rims``): the outline of smooth parts, traced in the training views and drawn
only from the views that graze them."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy import ndimage

from doodle.cameras import orbit_cameras
from doodle.exporters import DrawOptions, draw, union_mask
from doodle.exporters.drawing import occlusion_probes, off_contour
from doodle.fit.discovery.discover import stroke_coverage
from doodle.fit.discovery.evidence import Evidence, depth_maps
from doodle.fit.volume.carve import carve_hull
from doodle.fit.discovery.rims import find_rims
from doodle.scenes import Scene
from doodle.strokes import CurveSet, SceneFrame, StrokeSet, SuperquadricSet, dumps, loads
from doodle.strokes.bezier import bezier_points
from doodle.strokes.binary import decode, encode
from doodle.strokes.model import DefaultCamera

R = 0.6  # the ball's radius
FRAME = SceneFrame(radius=1.0, camera=DefaultCamera(distance=4.0, elevation_deg=20.0, width=128, height=128))


def _ball() -> SuperquadricSet:
    return SuperquadricSet(np.full((1, 3), R), np.ones((1, 2)), np.array([[1.0, 0, 0, 0]]), np.zeros((1, 3)))


def _cameras(views: int, elevations=(10.0, 35.0, 60.0)):
    return [c for e in elevations for c in orbit_cameras(FRAME, views, elevation_deg=e)]


@pytest.fixture(scope="module")
def ball_rims():
    cams = _cameras(12)
    masks = [union_mask(_ball(), c) for c in cams]
    scene = Scene(cams, [np.full((c.height, c.width, 3), 255, np.uint8) for c in cams], FRAME, masks)
    grid, occupied = carve_hull(scene, 96)
    rims = find_rims(cams, masks, grid, occupied, FRAME.center, FRAME.radius, 0.05, 2 * grid.voxel)
    return cams, masks, grid, occupied, rims


def _circle(radius: float, pieces: int = 8) -> np.ndarray:
    """The circle of ``radius`` about the z axis as ``pieces`` cubics ``(pieces, 4, 3)``."""
    a = np.linspace(0, 2 * np.pi, pieces + 1)
    k = 4 / 3 * np.tan(np.pi / (2 * pieces)) * radius  # the arc's handle length
    out = []
    for a0, a1 in zip(a[:-1], a[1:]):
        p0, p3 = radius * np.array([np.cos(a0), np.sin(a0), 0]), radius * np.array([np.cos(a1), np.sin(a1), 0])
        t0, t1 = np.array([-np.sin(a0), np.cos(a0), 0]), np.array([-np.sin(a1), np.cos(a1), 0])
        out.append([p0, p0 + k * t0, p3 - k * t1, p3])
    return np.array(out)


def _samples(rims, t=np.linspace(0, 1, 9)):
    pts = bezier_points(rims.controls, t)  # (N, T, 3)
    n = (1 - t)[None, :, None] * rims.normals[:, None, 0] + t[None, :, None] * rims.normals[:, None, 1]
    return pts, n / np.linalg.norm(n, axis=2, keepdims=True)


def test_a_balls_contour_curves_lie_on_its_contour_generators(ball_rims):
    """Each view's outline, back-projected through the carved hull, lands on the ball where that view's rays
    graze it, and carries the ball's surface normal there."""
    cams, _, grid, _, rims = ball_rims
    assert len(rims.controls) >= len(cams)  # at least one piece of outline a view
    pts, n = _samples(rims)
    radial = np.linalg.norm(pts, axis=2)
    assert np.abs(radial - R).max() < 2.0 * grid.voxel  # on the sphere (the hull is a voxel or so wider)
    assert np.median(np.abs(radial - R)) < 0.75 * grid.voxel
    assert np.einsum("ntk,ntk->nt", n, pts / radial[..., None]).min() > 0.97  # the outward normal
    eyes = np.array([cams[v].center for v in rims.view])[:, None, :]
    ray = (pts - eyes) / np.linalg.norm(pts - eyes, axis=2, keepdims=True)
    assert np.abs(np.einsum("ntk,ntk->nt", n, ray)).max() < 0.1  # grazed by its own view's rays


def test_a_neighbouring_views_contour_draws_this_views_outline(ball_rims):
    """Drawn from a view between the training views, the contour curves whose gate lets them through lie on
    that view's outline — and only its outline is drawn."""
    cams, _, _, _, rims = ball_rims
    normals = np.repeat(rims.normals[:, :, None], 2, axis=2)
    curves = CurveSet(rims.controls, 1.5, normals, np.full(len(rims.controls), 0.2))
    between = orbit_cameras(replace(FRAME, camera=replace(FRAME.camera, azimuth_deg=15.0)), 12, elevation_deg=25.0)[0]
    d = draw(StrokeSet(FRAME, curves), between, DrawOptions(tolerance=0.25))
    assert not d.layer("curves") and d.layer("silhouettes")  # contour curves are outline
    assert all(op.id.startswith("contour-") for op in d.layer("silhouettes"))
    ink = np.concatenate([op.points() for op in d.layer("silhouettes")])
    mask = union_mask(_ball(), between)
    outline = mask ^ ndimage.binary_erosion(mask)
    to_outline = ndimage.distance_transform_edt(~outline)
    px = np.clip(np.floor(ink).astype(int), 0, 127)
    assert np.quantile(to_outline[px[:, 1], px[:, 0]], 0.95) <= 1.5  # on this view's outline
    drawn = np.zeros_like(mask)
    drawn[px[:, 1], px[:, 0]] = True
    assert (ndimage.distance_transform_edt(~drawn)[outline] <= 2).mean() > 0.9  # and all round it


def test_a_contour_curve_is_drawn_only_where_the_view_grazes_it():
    """The ball's equator with radial normals is the whole outline seen from above, and from an oblique view
    only near the two points where it touches that view's outline."""
    controls = _circle(R)
    radial = controls[:, [0, 3]] / R
    normals = np.repeat(radial[:, :, None], 2, axis=2)
    curves = CurveSet(controls, 1.5, normals, np.full(len(controls), 0.2))
    top = orbit_cameras(FRAME, 1, elevation_deg=89.0)[0]
    side = orbit_cameras(FRAME, 1, elevation_deg=45.0)[0]
    s = StrokeSet(FRAME, curves)
    length = lambda d: sum(float(np.linalg.norm(np.diff(op.points(), axis=0), axis=1).sum()) for op in d.paths)  # noqa: E731
    full = length(draw(s, top, DrawOptions(tolerance=0.25)))
    oblique = length(draw(s, side, DrawOptions(tolerance=0.25)))
    assert full > 0.97 * 2 * np.pi * R * top.fx / FRAME.camera.distance  # the whole ring
    assert 0.02 * full < oblique < 0.25 * full  # two short arcs
    # hidden-line modes do not bring the rest back: off the outline a contour curve is no line at all
    assert length(draw(s, side, DrawOptions(tolerance=0.25, hidden="dash"))) == pytest.approx(oblique, rel=0.05)
    feature = replace(curves, contour=np.zeros(len(controls)))
    assert length(draw(replace(s, curves=feature), side, DrawOptions(tolerance=0.25, hidden="show"))) > 0.5 * full


def test_off_contour_and_occlusion_probes():
    p = np.array([[1.0, 0, 0], [1.0, 0, 0]])
    n = np.zeros((2, 2, 2, 3))
    n[:, :, :] = [1.0, 0, 0]
    eye_side = np.array([[1.0, -5, 0], [1.0, -5, 0]])  # rays graze the point (normal ⟂ ray)
    eye_front = np.array([[6.0, 0, 0], [6.0, 0, 0]])  # rays hit it head on
    fwd = np.zeros((2, 3))
    ortho = np.zeros(2, bool)
    gates = np.array([0.2, 0.0])  # a contour curve and a feature curve
    assert off_contour(p, np.zeros(2), n, gates, eye_side, fwd, ortho).tolist() == [False, False]
    assert off_contour(p, np.zeros(2), n, gates, eye_front, fwd, ortho).tolist() == [True, False]
    probes = occlusion_probes(p, np.zeros(2), n, 0.05)
    assert np.allclose(probes, [[1.05, 0, 0], [1.05, 0, 0]])  # tested a margin out along the normal
    assert np.allclose(occlusion_probes(p, np.zeros(2), np.zeros((2, 2, 2, 3)), 0.05), p)  # no normal: in place


def test_a_contour_curve_on_a_slightly_fat_occluder_is_still_drawn(ball_rims):
    """An occluder a little wider than the part it stands for must not hide the part's outline, which its
    rays graze; a second ball in front still hides it."""
    cams, _, _, _, rims = ball_rims
    normals = np.repeat(rims.normals[:, :, None], 2, axis=2)
    s = StrokeSet(FRAME, CurveSet(rims.controls, 1.5, normals, np.full(len(rims.controls), 0.2)),
                  replace(_ball(), scale=np.full((1, 3), R * 1.01), outline=np.zeros(1, bool)))
    cam = cams[1]
    drawn = sum(len(op.points()) for op in draw(s, cam).layer("silhouettes"))
    alone = sum(len(op.points()) for op in draw(replace(s, superquadrics=SuperquadricSet()), cam).layer("silhouettes"))
    assert drawn > 0.9 * alone
    eye = cam.center
    blocker = SuperquadricSet(np.full((1, 3), 0.9), np.ones((1, 2)), np.array([[1.0, 0, 0, 0]]),
                              (0.5 * eye / np.linalg.norm(eye) * 2.0)[None], outline=np.zeros(1, bool))
    hidden = sum(len(op.points()) for op in draw(replace(s, superquadrics=blocker), cam).layer("silhouettes"))
    assert hidden < 0.3 * alone


def test_contour_gates_survive_both_file_encodings(ball_rims):
    rims = ball_rims[4]
    k = min(len(rims.controls), 5)
    normals = np.repeat(rims.normals[:k, :, None], 2, axis=2)
    gates = np.r_[0.0, np.full(k - 1, 0.2)]
    s = StrokeSet(FRAME, CurveSet(rims.controls[:k], 1.5, normals, gates))
    back = loads(dumps(s))
    assert np.allclose(back.curves.gates, gates)
    binary = decode(encode(s))
    assert np.allclose(binary.curves.gates, gates, atol=1 / 255)
    plain = StrokeSet(FRAME, CurveSet(rims.controls[:k], 1.5, normals))
    assert '"contour"' not in dumps(plain) and decode(encode(plain)).curves.contour is None


@pytest.mark.parametrize("edit, message", [
    (lambda c: c.__setitem__("contour", [0.2]), "one number per curve"),
    (lambda c: c.__setitem__("contour", ["x"] * len(c["control_points"])), "expected a number"),
    (lambda c: c.__setitem__("contour", [1.5] * len(c["control_points"])), r"contour\[0\]: 1.5 outside"),
    (lambda c: (c.pop("normals"), c.__setitem__("contour", [0.2] * len(c["control_points"]))), "need curves.normals"),
])
def test_bad_contour_gates_are_refused_with_the_field_named(ball_rims, edit, message):
    import json

    from doodle.errors import StrokeFileError

    rims = ball_rims[4]
    normals = np.repeat(rims.normals[:3, :, None], 2, axis=2)
    doc = json.loads(dumps(StrokeSet(FRAME, CurveSet(rims.controls[:3], 1.5, normals, np.full(3, 0.2)))))
    edit(doc["curves"])
    with pytest.raises(StrokeFileError, match=message):
        loads(json.dumps(doc))


def test_a_contour_curve_is_not_counted_in_its_own_view(ball_rims):
    """The choice judges a contour curve in the views other than the one it was traced in: there it lies on
    the outline by construction."""
    cams, masks, grid, occupied, rims = ball_rims
    lines = [m ^ ndimage.binary_erosion(m) for m in masks]
    ev = Evidence(grid, np.zeros(occupied.shape, np.float32), occupied, np.zeros(occupied.shape, np.int16), cams,
                  lines, depth_maps(grid, occupied, cams), 6 * grid.voxel)
    mine = rims.view == 0
    gates, normals, source = np.full(mine.sum(), 0.3), rims.normals[mine], rims.view[mine]
    own, _, _ = stroke_coverage(rims.controls[mine], ev, [0], gates=gates, contour_normals=normals)
    loo, _, ink = stroke_coverage(rims.controls[mine], ev, [0], gates=gates, contour_normals=normals, source=source)
    outline = int(lines[0].sum())
    assert sum(len(c) for c in own) > 0.9 * outline  # its own view's whole outline
    assert sum(len(c) for c in loo) == 0 and not ink.any()


# The occluder volume: the visual hull on a coarse grid, hiding what lies behind the object's bulk.

def _box_occluder(lo, hi, voxel=0.05) -> "Voxels":
    from doodle.strokes.model import Voxels

    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    shape = tuple(int(v) for v in np.ceil((hi - lo) / voxel) + 1)
    return Voxels(lo, voxel, np.eye(3), np.ones(shape, bool))


def test_an_occluder_volume_hides_what_is_behind_it_and_not_its_own_surface():
    """A box's back edge is hidden behind the box's volume; its front edge, lying on the volume's surface,
    is not; a wire through the middle of a thin slab is not hidden by the slab it lies in."""
    cam = orbit_cameras(FRAME, 1, elevation_deg=0.0)[0]
    toward = cam.center / np.linalg.norm(cam.center)
    assert np.isclose(np.abs(toward).max(), 1.0)  # along a world axis (view 0: azimuth 0, elevation 0)
    box = _box_occluder([-0.4, -0.4, -0.4], [0.4, 0.4, 0.4])
    front_face = 0.4 * toward
    back_face = -0.4 * toward
    edge = lambda c: np.array([c + [0, 0, -0.3], c + [0, 0, -0.1], c + [0, 0, 0.1], c + [0, 0, 0.3]])  # noqa: E731
    normals = np.zeros((2, 2, 2, 3))
    normals[0] = toward  # the front edge's faces look at the camera
    normals[1] = -toward
    s = StrokeSet(FRAME, CurveSet(np.stack([edge(front_face), edge(back_face)]), 1.5, normals), occluder=box)
    d = draw(s, cam)
    assert [op.id for op in d.layer("curves")] == ["curve-000"]
    assert [op.id for op in draw(s, cam, DrawOptions(hidden="dash")).layer("hidden")] == ["hidden-curve-001"]
    assert len(draw(s, cam, DrawOptions(hidden="show")).layer("curves")) == 2
    thin = np.where(np.abs(toward) > 0.5, 0.02, 0.4)  # a slab facing the camera, thinner than the slack
    slab = _box_occluder(-thin, thin)
    wire = StrokeSet(FRAME, CurveSet(edge(np.zeros(3))[None]), occluder=slab)
    assert [op.id for op in draw(wire, cam).layer("curves")] == ["curve-000"]


def test_the_volume_blocks_exactly_the_segments_that_cross_it():
    from doodle.exporters.visibility import volume_blocked

    box = _box_occluder([0, 0, 0], [1, 1, 1], voxel=0.1)
    o = np.array([[-1.0, 0.5, 0.5], [-1.0, 0.5, 0.5], [-1.0, 2.0, 0.5], [0.5, 0.5, 0.5]])
    e = np.array([[2.0, 0.5, 0.5], [-0.2, 0.5, 0.5], [2.0, 2.0, 0.5], [0.5, 0.5, 3.0]])
    assert volume_blocked(o, e, box).tolist() == [True, False, False, True]


def test_occluder_volumes_survive_both_file_encodings_and_bad_ones_are_refused():
    import json

    from doodle.errors import StrokeFileError
    from doodle.strokes.model import Voxels

    rng = np.random.default_rng(0)
    occ = Voxels(np.array([0.1, -0.2, 0.3]), 0.04, np.array([[0, 1.0, 0], [-1.0, 0, 0], [0, 0, 1.0]]),
                   rng.random((7, 5, 9)) > 0.5)
    s = StrokeSet(FRAME, occluder=occ)
    for back in (loads(dumps(s)), decode(encode(s))):
        assert np.array_equal(back.occluder.occupied, occ.occupied)
        assert np.allclose(back.occluder.axes, occ.axes) and np.allclose(back.occluder.origin, occ.origin)
        assert back.occluder.voxel == pytest.approx(occ.voxel)
    doc = json.loads(dumps(s))
    for edit, message in [
        (lambda o: o.__setitem__("shape", [7, 5, 10]), "expected 44 bytes"),
        (lambda o: o.__setitem__("shape", [7, 5, 1000]), r"occluder.shape\[2\]"),
        (lambda o: o.__setitem__("bits", "not base64!"), "not base64"),
        (lambda o: o.__setitem__("axes", [[1, 0, 0], [1, 0, 0], [0, 0, 1]]), "orthonormal"),
        (lambda o: o.__setitem__("voxel", 0), "occluder.voxel"),
        (lambda o: o.pop("origin"), "occluder.origin: missing"),
    ]:
        bad = json.loads(json.dumps(doc))
        edit(bad["occluder"])
        with pytest.raises(StrokeFileError, match=message):
            loads(json.dumps(bad))


def test_an_outline_reach_explains_an_outline_a_few_pixels_off(ball_rims):
    """Automatic masks are a pixel or two off, differently in each photo: with an outline reach of ``r`` a
    stroke explains the outline pixels within ``r + 0.5`` px of it, while other lines (and the 1-px reach) must
    lie within its 3 × 3 neighbourhood. Here the view's outline is moved 3 px out (the mask grown), and the
    view's own contour curves are judged against it."""
    cams, masks, grid, occupied, rims = ball_rims
    grown = [ndimage.distance_transform_edt(~m) <= 3.0 for m in masks]
    lines = [g ^ ndimage.binary_erosion(g) for g in grown]
    ev = Evidence(grid, np.zeros(occupied.shape, np.float32), occupied, np.zeros(occupied.shape, np.int16), cams,
                  lines, depth_maps(grid, occupied, cams), 6 * grid.voxel)
    mine = rims.view == 0
    args = dict(gates=np.full(mine.sum(), 0.3), contour_normals=rims.normals[mine])
    near, off_near, ink = stroke_coverage(rims.controls[mine], ev, [0], **args)
    wide, off_wide, _ = stroke_coverage(rims.controls[mine], ev, [0], outlines={0: lines[0]}, outline_reach=3, **args)
    outline = int(lines[0].sum())
    assert len(np.unique(np.concatenate(near))) < 0.5 * outline
    assert len(np.unique(np.concatenate(wide))) > 0.95 * outline
    assert off_near.sum() > 0.3 * ink.sum() and off_wide.sum() < 0.02 * ink.sum()


def test_skipping_empty_space_gives_the_answer_of_testing_every_half_voxel():
    from doodle.arrays import nearest_voxels
    from doodle.exporters.visibility import SAMPLES_PER_VOXEL, _slab, volume_blocked
    from doodle.strokes.model import Voxels

    rng = np.random.default_rng(5)
    # scattered blobs with holes and thin walls: segments graze, pass beside and cross them
    occupied = ndimage.binary_dilation(rng.random((24, 20, 16)) > 0.995, iterations=2)
    occupied[5:18, 10, 3:12] = True
    axes = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    vol = Voxels(np.array([-1.0, -0.8, -0.6]), 0.08, axes, occupied)
    ends = rng.uniform(-2, np.array(occupied.shape) + 1, size=(3000, 3))  # in voxels, some outside the grid
    e = vol.origin + ends * vol.voxel @ axes
    o = e + rng.normal(size=(3000, 3)) * 3.0
    fast = volume_blocked(o, e, vol)
    # every sample, each segment's own: n evenly spaced, at most half a voxel apart, over the grid's padded box
    a, b = vol.coordinates(o), vol.coordinates(e)
    half = (np.array(occupied.shape) + 1) / 2
    t_in, t_out = (np.clip(t, 0, 1) for t in _slab(a - (np.array(occupied.shape) - 1) / 2, b - a, half))
    padded = np.pad(occupied, 1)
    brute = np.zeros(len(o), bool)
    for k in np.flatnonzero(t_out > t_in):
        n = int(np.ceil((t_out[k] - t_in[k]) * np.linalg.norm(b[k] - a[k]) * SAMPLES_PER_VOXEL)) + 1
        t = t_in[k] + (t_out[k] - t_in[k]) * np.arange(n) / max(n - 1, 1)
        brute[k] = nearest_voxels(padded, a[k] + t[:, None] * (b[k] - a[k])).any()
    assert 0.2 < fast.mean() < 0.8, fast.mean()
    assert (fast == brute).all()


def test_the_contour_march_finds_where_each_ray_first_enters_the_hull_as_stepping_every_voxel_does():
    from doodle.arrays import first_occupied, free_space, nearest_voxels

    rng = np.random.default_rng(11)
    occupied = ndimage.binary_dilation(rng.random((30, 26, 22)) > 0.997, iterations=3)
    occupied[4:25, 12, 5:9] = True  # a thin wall, grazed by some rays
    free = free_space(occupied)
    # rays in voxel coordinates (float32, as the contour code marches them), unit voxels per unit distance
    c0 = rng.uniform(-15, 45, size=(2000, 3)).astype(np.float32)
    target = rng.uniform(0, 30, size=(2000, 3))
    cd = (target - c0) / np.linalg.norm(target - c0, axis=1, keepdims=True)
    cd = cd.astype(np.float32)
    coarse = np.arange(0.0, 90.0, 1.0).astype(np.float32)
    first = first_occupied(free, lambda rows, j: c0[rows] + coarse[j][:, None] * cd[rows], np.abs(cd).max(axis=1),
                           np.full(len(c0), len(coarse)))
    inside = nearest_voxels(np.pad(occupied, 1), c0[:, None, :] + coarse[None, :, None] * cd[:, None, :])
    brute = np.where(inside.any(axis=1), np.argmax(inside, axis=1), -1)
    assert 0.2 < (brute >= 0).mean() < 0.9, (brute >= 0).mean()
    assert (first == brute).all()


def test_no_contour_is_traced_along_the_frame_that_cuts_the_object():
    """Where the object runs out of the photo, the mask's edge is the frame's: no ray of the outline is cast
    there (the release before cast a row of them, which made contour curves along the frame)."""
    from doodle.fit.discovery.rims import _boundary_rays

    cam = _cameras(1)[0]
    mask = np.zeros((cam.height, cam.width), bool)
    mask[cam.height // 2:, cam.width // 4: 3 * cam.width // 4] = True  # out of the bottom of the frame
    rays = _boundary_rays(cam, mask)
    xy = np.concatenate([r[0] for r in rays])
    assert xy[:, 1].min() < cam.height / 2 + 1  # the top edge is traced
    assert (xy[:, 1] > cam.height - 1.5).sum() <= 4  # the frame's edge is not (only the sides' ends reach it)
