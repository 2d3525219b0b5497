"""What a move may change on its mover, kept so that it can be taken back.

A move that fails with an exception (an input the checks at the door let
through, or a bug) must leave its mover exactly as it was: the World takes
a MoverSnapshot before the move and puts it back if the move raises.
Shadows change only in the move's very last step (reshadow), after
everything that can fail, so they need no copy there.

A move that ended may still have to be taken back: a service instance that
owns only some landblocks hands a mover whose move ended outside them to
the owner, and when no owner takes it the move is refused. A MoveUndo,
taken before such a move, puts back the mover and its shadows (the cells it
was listed in, at the places it held in their lists), so the world is as
if the move had never been asked.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .mover import Mover
from .shadows import remove_shadows
from .._compat import mypyc_attr

if TYPE_CHECKING:
    from ..cells.obj_cell import ObjCell
    from ..objects.obstacle import Obstacle

__all__ = ["MoverSnapshot", "MoveUndo"]


@mypyc_attr(acyclic=True, free_list_len=1)
class MoverSnapshot:
    """The mutable state of one mover at one moment: the slots a transition, SetPositionInternal or a
    physics step writes. Every value is immutable or replaced, never edited in place, so keeping the
    references is a full copy. Taken on every move: plain attribute reads, compiled (setup.py).

    Not the move count (Mover.seq, Mover.last): engine.world.moves counts a move only once it can no
    longer raise, so a move that raises never changed them; MoveUndo, which takes back moves that ended,
    keeps them."""

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


class MoveUndo:
    """A mover as it stands, shadows included: `restore()` after a move that ended puts it back exactly
    (the mover's slots, and its obstacle in the same cells' shadow lists at the same places, so that
    other movers test it in the same order as before; its move count and last result too). Taken only before moves that may be refused after
    they ended (a hand-over: engine.world.batch.run_batch's `stop_if`, the service's moves)."""

    __slots__ = ("snapshot", "seq", "last", "shadow_cells", "shadow_slots", "shadow_after")

    def __init__(self, mover: Mover) -> None:
        self.snapshot = MoverSnapshot(mover)
        #: the move count and last result: a refused move is no move, so neither counts it
        self.seq = mover.seq
        self.last = mover.last
        self.shadow_cells: list[ObjCell] = list(mover.shadow_cells)
        #: in each of those cells' lists (oldest first): the mover's place, and the object just before it
        #: (None: it was first), which it goes back behind if the list changed meanwhile
        self.shadow_slots: list[int] = []
        self.shadow_after: list[Obstacle | None] = []
        obstacle = mover.obstacle
        if obstacle is not None:
            for cell in self.shadow_cells:
                slot = cell.shadow_objects.index(obstacle)
                self.shadow_slots.append(slot)
                self.shadow_after.append(cell.shadow_objects[slot - 1] if slot > 0 else None)

    def restore(self) -> None:
        mover = self.snapshot.mover
        remove_shadows(mover)
        obstacle = mover.obstacle
        if obstacle is not None:
            for cell, slot, before in zip(self.shadow_cells, self.shadow_slots, self.shadow_after):
                objects = cell.shadow_objects
                if slot > len(objects) or (slot > 0 and objects[slot - 1] is not before):
                    # the list changed meanwhile (a mover handed in while this one waited on its hand-over):
                    # back behind the object it followed, ahead of everything added since
                    slot = objects.index(before) + 1 if before in objects else len(objects)
                objects.insert(slot, obstacle)
        mover.shadow_cells = list(self.shadow_cells)
        self.snapshot.restore()
        mover.seq = self.seq
        mover.last = self.last
