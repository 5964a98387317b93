"""The hull's outline (``doodle.exporters.outline``): the silhouette a stroke set's ``hull`` casts in a view."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from doodle.cameras import Camera
from doodle.cameras.camera import look_at
from doodle.errors import StrokeFileError
from doodle.exporters import DrawOptions, draw, draw_many
from doodle.exporters.outline import outline_polylines
from doodle.strokes import CurveSet, StrokeSet, dumps, loads
from doodle.strokes.binary import decode, encode
from doodle.strokes.model import SceneFrame, Voxels


def _camera(eye, size=256, f=300.0) -> Camera:
    R, t = look_at(np.asarray(eye, float), np.zeros(3), np.array([0.0, 0.0, 1.0]))
    return Camera(f, f, size / 2, size / 2, size, size, R, t)


def _volume(inside, voxel: float, half: float = 1.0, axes=np.eye(3)) -> Voxels:
    """The voxels of a grid over ``[-half, half]³`` (turned by ``axes``) whose centres ``inside`` accepts."""
    n = int(round(2 * half / voxel))
    origin = np.full(3, -half + 0.5 * voxel) @ axes
    ijk = np.stack(np.meshgrid(*[np.arange(n)] * 3, indexing="ij"), -1).reshape(-1, 3)
    centres = origin + (ijk * voxel) @ axes
    return Voxels(origin, voxel, axes, inside(centres).reshape(n, n, n))


def _ball(radius=0.6, voxel=0.02, axes=np.eye(3)) -> Voxels:
    return _volume(lambda p: np.linalg.norm(p, axis=1) <= radius, voxel, axes=axes)


def _ball_outline_radius(cam: Camera, radius: float) -> float:
    d = np.linalg.norm(cam.center)
    return cam.fx * radius / np.sqrt(d**2 - radius**2)


@pytest.mark.parametrize("turned", [False, True])
def test_a_voxelised_balls_outline_is_its_circle_within_half_a_voxel(turned):
    axes = np.eye(3)
    if turned:  # a grid that turns with the object (the fit's are turned about the up axis)
        a = np.radians(30)
        axes = np.array([[np.cos(a), np.sin(a), 0], [-np.sin(a), np.cos(a), 0], [0, 0, 1.0]])
    hull = _ball(axes=axes)
    for eye in ([3.0, 0.0, 0.0], [1.5, 1.5, 2.0], [0.0, -2.2, 1.6]):
        cam = _camera(eye)
        [(polys, foot)] = outline_polylines(hull, [cam])
        assert len(polys) == 1 and np.allclose(polys[0][0], polys[0][-1])  # one closed loop
        pts = polys[0]
        r = np.linalg.norm(pts - [cam.cx, cam.cy], axis=1)
        assert np.abs(r - _ball_outline_radius(cam, 0.6)).max() < 0.5 * foot
        angles = np.sort(np.arctan2(pts[:, 1] - cam.cy, pts[:, 0] - cam.cx))
        assert np.diff(np.r_[angles, angles[0] + 2 * np.pi]).max() < 0.1  # all the way round


def test_a_ring_has_an_outer_and_an_inner_outline_and_an_orthographic_view_sees_them_too():
    ring = _volume(lambda p: (np.hypot(np.hypot(p[:, 0], p[:, 1]) - 0.5, p[:, 2]) <= 0.15), 0.02)
    top = _camera([0.0, 0.01, 3.0])
    [(polys, foot)] = outline_polylines(ring, [top])
    radii = sorted(np.linalg.norm(p - [top.cx, top.cy], axis=1).mean() for p in polys)
    assert len(polys) == 2
    d = 3.0 - 0.15  # the ring's top face is nearest the camera
    assert radii[0] == pytest.approx(top.fx * 0.35 / d, abs=foot) and radii[1] == pytest.approx(top.fx * 0.65 / (3.0 - 0.0), abs=2 * foot)
    ortho = Camera(100.0, 100.0, 128, 128, 256, 256, top.R, top.t, projection="orthographic")
    [(polys, foot)] = outline_polylines(ring, [ortho])
    assert foot == pytest.approx(100.0 * 0.02)
    radii = sorted(np.linalg.norm(p - [128, 128], axis=1).mean() for p in polys)
    assert radii == pytest.approx([35.0, 65.0], abs=foot)


def test_a_camera_among_the_voxels_or_seeing_none_of_them_gets_no_outline():
    hull = _ball()
    inside = _camera([0.1, 0.0, 0.0])
    away = Camera(300.0, 300.0, 128, 128, 256, 256, *look_at(np.array([3.0, 0, 0]), np.array([6.0, 0, 0]), np.array([0, 0, 1.0])))
    empty = Voxels(np.zeros(3), 0.1, np.eye(3), np.zeros((4, 4, 4), bool))
    assert outline_polylines(hull, [inside, away]) == [([], 0.0), ([], 0.0)]
    assert outline_polylines(empty, [_camera([3.0, 0, 0])]) == [([], 0.0)]
    [(polys, foot)] = outline_polylines(hull, [_camera([3.0, 0, 0])])
    assert len(polys) == 1 and foot == pytest.approx(300 * 0.02 / (3.0 - 0.62), rel=0.05)  # the nearest voxel's image


def _outline_points(drawing) -> np.ndarray:
    ops = [op for op in drawing.paths if op.id == "outline"]
    return np.concatenate([op.points() for op in ops]) if ops else np.zeros((0, 2))


def test_the_outline_is_drawn_in_the_silhouettes_layer_and_gives_way_to_a_curve_along_it():
    box = _volume(lambda p: np.all(np.abs(p) <= [0.5, 0.3, 0.2], axis=1), 0.02)
    cam = _camera([3.0, 0.3, 0.0])
    frame = SceneFrame(np.array([0, 0, 1.0]), np.zeros(3), 0.7)
    alone = draw(StrokeSet(frame, CurveSet(), hull=box), cam, DrawOptions(min_mark=0))
    [op] = alone.paths
    assert (op.id, op.layer) == ("outline", "silhouettes") and all(op.closed)
    # the box's top front edge, on the outline from this side and a little above it
    edge = np.array([[[0.5, -0.3, 0.2], [0.5, -0.1, 0.2], [0.5, 0.1, 0.2], [0.5, 0.3, 0.2]]])
    both = draw(StrokeSet(frame, CurveSet(edge), hull=box), cam, DrawOptions(min_mark=0))
    curve = np.concatenate([op.points() for op in both.layer("curves")])
    outline = _outline_points(both)
    from scipy.spatial import cKDTree

    near = cKDTree(curve).query(outline)[0]
    assert near.min() > 1.5  # where the curve draws it, the outline is not drawn twice
    # ... and everywhere else it is: every point of the outline alone is near the curve or the outline left
    rest = cKDTree(np.concatenate([curve, outline])).query(_outline_points(alone))[0]
    assert rest.max() < 3.0
    assert not any(op.closed[0] for op in both.paths if op.id == "outline")  # the loop is cut where the curve is


def test_options_leave_the_outline_out():
    hull = _ball()
    s = StrokeSet(SceneFrame(np.array([0, 0, 1.0]), np.zeros(3), 0.7), CurveSet(), hull=hull)
    cams = [_camera([3.0, 0.0, 0.0]), _camera([0.0, 3.0, 1.0])]
    assert all(d.paths for d in draw_many(s, cams))
    assert not any(d.paths for d in draw_many(s, cams, DrawOptions(outline=False)))
    assert not any(d.paths for d in draw_many(s, cams, DrawOptions(silhouettes=False)))


def test_a_hull_survives_both_file_encodings_and_binary_version_3_is_read():
    rng = np.random.default_rng(0)
    frame = SceneFrame(np.array([0, 0, 1.0]), np.zeros(3), 1.0)
    curves = CurveSet(rng.uniform(-0.5, 0.5, (3, 4, 3)), normals=np.zeros((3, 2, 2, 3)))
    small = Voxels(np.array([-0.5, -0.5, -0.5]), 0.1, np.eye(3), rng.random((10, 10, 10)) > 0.5)
    noisy = Voxels(np.array([-0.5, -0.5, -0.5]), 0.01, np.eye(3), rng.random((100, 100, 100)) > 0.5)  # 125 kB packed
    for hull in (small, noisy):
        s = StrokeSet(frame, curves, hull=hull)
        back = loads(dumps(s))
        assert np.array_equal(back.hull.occupied, hull.occupied) and back.occluder is None
        data = encode(s)
        assert data[4] == 5 and data[8 + 68 + 42] & 32  # volumes: raw bits in an xz trailer
        # version 3 (the volumes' JSON objects, base64 bits, in a zlib trailer), as that release wrote `small`
        old = decode((Path(__file__).parent / "data" / "binary-v3.doodleb").read_bytes())
        for again in (decode(data), old) if hull is small else (decode(data),):
            assert np.array_equal(again.hull.occupied, hull.occupied) and again.hull.voxel == pytest.approx(hull.voxel)
            assert again.occluder is None and len(again.curves) == 3
    good = json.loads(dumps(StrokeSet(frame, curves, hull=small)))
    for change, message in ((dict(bits="@" + good["hull"]["bits"]), "hull.bits: not base64"),
                            (dict(shape=[10, 10, 9]), "hull.bits: expected 113 bytes for a 10×10×9 grid"),
                            (dict(axes=[[1, 0, 0], [1, 0, 0], [0, 0, 1]]), "hull.axes: expected orthonormal rows")):
        with pytest.raises(StrokeFileError, match=message):
            loads(json.dumps({**good, "hull": {**good["hull"], **change}}))


def test_where_the_hull_runs_out_of_the_view_its_outline_stops_at_the_frame():
    """A view whose frame cuts the ball (the principal point moved so that its lower part lies below the
    photo): the outline is the visible arc alone, open at the frame, and no line runs along the frame's edge
    (the release before drew one there, a ruler line under the object)."""
    hull = _ball()
    eye = np.array([3.0, 0.0, 0.0])
    R, t = look_at(eye, np.zeros(3), np.array([0.0, 0.0, 1.0]))
    cam = Camera(300.0, 300.0, 128.0, 100.0, 256, 128, R, t)  # the ball's centre 28 px above the bottom edge
    [(polys, foot)] = outline_polylines(hull, [cam])
    pts = np.concatenate(polys)
    assert len(polys) == 1 and not np.allclose(polys[0][0], polys[0][-1])  # one open arc
    r = np.linalg.norm(pts - [cam.cx, cam.cy], axis=1)
    assert np.abs(r - _ball_outline_radius(cam, 0.6)).max() < 0.5 * foot  # every point on the circle
    # nothing along the edge: the arc's two ends meet it (the ball's circle crosses it at ±54 px)
    assert pts[:, 1].max() <= cam.height and (pts[:, 1] > cam.height - 1.5).sum() <= 4
