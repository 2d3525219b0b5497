"""The row layout of the engine's batch results (engine.world.batch): what each row holds, where, and
what its status bits mean.

A leaf, so that whoever reads rows (the service's column replies, a client unpacking them) knows the
layout without loading the machinery that writes them. Each row is REALS_PER_ROW little-endian float64s
and INTS_PER_ROW little-endian int64s; ROW_REALS and ROW_INTS name the runs in order.
"""

from __future__ import annotations

from typing import Final

__all__ = ["ROW_REALS", "ROW_INTS", "REALS_PER_ROW", "INTS_PER_ROW", "TRANSITION_STATES", "TRANSIENT_MASK", "Status",
           "real_slices", "int_columns"]

#: (name, width) of each run of a row's reals, in order: NaN where the result has no such value
ROW_REALS: Final = (("origin", 3), ("orientation", 4), ("contact_plane", 4), ("collision_normal", 3),
                    ("sliding_normal", 3))
#: a row's ints, in order: the cell id, the Status bits, the transient-state bits (engine.world.transient.TS,
#: the named ones: TRANSIENT_MASK), the transition state's index in TRANSITION_STATES,
#: frames_stationary_fall, contact_plane_cell, how many collided-object ids the row adds, and the result's
#: seq (MoveResult.seq: the mover's move count after this move, at least 1; 0 in a row whose item did not run)
ROW_INTS: Final = ("cell", "status", "transient", "transition_state", "frames_stationary_fall",
                   "contact_plane_cell", "collide_count", "seq")
REALS_PER_ROW: Final = 17
INTS_PER_ROW: Final = 8

#: MoveResult.transition_state values; a row holds the index.
TRANSITION_STATES: Final = ("OK", "Collided", "Adjusted", "Slid", "Invalid", "NoTransition")
#: the transient-state bits a row can hold: the seven a State names (engine.world.transient.NAMED_BITS)
TRANSIENT_MASK: Final = 0x7F


class Status:
    """Bits of a row's status integer."""

    RESOLVED: Final = 1 << 0  # the item ran and the row holds its result
    OK: Final = 1 << 1
    CONTACT: Final = 1 << 2
    ON_WALKABLE: Final = 1 << 3
    WATER_CONTACT: Final = 1 << 4
    HAS_CONTACT_PLANE: Final = 1 << 5
    HAS_CONTACT_PLANE_CELL: Final = 1 << 6
    HAS_COLLISION_NORMAL: Final = 1 << 7
    HAS_SLIDING_NORMAL: Final = 1 << 8
    HAS_FRAMES_STATIONARY_FALL: Final = 1 << 9


def real_slices() -> dict[str, tuple[int, int]]:
    """name -> (first, end) of each run of a row's reals."""
    out: dict[str, tuple[int, int]] = {}
    at = 0
    for name, width in ROW_REALS:
        out[name] = (at, at + width)
        at += width
    return out


def int_columns() -> dict[str, int]:
    """name -> index of each of a row's ints."""
    return {name: i for i, name in enumerate(ROW_INTS)}
