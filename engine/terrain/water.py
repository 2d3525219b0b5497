"""Water on terrain: per-vertex surface types, per-cell flooding, depth."""

from __future__ import annotations

import math
from typing import Final

__all__ = ["WaterType", "is_water_terrain", "ENTIRELY_WATER_DEPTH", "PARTIAL_WATER_DEPTH", "SHORE_DEPTH"]


class WaterType:
    NOT_WATER: Final = 0
    PARTIALLY_WATER: Final = 1
    ENTIRELY_WATER: Final = 2


# Float32 values the client uses (0.9, 0.45, 0.1 rounded to single precision).
ENTIRELY_WATER_DEPTH: Final = 0.89999998
PARTIAL_WATER_DEPTH: Final = 0.44999999
SHORE_DEPTH: Final = 0.1


def is_water_terrain(word: int) -> bool:
    """A terrain word's surface type (bits 2..6) is one of the five water types."""
    return 0x10 <= ((word >> 2) & 0x1F) <= 0x14


def c_fmod(a: float, b: float) -> float:
    """C's % on floats: the remainder keeps the sign of the dividend."""
    return math.fmod(a, b)
