import numpy as np
import pytest
import torch

from doodle.strokes.superquadric import (
    inside_outside, log_inside_outside, local_gradient_log, matrix_to_quaternion, quaternion_to_matrix,
    surface_points, union_log_inside_outside, world_normals, world_to_local,
)

EPS_GRID = [0.1, 0.5, 1.0, 1.5, 1.9]


def _grid(n=9):
    eta, omega = np.meshgrid(np.linspace(-np.pi / 2, np.pi / 2, n), np.linspace(-np.pi, np.pi, 2 * n))
    return eta, omega


class TestInsideOutside:
    def test_sphere_values(self):
        x = np.array([[[0.0, 0, 0.5], [2.0, 0, 0], [0, 1.0, 0]]])
        f = inside_outside(x, np.ones((1, 3)), np.ones((1, 2)))
        assert np.allclose(f, [[0.25, 4.0, 1.0]], atol=1e-9)

    @pytest.mark.parametrize("e1", EPS_GRID)
    @pytest.mark.parametrize("e2", EPS_GRID)
    def test_parametric_surface_has_f_one(self, e1, e2):
        scale = np.array([[0.7, 0.4, 0.3]])
        p, _ = surface_points(*_grid(), scale, np.array([[e1, e2]]))
        f = inside_outside(p.reshape(1, -1, 3), scale, np.array([[e1, e2]]))
        assert np.allclose(f, 1.0, atol=1e-5)

    @pytest.mark.parametrize("e1", EPS_GRID)
    @pytest.mark.parametrize("e2", EPS_GRID)
    def test_analytic_normals_match_gradient_and_autograd(self, e1, e2):
        scale = torch.tensor([[0.7, 0.4, 0.3]], dtype=torch.float64)
        shape = torch.tensor([[e1, e2]], dtype=torch.float64)
        p, n = surface_points(*(torch.from_numpy(a) for a in _grid()), scale, shape)
        x = p.reshape(1, -1, 3).clone().requires_grad_(True)
        (g_auto,) = torch.autograd.grad(log_inside_outside(x, scale, shape).sum(), x)
        g = local_gradient_log(x.detach(), scale, shape)
        assert torch.allclose(g, g_auto, atol=1e-6, rtol=1e-5)
        g_unit = torch.nn.functional.normalize(g, dim=-1)
        # Away from exact creases (where the parametric normal is ill-defined) they agree.
        cos = (g_unit * n.reshape(1, -1, 3)).sum(-1)
        assert (cos > 0.99).float().mean() > 0.95

    @pytest.mark.parametrize("dtype", [torch.float32, torch.float64])
    @pytest.mark.parametrize("e", [0.1, 1.9])
    def test_no_nan_on_axes_and_far_away(self, dtype, e):
        pts = torch.tensor([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, 0.3], [50, 0, 0], [1e3, 1e3, 1e3]],
                           dtype=dtype).unsqueeze(0).requires_grad_(True)
        scale = torch.tensor([[1.0, 0.5, 0.25]], dtype=dtype, requires_grad=True)
        shape = torch.tensor([[e, e]], dtype=dtype, requires_grad=True)
        lf = log_inside_outside(pts, scale, shape)
        occupancy = torch.sigmoid(8 * (1 - torch.exp(shape[:, :1] * lf)))  # the fitting's soft occupancy
        (lf.sum() + occupancy.sum() + local_gradient_log(pts, scale, shape).sum()).backward()
        for tensor in (lf, pts.grad, scale.grad, shape.grad):
            assert torch.isfinite(tensor).all()

    def test_gradcheck(self):
        x = torch.randn(2, 5, 3, dtype=torch.float64, requires_grad=True)
        scale = torch.rand(2, 3, dtype=torch.float64).add(0.2).requires_grad_(True)
        shape = torch.rand(2, 2, dtype=torch.float64).mul(1.7).add(0.2).requires_grad_(True)
        assert torch.autograd.gradcheck(log_inside_outside, (x, scale, shape))


class TestFramesAndUnion:
    def test_quaternion_round_trip(self):
        q = np.random.default_rng(0).normal(size=(20, 4))
        q /= np.linalg.norm(q, axis=1, keepdims=True)
        q *= np.sign(q[:, :1])
        R = quaternion_to_matrix(q)
        assert np.allclose(R @ R.transpose(0, 2, 1), np.eye(3), atol=1e-12)
        assert np.allclose(np.linalg.det(R), 1.0)
        assert np.allclose(matrix_to_quaternion(R), q, atol=1e-9)

    def test_world_to_local_inverts_pose(self):
        q = np.array([[np.cos(0.4), 0, 0, np.sin(0.4)]])
        t = np.array([[1.0, 2.0, 3.0]])
        local = np.array([[0.3, -0.2, 0.1]])
        world = local @ quaternion_to_matrix(q)[0].T + t
        assert np.allclose(world_to_local(world, q, t)[0], local)

    def test_union_is_min_and_normals_unit(self):
        scale = np.array([[0.5, 0.5, 0.5], [0.3, 0.3, 0.3]])
        shape = np.ones((2, 2))
        rot = np.tile([1.0, 0, 0, 0], (2, 1))
        trans = np.array([[0.0, 0, 0], [1.0, 0, 0]])
        pts = np.array([[0.1, 0, 0], [1.1, 0.1, 0], [3.0, 0, 0]])
        u = union_log_inside_outside(pts, scale, shape, rot, trans)
        assert u[0] < 0 and u[1] < 0 and u[2] > 0
        assert np.allclose(np.linalg.norm(world_normals(pts, scale, shape, rot, trans), axis=-1), 1.0)

    def test_empty_union_is_outside(self):
        z = np.zeros((0, 3))
        assert np.isinf(union_log_inside_outside(np.zeros((2, 3)), z, np.zeros((0, 2)), np.zeros((0, 4)), z)).all()


class TestRayOccupancy:
    def test_same_value_and_gradient_as_differentiating_every_sample(self):
        from doodle.fit.gradient.objectives.edges import ray_occupancy, union_occupancy

        gen = torch.Generator().manual_seed(3)
        params = [torch.rand(3, 3, generator=gen) * 0.5 + 0.2, torch.rand(3, 2, generator=gen) * 0.8 + 0.2,
                  torch.nn.functional.normalize(torch.randn(3, 4, generator=gen), dim=1), torch.randn(3, 3, generator=gen) * 0.3]
        params = [p.requires_grad_() for p in params]
        rays = torch.randn(500, 16, 3, generator=gen) * 0.6
        weights = torch.rand(500, generator=gen)
        full = union_occupancy(rays, *params, 8.0).max(dim=1).values
        fast = ray_occupancy(rays, *params, 8.0)
        assert torch.allclose(full, fast, atol=1e-6)
        g_full = torch.autograd.grad((full * weights).sum(), params)
        g_fast = torch.autograd.grad((fast * weights).sum(), params)
        assert all(g.abs().sum() > 0 for g in g_fast)
        for a, b in zip(g_full, g_fast):
            assert torch.allclose(a, b, atol=1e-5, rtol=1e-4)
