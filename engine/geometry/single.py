"""Rounding a double to single precision, in plain float arithmetic.

The client computes in 32-bit floats; the engine emulates that where it
decides an outcome (SnapToPlane) and in what a move leaves behind. Rounding
through `struct` costs two calls and two allocations; Veltkamp's split does it
in three float operations, which the compiled engine keeps in registers.

`fl(x, single)` is the one place the engine's precision setting
(EngineSettings.single_precision) takes effect: every routine that the
client computes in float32 rounds each operation through it, and with
`single` false it returns `x` unchanged, so the same routine runs in double
precision. It is a native function of a float and a native bool: in the
compiled engine a call costs what a call of `to_single` cost, plus one
branch (an indirect call through a variable would be a slow generic call).
"""

from __future__ import annotations

import struct
from typing import Final

__all__ = ["fl", "to_single"]

#: 2**29 + 1: multiplying by it splits a 53-bit significand after its top 24 bits
_SPLIT: Final = 536870913.0
#: the smallest normal float32; below it float32 has fewer significant bits
_MIN_NORMAL: Final = 1.1754943508222875e-38
#: safely below where float32 overflows to infinity (3.4028235677973366e38)
_SAFE_MAX: Final = 3.4e38

_SINGLE: Final = struct.Struct("<f")


def _through_struct(x: float) -> float:
    return float(_SINGLE.unpack(_SINGLE.pack(x))[0])


def fl(x: float, single: bool) -> float:
    """`x` rounded to the working precision: to the nearest float32 (ties to
    even, as C's `(float)x` rounds it) when `single`, else `x` itself.

    In float32's normal range the high half of Veltkamp's split is exactly that
    rounding under the double-precision round-to-nearest-even arithmetic that
    CPython and the compiled engine use; zeros, subnormals, huge values, NaN
    and infinities take the struct path (which raises OverflowError beyond
    float32's range, as packing a float32 does).
    """
    if single:
        # the test on `single` takes the place of main's zero test on the
        # hot path: a zero fails the range test and is returned below
        ax = abs(x)
        if _MIN_NORMAL <= ax < _SAFE_MAX:
            scaled = _SPLIT * x
            return scaled + (x - scaled)
        if x != 0.0:
            return _through_struct(x)
    return x


def to_single(x: float) -> float:
    """`x` rounded to the nearest float32: data the dats and the reference
    hold in single precision, whatever the engine's setting."""
    return fl(x, True)
