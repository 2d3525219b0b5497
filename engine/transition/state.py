"""Enumerations of the transition: states, insert types, ObjectInfo flags.

Plain int constants rather than enum members: they are compared in every
sub-step, and an int comparison is the cheapest thing Python does.
"""

from __future__ import annotations

__all__ = ["TransitionState", "InsertType", "OI", "STATE_NAMES"]


class TransitionState:
    INVALID = 0  # failed completely
    OK = 1  # no collision, position accepted
    COLLIDED = 2  # hard stop
    ADJUSTED = 3  # nudged out of an overlap; check again
    SLID = 4  # projected along a surface; check again


STATE_NAMES = {0: "Invalid", 1: "OK", 2: "Collided", 3: "Adjusted", 4: "Slid"}


class InsertType:
    TRANSITION = 0
    PLACEMENT = 1
    INITIAL_PLACEMENT = 2


class OI:
    """ObjectInfoState bits (the client's values)."""

    CONTACT = 0x1
    ON_WALKABLE = 0x2
    IS_VIEWER = 0x4
    PATH_CLIPPED = 0x8
    FREE_ROTATE = 0x10
    PERFECT_CLIP = 0x40
    IS_IMPENETRABLE = 0x80
    IS_PLAYER = 0x100
    EDGE_SLIDE = 0x200
    IGNORE_CREATURES = 0x400
    IS_PK = 0x800
    IS_PK_LITE = 0x1000
