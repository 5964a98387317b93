import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from doodle.strokes.bitcodes import MAX_ORDER, BitReader, best_order, golomb, golomb_bits, pack


@settings(max_examples=80, deadline=None)
@given(st.lists(st.integers(-(2**33), 2**33), max_size=60), st.integers(0, MAX_ORDER),
       st.lists(st.integers(0, 2**20 - 1), max_size=5))
def test_golomb_codes_read_back_between_fixed_fields(values, k, fixed):
    bits = np.concatenate([golomb(np.array(values, np.int64), k), pack(np.array(fixed, np.int64), 20),
                           golomb(np.array(values[::-1], np.int64), k)])
    assert len(bits) == 2 * golomb_bits(np.array(values, np.int64), k) + 20 * len(fixed)
    r = BitReader(bits)
    assert r.golomb(len(values), k).tolist() == values
    assert r.take(len(fixed), 20).tolist() == fixed
    assert r.golomb(len(values), k).tolist() == values[::-1]
    assert r.left == 0


def test_small_values_cost_few_bits_and_the_order_fits_the_spread():
    assert golomb_bits(np.array([0]), 0) == 1 and golomb_bits(np.array([-1, 1]), 0) == 3 + 3
    wide = np.random.default_rng(0).integers(-300, 300, 200)
    k = best_order(wide)
    assert 6 <= k <= 9
    assert golomb_bits(wide, k) == min(golomb_bits(wide, j) for j in range(MAX_ORDER + 1))
    assert golomb_bits(wide, k) < 200 * 11  # beats 11-bit fixed fields


@pytest.mark.parametrize("bits", [[0] * 50, [0, 0, 1], [1, 0, 1]])
def test_bad_or_short_codes_raise_value_error(bits):
    with pytest.raises(ValueError):
        BitReader(np.array(bits, np.uint8)).golomb(2, 1)
