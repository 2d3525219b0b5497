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


#: the named bits (all below 0x80)
_NAMED_MASK: Final = 0x7F
#: the names of every combination of the named bits, indexed by it (a list: no boxed key per lookup)
_NAMES_BY_BITS: Final[list[list[str]]] = [
    [name for name, bit in NAMED_BITS if bits & bit] for bits in range(_NAMED_MASK + 1)
]


def transient_names(bits: int) -> list[str]:
    """The flag names the formats use, in the client's bit order (a new list)."""
    return list(_NAMES_BY_BITS[bits & _NAMED_MASK])
