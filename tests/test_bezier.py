import numpy as np
import pytest
import torch

from doodle.strokes.bezier import bernstein, bezier_derivative, bezier_length, bezier_points, bezier_segment


class TestBezierPoints:
    def test_endpoints_interpolate(self):
        c = np.random.default_rng(0).normal(size=(5, 4, 3))
        pts = bezier_points(c, np.array([0.0, 1.0]))
        assert np.allclose(pts[:, 0], c[:, 0]) and np.allclose(pts[:, 1], c[:, 3])

    def test_batched_and_unbatched_agree(self):
        c = np.random.default_rng(1).normal(size=(3, 4, 2))
        t = np.linspace(0, 1, 7)
        batched = bezier_points(c, t)
        assert batched.shape == (3, 7, 2)
        for i in range(3):
            assert np.allclose(bezier_points(c[i], t), batched[i])

    def test_matches_explicit_formula(self):
        c = np.random.default_rng(2).normal(size=(4, 3))
        t = 0.3
        expected = sum(b * c[j] for j, b in enumerate([(1 - t) ** 3, 3 * t * (1 - t) ** 2, 3 * t * t * (1 - t), t**3]))
        assert np.allclose(bezier_points(c, np.array([t]))[0], expected)

    def test_partition_of_unity(self):
        assert np.allclose(bernstein(np.linspace(0, 1, 11)).sum(-1), 1.0)

    def test_torch_numpy_same(self):
        c = np.random.default_rng(3).normal(size=(2, 4, 3))
        t = np.linspace(0, 1, 5)
        assert np.allclose(bezier_points(torch.from_numpy(c), torch.from_numpy(t)).numpy(), bezier_points(c, t))

    def test_bad_shape(self):
        with pytest.raises(ValueError, match=r"expected shape \(\.\.\., 4, \*\)"):
            bezier_points(np.zeros((3, 3)), np.zeros(2))

    def test_gradcheck(self):
        c = torch.randn(2, 4, 3, dtype=torch.float64, requires_grad=True)
        t = torch.linspace(0, 1, 5, dtype=torch.float64)
        assert torch.autograd.gradcheck(lambda x: bezier_points(x, t), (c,))


class TestDerivativeAndSegments:
    def test_derivative_matches_finite_difference(self):
        c = np.random.default_rng(4).normal(size=(4, 3))
        t = np.array([0.1, 0.5, 0.9])
        h = 1e-6
        fd = (bezier_points(c, t + h) - bezier_points(c, t - h)) / (2 * h)
        assert np.allclose(bezier_derivative(c, t), fd, atol=1e-6)

    @pytest.mark.parametrize("t0,t1", [(0.0, 0.5), (0.2, 0.9), (0.7, 1.0)])
    def test_segment_is_exact(self, t0, t1):
        c = np.random.default_rng(5).normal(size=(3, 4, 3))
        seg = bezier_segment(c, t0, t1)
        s = np.linspace(0, 1, 9)
        assert np.allclose(bezier_points(seg, s), bezier_points(c, t0 + s * (t1 - t0)))

    def test_length_of_straight_line(self):
        c = np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]])
        assert bezier_length(c) == pytest.approx(3.0)
