"""The layout of the engine's batch results (engine.world.batch): which columns a batch writes, in what
types, and what the flags mean.

A batch writes its results a column at a time (struct of arrays): one little-endian buffer per column,
each value written as its move ends, in the column's own type. These are exactly the reply columns of
the service's column form (docs/protocol.md, "Columns"), so a reader hands the buffers on as they are
and reads them with one `np.frombuffer` each; nothing is converted per move in interpreted code.

A leaf, so that whoever reads the columns knows the layout without loading the machinery that writes
them.
"""

from __future__ import annotations

from typing import Final

__all__ = ["RESULT_COLUMNS", "TRANSITION_STATES", "TRANSIENT_SHIFT", "TRANSIENT_MASK", "NO_CODE", "Status"]

#: (name, type, values per item) of each result column, in order. Types: u64, u32, u8 (unsigned integers)
#: and f64 (IEEE doubles), all little-endian. An item that did not run holds NaN in its reals, NO_CODE in
#: its u8 codes and 0 elsewhere (seq 0 among them), with Status.RESOLVED clear in `flags`.
RESULT_COLUMNS: Final = (
    ("seq", "u64", 1),  # the mover's move count after this move (MoveResult.seq): at least 1
    ("cell", "u32", 1),
    ("origin", "f64", 3),
    ("orientation", "f64", 4),  # w x y z
    ("flags", "u32", 1),  # Status bits, and the transient-state bits from TRANSIENT_SHIFT up
    ("transition_state", "u8", 1),  # the index in TRANSITION_STATES
    ("frames_stationary_fall", "u8", 1),  # NO_CODE when the move ran no transition
    ("contact_plane", "f64", 4),  # normal x y z, then d; NaN without one
    ("contact_plane_cell", "u32", 1),
    ("collision_normal", "f64", 3),
    ("sliding_normal", "f64", 3),
    ("collide_count", "u32", 1),  # how many ids the item adds to the batch's collided-object ids
)

#: MoveResult.transition_state values; the column holds the index.
TRANSITION_STATES: Final = ("OK", "Collided", "Adjusted", "Slid", "Invalid", "NoTransition")
#: a u8 code's value where the item has none (no transition state: it did not run; no frames count)
NO_CODE: Final = 255
#: where the transient-state bits (engine.world.transient.TS, the seven a State names) start in `flags`
TRANSIENT_SHIFT: Final = 16
#: the transient-state bits `flags` can hold, before the shift: the seven a State names
#: (engine.world.transient.NAMED_BITS)
TRANSIENT_MASK: Final = 0x7F


class Status:
    """The low bits of the `flags` column."""

    RESOLVED: Final = 1 << 0  # the item ran and its columns hold its result
    OK: Final = 1 << 1
    CONTACT: Final = 1 << 2
    ON_WALKABLE: Final = 1 << 3
    WATER_CONTACT: Final = 1 << 4
    HAS_CONTACT_PLANE: Final = 1 << 5
    HAS_CONTACT_PLANE_CELL: Final = 1 << 6
    HAS_COLLISION_NORMAL: Final = 1 << 7
    HAS_SLIDING_NORMAL: Final = 1 << 8
    HAS_FRAMES_STATIONARY_FALL: Final = 1 << 9
