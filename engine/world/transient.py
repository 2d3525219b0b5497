"""TransientState bits of a physics object (the client's values)."""

from __future__ import annotations

from typing import Final

__all__ = ["TS", "NAMED_BITS", "transient_names"]


class TS:
    CONTACT: Final = 0x1
    ON_WALKABLE: Final = 0x2
    SLIDING: Final = 0x4
    WATER_CONTACT: Final = 0x8
    STATIONARY_FALL: Final = 0x10
    STATIONARY_STOP: Final = 0x20
    STATIONARY_STUCK: Final = 0x40
    STATIONARY_COMPLETE: Final = 0x70
    ACTIVE: Final = 0x80
    CHECK_ETHEREAL: Final = 0x100


#: (name, bit) of the flags a State reports, in the client's bit order
NAMED_BITS: Final = (
    ("Contact", TS.CONTACT),
    ("OnWalkable", TS.ON_WALKABLE),
    ("Sliding", TS.SLIDING),
    ("WaterContact", TS.WATER_CONTACT),
    ("StationaryFall", TS.STATIONARY_FALL),
    ("StationaryStop", TS.STATIONARY_STOP),
    ("StationaryStuck", TS.STATIONARY_STUCK),
)


_NAMES_BY_BITS: Final[dict[int, list[str]]] = {}


def transient_names(bits: int) -> list[str]:
    """The flag names the formats use, in the client's bit order (a new list)."""
    names = _NAMES_BY_BITS.get(bits)
    if names is None:
        names = _NAMES_BY_BITS[bits] = [name for name, bit in NAMED_BITS if bits & bit]
    return list(names)
