
import numpy as np
import pytest
import torch

from doodle.cameras import Camera, azimuth_elevation, look_at, orbit_cameras, project_points
from doodle.strokes import SceneFrame


class TestProjection:
    def test_perspective_exact(self):
        uv, z = project_points(np.array([[1.0, -1.0, 4.0]]), np.eye(3), np.zeros(3), np.array([200.0, 100, 64, 48]))
        assert np.allclose(uv, [[64 + 50, 48 - 25]]) and np.allclose(z, [4.0])

    def test_orthographic_ignores_depth(self):
        K = np.array([10.0, 10, 0, 0])
        a, _ = project_points(np.array([[1.0, 2, 3]]), np.eye(3), np.zeros(3), K, orthographic=True)
        b, _ = project_points(np.array([[1.0, 2, 30]]), np.eye(3), np.zeros(3), K, orthographic=True)
        assert np.allclose(a, b) and np.allclose(a, [[10, 20]])

    def test_torch_and_numpy_agree_and_differentiate(self):
        cam = orbit_cameras(SceneFrame(), 3)[1]
        p = np.random.default_rng(0).normal(size=(5, 3)) * 0.3
        uv_np, _ = cam.project(p)
        pt = torch.tensor(p, requires_grad=True)
        uv_t, _ = cam.project(pt)
        uv_t.sum().backward()
        assert np.allclose(uv_t.detach().numpy(), uv_np) and torch.isfinite(pt.grad).all()

    def test_rays_pass_through_projected_pixels(self):
        cam = orbit_cameras(SceneFrame(), 1, width=64, height=48)[0]
        o, d = cam.rays()
        p = o[10, 20] + 3.0 * d[10, 20]
        uv, _ = cam.project(p[None])
        assert np.allclose(uv[0], [20.5, 10.5], atol=1e-9)


class TestLookAtAndOrbit:
    def test_up_is_up_in_the_image(self):
        R, t = look_at(np.array([4.0, 0, 1]), np.zeros(3), np.array([0, 0, 1.0]))
        cam = Camera(100, 100, 50, 50, 100, 100, R, t)
        (top, center), _ = cam.project(np.array([[0, 0, 0.5], [0, 0, 0.0]]))
        assert top[1] < center[1]  # image y points down
        (right,), _ = cam.project(np.array([[0, 0.5, 0.0]]))  # camera on +x looking at -x: +y is to the right
        assert right[0] > center[0]
        assert np.allclose(R @ R.T, np.eye(3)) and np.linalg.det(R) == pytest.approx(1.0)

    def test_orbit_semantics(self):
        frame = SceneFrame(center=np.array([1.0, 2, 3]))
        frame.camera.azimuth_deg = 30.0
        cams = orbit_cameras(frame, 36)
        az = [azimuth_elevation(c.center, frame) for c in cams]
        assert az[0][0] == pytest.approx(30.0)
        steps = np.diff([a[0] for a in az]) % 360
        assert np.allclose(steps, 10.0)
        assert all(a[1] == pytest.approx(frame.camera.elevation_deg) and a[2] == pytest.approx(frame.camera.distance) for a in az)
        for c in cams:
            uv, _ = c.project(frame.center[None])
            assert np.allclose(uv, [[400, 400]])

    def test_orbit_rejects_zero_views(self):
        with pytest.raises(ValueError, match="at least 1"):
            orbit_cameras(SceneFrame(), 0)

    def test_orthographic_orbit_frames_same_extent(self):
        frame = SceneFrame()
        p = np.array([[0.0, 0.0, 0.5]])
        persp = orbit_cameras(frame, 1)[0]
        ortho = orbit_cameras(frame, 1, projection="orthographic")[0]
        assert abs(persp.project(p)[0][0, 1] - ortho.project(p)[0][0, 1]) < 20

    def test_scaled_camera(self):
        cam = orbit_cameras(SceneFrame(), 1)[0]
        small = cam.scaled(0.25)
        p = np.array([[0.2, 0.1, 0.3]])
        assert np.allclose(small.project(p)[0], cam.project(p)[0] * 0.25)
        assert small.fov_deg == pytest.approx(cam.fov_deg) == pytest.approx(39.6)
