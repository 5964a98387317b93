import numpy as np
import pytest

from doodle.errors import DoodleError
from doodle.samples import SCENES, load_ground_truth, render_rgba, sample_cameras, visible_feature_edges, write_sample


def test_all_scenes_render_an_object():
    cam = sample_cameras("test", 1, 64)[0]
    for name, build in SCENES.items():
        img = render_rgba(build(), cam, 1)
        coverage = (img[..., 3] > 0).mean()
        assert 0.02 < coverage < 0.8, name  # the tripod's legs and cable cover little


def test_torus_rays_meet_the_tube_and_pass_through_the_hole():
    from doodle.samples.primitives import Torus

    ring = Torus(np.array([0.0, 0, 1.0]), major=0.3, minor=0.05)
    o = np.array([[0.0, 0, 3], [0.3, 0, 3], [0.0, -0.3, 3], [0.34, 0, 3], [0.36, 0, 3], [-2, 0, 1]])
    d = np.array([[0.0, 0, -1]] * 5 + [[1.0, 0, 0]])
    t, n = ring.intersect(o, d)
    assert np.isinf(t[0])  # through the hole
    assert np.allclose(t[1:3], 3 - 1 - 0.05, atol=1e-4) and np.allclose(n[1], [0, 0, 1], atol=1e-3)
    assert np.isclose(t[3], 2 - 0.03, atol=1e-4)  # off the tube's centre circle: its surface is 0.03 higher
    assert np.isinf(t[4])  # just outside the tube
    assert np.isclose(t[5], 2 - 0.35, atol=1e-4) and np.allclose(n[5], [-1, 0, 0], atol=1e-3)
    assert ring.contains(np.array([[0.3, 0, 1.0], [0.0, 0, 1.0]])).tolist() == [True, False]


def test_deterministic(tmp_path):
    """A sample scene is the same bytes whichever process writes it."""
    from helpers import in_a_fresh_process

    a = write_sample("snowman", tmp_path / "a", n_train=2, n_test=1, size=32)
    in_a_fresh_process(f"from doodle.samples import write_sample; write_sample('snowman', {str(tmp_path / 'b')!r}, "
                       "n_train=2, n_test=1, size=32)")
    b = tmp_path / "b"
    for rel in ("train/r_0.png", "train/r_1.png", "test/r_0.png", "transforms_train.json", "ground_truth.json"):
        assert (a / rel).read_bytes() == (b / rel).read_bytes(), rel


def test_cameras_on_upper_hemisphere():
    for split in ("train", "test"):
        for c in sample_cameras(split, 40):
            assert c.center[2] > 0.1


def test_hidden_edges_removed():
    from doodle.samples.scenes import chair

    edges = visible_feature_edges(chair())
    # no visible edge point lies on the seat underside inside the leg tops
    mids = edges.mean(1)
    on_leg_top = (np.abs(mids[:, 2] + 0.2) < 1e-6) & (np.abs(np.abs(mids[:, 0]) - 0.36) < 0.04) & (np.abs(np.abs(mids[:, 1]) - 0.36) < 0.04)
    assert not on_leg_top.any()
    assert len(edges) > 100


def test_ground_truth_loads(chair_dir):
    gt = load_ground_truth(chair_dir)
    assert gt["feature_edges"].shape[1:] == (2, 3) and len(gt["primitives"]) == 6


def test_refuses_to_overwrite(tmp_path):
    (tmp_path / "x").mkdir()
    (tmp_path / "x" / "keep.txt").write_text("mine")
    with pytest.raises(DoodleError, match="--force"):
        write_sample("chair", tmp_path / "x", n_train=1, n_test=1, size=16)
    assert (tmp_path / "x" / "keep.txt").read_text() == "mine"


def test_unknown_name():
    with pytest.raises(DoodleError, match="chair, snowman, lamp"):
        write_sample("kettle", "/nonexistent/x")


def test_every_part_lies_in_its_bounding_sphere_and_the_cast_is_each_parts_nearest_hit():
    """The ray cast culls rays by the parts' bounding spheres: each sphere holds its part (points the part
    contains, on a grid over its box), and the cast's hits are the nearest of every part's own hits without culling."""
    from doodle.samples.primitives import Cone, Cylinder
    from doodle.samples.raycast import cast

    rng = np.random.default_rng(0)
    tilted = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    parts = [Cylinder(center=np.array([0.1, -0.2, 0.0]), R=tilted, radius=0.05, height=1.2),  # a leg
             Cone(center=np.array([0.0, 0.3, 0.1]), radius=0.4, height=0.3),  # wider than tall
             Cone(center=np.array([-0.3, 0.0, 0.0]), R=tilted, radius=0.1, height=0.7)]  # a spout
    for part in parts:
        centre, radius = part.bounding_sphere()
        reach = part.bounding_radius()  # about the part's origin (its base): a loose sphere that holds it
        grid = part.center + rng.uniform(-reach, reach, size=(400_000, 3))
        inside = grid[part.contains(grid)]
        assert len(inside) > 100
        assert np.linalg.norm(inside - centre, axis=1).max() <= radius + 1e-12
    for name in ("tripod", "mug", "lamp"):
        prims = SCENES[name]() + parts
        o = np.tile([[0.2, -3.5, 1.5]], (4000, 1)) + rng.normal(scale=0.05, size=(4000, 3))
        d = rng.normal(size=(4000, 3)) * [0.25, 0.0, 0.25] + [0.0, 1.0, -0.4]
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        t, n, idx = cast(prims, o, d)
        each = [p.intersect_near(o, d) for p in prims]
        nearest = np.min([e[0] for e in each], axis=0)
        assert np.isfinite(t).sum() > 400
        np.testing.assert_array_equal(t, nearest)
        hit = np.isfinite(t)
        np.testing.assert_array_equal(n[hit], np.array([each[k][1][j] for j, k in zip(np.flatnonzero(hit), idx[hit])]))
