"""What a move may change on its mover, kept so a move that raises changes nothing.

A move that fails with an exception (an input the checks at the door let
through, or a bug) must leave its mover exactly as it was: the World takes
this snapshot before the move and puts it back if the move raises. Shadows
change only in the move's very last step (reshadow), after everything that
can fail, so they need no copy.
"""

from __future__ import annotations

from typing import Any

from .mover import Mover

__all__ = ["MoverSnapshot"]

#: the Mover slots a transition, SetPositionInternal or a physics step writes
_MUTABLE = (
    "position",
    "cell",
    "transient",
    "contact_plane",
    "contact_plane_cell_id",
    "sliding_normal",
    "velocity",
    "acceleration",
    "missile",
    "colliding_with_environment",
    "held_time",
    "held_motion",
)

_VELOCITY = _MUTABLE.index("velocity")


class MoverSnapshot:
    """The mutable state of one mover at one moment (all values are immutable or replaced, never edited)."""

    __slots__ = ("mover", "values")

    def __init__(self, mover: Mover) -> None:
        self.mover = mover
        self.values: tuple[Any, ...] = tuple(getattr(mover, name) for name in _MUTABLE)

    def velocity(self) -> Any:
        """The mover's velocity when the snapshot was taken."""
        return self.values[_VELOCITY]

    def restore(self) -> None:
        for name, value in zip(_MUTABLE, self.values):
            setattr(self.mover, name, value)
