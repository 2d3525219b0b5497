"""TransientState bits of a physics object (the client's values)."""

from __future__ import annotations

__all__ = ["TS", "transient_names"]


class TS:
    CONTACT = 0x1
    ON_WALKABLE = 0x2
    SLIDING = 0x4
    WATER_CONTACT = 0x8
    STATIONARY_FALL = 0x10
    STATIONARY_STOP = 0x20
    STATIONARY_STUCK = 0x40
    STATIONARY_COMPLETE = 0x70
    ACTIVE = 0x80
    CHECK_ETHEREAL = 0x100


_NAMES = (
    ("Contact", TS.CONTACT),
    ("OnWalkable", TS.ON_WALKABLE),
    ("Sliding", TS.SLIDING),
    ("WaterContact", TS.WATER_CONTACT),
    ("StationaryFall", TS.STATIONARY_FALL),
    ("StationaryStop", TS.STATIONARY_STOP),
    ("StationaryStuck", TS.STATIONARY_STUCK),
)


def transient_names(bits: int) -> list[str]:
    """The flag names the formats use, in the client's bit order."""
    return [name for name, bit in _NAMES if bits & bit]
