"""Enumerations of the transition: states, insert types, ObjectInfo flags.

Plain int constants rather than enum members: they are compared in every
sub-step, and an int comparison is the cheapest thing Python does.
"""

from __future__ import annotations

from typing import Final

__all__ = ["TransitionState", "InsertType", "OI", "STATE_NAMES"]


class TransitionState:
    INVALID: Final = 0  # failed completely
    OK: Final = 1  # no collision, position accepted
    COLLIDED: Final = 2  # hard stop
    ADJUSTED: Final = 3  # nudged out of an overlap; check again
    SLID: Final = 4  # projected along a surface; check again


STATE_NAMES: Final = {0: "Invalid", 1: "OK", 2: "Collided", 3: "Adjusted", 4: "Slid"}


class InsertType:
    TRANSITION: Final = 0
    PLACEMENT: Final = 1
    INITIAL_PLACEMENT: Final = 2


class OI:
    """ObjectInfoState bits (the client's values)."""

    CONTACT: Final = 0x1
    ON_WALKABLE: Final = 0x2
    IS_VIEWER: Final = 0x4
    PATH_CLIPPED: Final = 0x8
    FREE_ROTATE: Final = 0x10
    PERFECT_CLIP: Final = 0x40
    IS_IMPENETRABLE: Final = 0x80
    IS_PLAYER: Final = 0x100
    EDGE_SLIDE: Final = 0x200
    IGNORE_CREATURES: Final = 0x400
    IS_PK: Final = 0x800
    IS_PK_LITE: Final = 0x1000
