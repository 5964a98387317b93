"""The visual hull's domain: an object is never cut off where the scene's frame is too small for it."""

from dataclasses import replace

import numpy as np
import pytest

from doodle.fit.volume import carve
from doodle.fit.volume.carve import carve_hull
from doodle.scenes import load_scene, working_scene


def _extent(grid, occupied) -> tuple[np.ndarray, np.ndarray]:
    """World box ``(lo, hi)`` of the occupied voxels' centres."""
    centres = grid.centres(np.argwhere(occupied).astype(float))
    return centres.min(0), centres.max(0)


@pytest.fixture(scope="module")
def snowman(snowman_dir):
    work = working_scene(load_scene(snowman_dir), 96)
    lo, hi = _extent(*carve_hull(work, 64))
    return work, lo, hi


def _off_frame(work, lo, hi):
    """The snowman's scene with its frame shifted down and shrunk, as SfM's frame is centred on where the
    cameras aim (DTU's skull's face): the first cube (1.15 radii about the centre) misses the top of the head
    and one side of the body, and its bottom face lies below the object."""
    size = float((hi - lo).max())
    frame = replace(work.frame, center=work.frame.center + np.array([0.25, 0.0, -0.25]) * size, radius=0.35 * size)
    return replace(work, frame=frame)


def test_the_hull_grows_past_a_frame_too_small_for_the_object(snowman):
    work, lo, hi = snowman
    grid, occupied = carve_hull(_off_frame(work, lo, hi), 64)
    lo2, hi2 = _extent(grid, occupied)
    voxel = 2 * grid.voxel
    # the head's top and the body's sides are all there, as under the scene's own frame
    assert hi2[2] >= hi[2] - voxel
    assert np.all(lo2[:2] <= lo[:2] + voxel) and np.all(hi2[:2] >= hi[:2] - voxel)


def test_without_growing_the_frame_cuts_the_object_off(snowman, monkeypatch):
    """The same off frame with the first cube kept as it is: the head is cut (the test above measures this)."""
    work, lo, hi = snowman
    monkeypatch.setattr(carve, "GROW_TRIES", 0)
    grid, occupied = carve_hull(_off_frame(work, lo, hi), 64)
    lo2, hi2 = _extent(grid, occupied)
    assert hi2[2] < hi[2] - 2 * grid.voxel and lo2[0] > lo[0] + 2 * grid.voxel


def test_the_side_below_does_not_grow(snowman):
    """Below an object no view carves a wedge that goes far down; the cube does not chase it there."""
    work, lo, hi = snowman
    size = float((hi - lo).max())
    # the frame high up: the first cube's bottom face cuts through the snowman's body
    frame = replace(work.frame, center=work.frame.center + np.array([0.0, 0.0, 0.45 * size]), radius=0.5 * size)
    grid, occupied = carve_hull(replace(work, frame=frame), 64)
    lo2, _ = _extent(grid, occupied)
    bottom = frame.center[2] - carve.FIRST_SIDE * frame.radius
    assert lo2[2] >= bottom - grid.voxel
    assert lo2[2] > lo[2] + 2 * grid.voxel  # so the object was cut there


def test_the_hull_carved_in_threads_is_the_hull_carved_in_one(snowman, monkeypatch):
    """The views' counts are summed point by point, so the cells split among threads carve the same hull."""
    work, _, _ = snowman
    monkeypatch.setattr(carve, "CLASSIFY_CHUNK", 1 << 40)
    one = carve_hull(work, 64)
    monkeypatch.setattr(carve, "CLASSIFY_CHUNK", 1000)  # many chunks, as many threads as the machine has
    monkeypatch.setattr(carve, "cpu_count", lambda: 8)
    many = carve_hull(work, 64)
    assert one[0].shape == many[0].shape and np.array_equal(one[0].origin, many[0].origin)
    assert one[1].any() and np.array_equal(one[1], many[1])


def test_points_project_to_the_pixels_and_depths_of_the_pinhole_formula():
    """``project_points`` (the carving's and the edge vote's hot loop, float32) adds the translation column by
    column: the same pixels and depths, to the bit, as ``floor((R p + t)_xy / z · f + c)`` written whole."""
    from doodle.cameras import Camera

    rng = np.random.default_rng(7)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    cam = Camera(512.3, 511.7, 250.2, 260.9, 512, 512, q * np.sign(np.linalg.det(q)), np.array([0.1, -0.2, 4.0]))
    pts = rng.normal(scale=1.5, size=(5000, 3)).astype(np.float32)
    u, v, z = carve.project_points(cam, pts)
    pc = pts @ cam.R.astype(np.float32).T + cam.t.astype(np.float32)
    zs = np.where(pc[:, 2] > 1e-6, pc[:, 2], 1e-6)
    np.testing.assert_array_equal(z, pc[:, 2])
    with np.errstate(invalid="ignore"):  # points behind the camera: their pixels are never read
        for got, row, f, c in ((u, 0, cam.fx, cam.cx), (v, 1, cam.fy, cam.cy)):
            np.testing.assert_array_equal(got, np.floor(pc[:, row] / zs * np.float32(f) + np.float32(c)).astype(np.int32))
    assert 0.3 < ((u >= 0) & (u < 512) & (v >= 0) & (v < 512)).mean() < 1
