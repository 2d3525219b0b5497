"""Rounding to single precision (engine.geometry.single.to_single) against numpy's float32 cast."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from engine.geometry.single import to_single


def _numpy_single(x: float) -> float:
    return float(np.float32(x))


def _neighbours(f: float) -> tuple[float, float]:
    """The float32 value f and the next float32 away from zero, as doubles."""
    bits = struct.unpack("<I", struct.pack("<f", f))[0]
    return f, struct.unpack("<f", struct.pack("<I", bits + 1))[0]


@pytest.mark.parametrize("value", [1.0, 0.1, -0.1, 100.0 / 3.0, 123.456, -87.75441, 2.0**-100, 1e30])
@pytest.mark.parametrize("fraction", [0.0, 0.25, 0.5, 0.75, 0.5 - 2.0**-20, 0.5 + 2.0**-20])
def test_between_two_singles_it_picks_the_nearest_and_breaks_ties_to_even(value: float, fraction: float) -> None:
    low, high = _neighbours(struct.unpack("<f", struct.pack("<f", value))[0])
    x = low + (high - low) * fraction
    expected = low if fraction < 0.5 else high if fraction > 0.5 else None
    if expected is None:  # an exact tie: the neighbour with an even last bit
        low_bits = struct.unpack("<I", struct.pack("<f", low))[0]
        expected = low if low_bits % 2 == 0 else high
    assert to_single(x) == expected
    assert to_single(x) == _numpy_single(x)


@pytest.mark.parametrize("k", range(-40, 41, 3))
def test_just_below_a_power_of_two_rounds_up_into_the_next_binade(k: int) -> None:
    p = 2.0**k
    assert to_single(p * (1.0 - 2.0**-25)) == p  # the tie between 1 - 2**-24 and 1 goes to the even 1
    assert to_single(p * (1.0 - 2.0**-26)) == p
    assert to_single(p * (1.0 - 2.0**-24)) == p * (1.0 - 2.0**-24)  # exactly a float32


def test_zeros_keep_their_sign_and_specials_pass_through() -> None:
    assert to_single(0.0) == 0.0 and math.copysign(1.0, to_single(0.0)) == 1.0
    assert math.copysign(1.0, to_single(-0.0)) == -1.0
    assert math.isnan(to_single(math.nan))
    assert to_single(math.inf) == math.inf and to_single(-math.inf) == -math.inf


def test_subnormal_singles_lose_bits_like_the_cast() -> None:
    tiny = 3.0 * 2.0**-149 + 2.0**-152  # between float32 subnormals
    assert to_single(tiny) == _numpy_single(tiny) == 3.0 * 2.0**-149


def test_beyond_float32_range_raises_like_packing_a_float32() -> None:
    with pytest.raises(OverflowError):
        to_single(1e39)


@given(st.floats(allow_nan=False, allow_infinity=False, min_value=-3.3e38, max_value=3.3e38))
def test_any_double_in_range_rounds_as_numpy_casts_it(x: float) -> None:
    assert to_single(x) == _numpy_single(x)
