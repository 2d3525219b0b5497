"""What a move may change on its mover, kept so a move that raises changes nothing.

A move that fails with an exception (an input the checks at the door let
through, or a bug) must leave its mover exactly as it was: the World takes
this snapshot before the move and puts it back if the move raises. Shadows
change only in the move's very last step (reshadow), after everything that
can fail, so they need no copy.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .mover import Mover
from .._compat import mypyc_attr

if TYPE_CHECKING:
    from ..cells.obj_cell import ObjCell

__all__ = ["MoverSnapshot"]


@mypyc_attr(acyclic=True, free_list_len=1)
class MoverSnapshot:
    """The mutable state of one mover at one moment: the slots a transition, SetPositionInternal or a
    physics step writes. Every value is immutable or replaced, never edited in place, so keeping the
    references is a full copy. Taken on every move: plain attribute reads, compiled (setup.py)."""

    __slots__ = ("mover", "position", "cell", "transient", "contact_plane", "contact_plane_cell_id",
                 "sliding_normal", "velocity", "acceleration", "missile", "colliding_with_environment",
                 "held_time", "held_motion")

    def __init__(self, mover: Mover) -> None:
        self.mover = mover
        self.position = mover.position
        self.cell: ObjCell | None = mover.cell
        self.transient = mover.transient
        self.contact_plane = mover.contact_plane
        self.contact_plane_cell_id = mover.contact_plane_cell_id
        self.sliding_normal = mover.sliding_normal
        self.velocity = mover.velocity
        self.acceleration = mover.acceleration
        self.missile = mover.missile
        self.colliding_with_environment = mover.colliding_with_environment
        self.held_time = mover.held_time
        self.held_motion = mover.held_motion

    def restore(self) -> None:
        m = self.mover
        m.position = self.position
        m.cell = self.cell
        m.transient = self.transient
        m.contact_plane = self.contact_plane
        m.contact_plane_cell_id = self.contact_plane_cell_id
        m.sliding_normal = self.sliding_normal
        m.velocity = self.velocity
        m.acceleration = self.acceleration
        m.missile = self.missile
        m.colliding_with_environment = self.colliding_with_environment
        m.held_time = self.held_time
        m.held_motion = self.held_motion
