"""The compact file's size: curves that tell least are left out first until the file fits --max-bytes."""

from __future__ import annotations

import numpy as np

from doodle.fit.budget import closed_chains, least_telling_first


def _ink(*curves: list[int]) -> tuple[list[list[np.ndarray]], list[np.ndarray]]:
    """One view of 10 pixels; each curve inks the given pixels."""
    ink = [[np.array(c, np.int64) for c in curves]]
    count = np.zeros(10, np.int64)
    for c in curves:
        count[c] += 1
    return ink, [count]


def test_the_curve_whose_ink_others_draw_too_goes_first_and_the_rest_are_recounted():
    # C only redraws part of A; A alone draws pixel 6; B alone 3, 4, 5 (2 is shared with A)
    a, b, c = [0, 1, 2, 6], [2, 3, 4, 5], [0, 1]
    ink, count = _ink(a, b, c)
    kept = least_telling_first(ink, count, lambda keep: keep.sum() <= 2)
    assert kept.tolist() == [True, True, False]
    # recounted: without C, A alone draws 0, 1 and 6 (3 px) and B 3, 4, 5 (3 px): a tie, the first kept...
    # ...but with D (pixels 0, 1, 6 again) A draws nothing alone and goes before B
    ink, count = _ink(a, b, c, [0, 1, 6])
    kept = least_telling_first(ink, count, lambda keep: keep.sum() <= 2)
    assert kept[1] and kept.sum() == 2
    assert count[0].tolist() == _ink(a, b, c, [0, 1, 6])[1][0].tolist()  # the counts given are not changed


def test_ink_on_a_superquadrics_outline_tells_nothing():
    a, b = [0, 1, 2], [5, 6]
    ink, count = _ink(a, b)
    count[0][[0, 1, 2]] += 3  # a superquadric's outline draws all of A's pixels
    kept = least_telling_first(ink, count, lambda keep: keep.sum() <= 1)
    assert kept.tolist() == [False, True]


def test_nothing_is_left_out_of_a_file_that_fits():
    ink, count = _ink([0, 1], [2])
    assert least_telling_first(ink, count, lambda keep: True).all()


def test_closed_chains_are_one_unit_and_open_ones_are_not():
    square = np.array([[[0, 0, 0], [0.3, 0, 0], [0.6, 0, 0], [1, 0, 0]], [[1, 0, 0], [1, 0.3, 0], [1, 0.6, 0], [1, 1, 0]],
                       [[1, 1, 0], [0.6, 1, 0], [0.3, 1, 0], [0, 1, 0]], [[0, 1, 0], [0, 0.6, 0], [0, 0.3, 0], [0, 0, 0]]],
                      float)
    open_pair = square[:2] + [0, 0, 5]  # two joined cubics that do not close
    labels = closed_chains(np.concatenate([open_pair, square, square[:1] + 9]), 1e-9)
    assert labels.tolist() == [0, 1, 2, 2, 2, 2, 6]


def test_what_a_left_out_curve_shared_is_the_others_alone_after_it():
    # X and Y draw the same two pixels, Z one of its own: X goes first (nothing alone), then Y draws two pixels
    # alone and Z one, so Z goes next — without the recount Y (still "nothing alone") would
    ink, count = _ink([0, 1], [0, 1], [5])
    assert least_telling_first(ink, count, lambda keep: keep.sum() <= 1).tolist() == [False, True, False]


def test_a_units_ink_near_the_lines_is_found_on_its_box_as_on_the_frame():
    """``_near_lines`` dilates a unit's ink on its box: the same pixels as on the whole frame, in the same order,
    at the frame's edges too."""
    from scipy import ndimage

    from doodle.fit.budget import _near_lines

    rng = np.random.default_rng(1)
    for _ in range(200):
        h, w = rng.integers(3, 40, 2)
        ink = np.zeros((h, w), bool)
        for _ in range(rng.integers(0, 5)):
            y, x = rng.integers(0, h), rng.integers(0, w)
            ink[y:y + rng.integers(1, 4), x:x + rng.integers(1, 4)] = True
        lines = rng.random((h, w)) < 0.4
        whole = np.flatnonzero(ndimage.binary_dilation(ink) & lines)
        assert np.array_equal(_near_lines(ink, lines), whole)
