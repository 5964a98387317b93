"""Thin plates offered as occluders (doodle/fit/volume/plates.py)."""

import numpy as np

from doodle.fit.volume.plates import planar, thin_plates
from doodle.strokes.model import SuperquadricSet
from doodle.strokes.superquadric import quaternion_to_matrix

VOXEL = 0.05
ORIGIN = np.array([-1.0, -1.0, -1.0])


def _chair_back() -> np.ndarray:
    """A slab 4 voxels thick (x), 30 wide (y), 40 high (z), on two legs 3 voxels across: one thin part."""
    thin = np.zeros((40, 40, 70), bool)
    thin[18:22, 5:35, 25:65] = True  # the back
    thin[18:21, 5:8, 0:25] = thin[18:21, 32:35, 0:25] = True  # its legs
    return thin


def test_a_slab_on_legs_is_one_plate_boxed_inside_it_and_the_legs_are_none():
    thin = _chair_back()
    sheet = planar(thin, radius=2)
    assert sheet[18:22, 10:30, 30:60].mean() > 0.9 and not sheet[:, :, :15].any()  # the legs are rods
    plates = thin_plates(thin, ORIGIN, VOXEL, np.eye(3), radius=2, limit=4)
    assert len(plates) == 1 and not plates.drawn.any()
    R = quaternion_to_matrix(plates.rotation[0])
    assert abs(R[:, 2] @ np.array([1.0, 0, 0])) > 0.99  # thin along x
    centre = ORIGIN + np.array([19.5, 19.5, 44.5]) * VOXEL
    assert np.linalg.norm(plates.translation[0] - centre) < 2 * VOXEL
    half = np.sort(plates.scale[0])
    assert half[0] <= 2 * VOXEL and 13 * VOXEL <= half[1] <= 15 * VOXEL and 18 * VOXEL <= half[2] <= 20 * VOXEL


def test_rods_and_lumps_are_no_plates():
    thin = np.zeros((30, 30, 60), bool)
    thin[10:13, 10:13, 5:55] = True  # a pole
    thin[20:26, 20:26, 20:26] = True  # a small lump
    assert len(thin_plates(thin, ORIGIN, VOXEL, np.eye(3), radius=2, limit=4)) == 0


def test_occluders_keep_the_outline_flags_and_cells_of_the_set_before():
    a = SuperquadricSet(np.ones((2, 3)), np.ones((2, 2)), np.tile([1.0, 0, 0, 0], (2, 1)), np.zeros((2, 3)),
                        outline=np.array([True, False]), outline_cells=np.ones((2, 8, 16), bool))
    plates = thin_plates(_chair_back(), ORIGIN, VOXEL, np.eye(3), radius=2, limit=4)
    both = a.and_occluders(plates)
    assert len(both) == 3 and both.drawn.tolist() == [True, False, False]
    assert both.drawn_cells[0].all() and not both.drawn_cells[2].any()
    assert a.and_occluders(SuperquadricSet()) is a


def test_a_sign_on_a_post_keeps_its_board_as_an_occluder():
    """A board on a post has no thick part: no superquadric draws it, and its board is offered as an occluder and
    kept by the judge (it hides what the hull hides): one superquadric that draws nothing, over the board."""
    from helpers import render_scene

    from doodle.fit import FitConfig, fit
    from doodle.samples.primitives import Box

    board = Box(np.array([0.0, 0, 0.3]), half=np.array([0.6, 0.03, 0.4]))
    post = Box(np.array([0.0, 0, -0.45]), half=np.array([0.05, 0.05, 0.35]))
    logs = []
    sq = fit(render_scene([board, post], n=16, size=128), FitConfig(size=128, abstraction_steps=40), progress=False,
             log=logs.append).strokes.superquadrics
    assert any("1 thin plate" in m for m in logs), logs
    assert len(sq) == 1 and not sq.drawn.any()
    assert np.linalg.norm(sq.translation[0] - board.center) < 0.05
    thin_axis = quaternion_to_matrix(sq.rotation[0])[:, 2]
    assert abs(thin_axis[1]) > 0.98 and sq.scale[0, 2] < 0.05
    assert np.allclose(np.sort(sq.scale[0, :2]), [0.4, 0.6], rtol=0.1)  # the board's half-extents (a hull's)
