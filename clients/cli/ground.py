"""Put a mover on the ground below it: what `acphys move --start ... --motion` does first.

A mover registered at a height is out of contact, and a physics step from
rest does nothing useful there (own motion only acts on the ground; gravity
starts from zero speed). The client never leaves an object so: a new object
is placed where it stands, on the surface below it. Here that placement is a
straight drop resolved by transitions (the client's `CPhysicsObj::transition`
toward a point below), a few metres per move because one transition may only
cover so many sub-steps, until the mover is in contact.
"""

from __future__ import annotations

from typing import Protocol

from clients.types import Move, MoverState

__all__ = ["DROP_CHUNK_M", "MAX_DROP_M", "drop_to_ground"]

DROP_CHUNK_M = 5.0  # metres per transition: well inside one transition's sub-step limit
MAX_DROP_M = 300.0  # more than any landscape's height range (the height table tops out near 200 m)


class _Sender(Protocol):
    def send(self, move: Move, timeout: float | None = None) -> MoverState: ...


def drop_to_ground(client: _Sender, state: MoverState) -> MoverState:
    """Move the mover straight down until it is in contact; its state then (unchanged when already in contact).

    Stops without contact when a move makes no progress (nothing below, or the
    mover is stuck) or after MAX_DROP_M."""
    dropped = 0.0
    while not state.contact and dropped < MAX_DROP_M:
        z = state.position.origin.z
        state = client.send(Move(state.id, offset=(0.0, 0.0, -DROP_CHUNK_M)))
        fell = z - state.position.origin.z
        if fell <= 1e-6:
            break
        dropped += fell
    return state
