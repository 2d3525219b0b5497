"""What one record of the state log (service/persistence/journal.py) holds, and the core's side of writing them.

A record is one request's resolved changes, one kind per record:

    kind u8, n u32, then by kind:
    MOVES        ids n x u64, seqs n x u64, states n x MOVER_STATE_BYTES
    REGISTER     as MOVES, then a msgpack array of n mover maps (the spec as registered)
    UPDATE       as REGISTER (the spec as updated)
    HANDOVER_IN  as REGISTER (a mover taken from another instance)
    REMOVE       ids n x u64
    HANDING_OVER ids n x u64, then landblocks n x u32: a hand-over about to be sent (synced first)
    HANDOVER_OUT as HANDING_OVER: the owner of the landblock took the mover
    HANDOVER_FAILED ids n x u64: no owner took it; it stays here

all little-endian. A state is the mover's whole engine state as
engine.world.batch.write_mover_state writes it (place, contact plane and
cell, transient flags, sliding normal, velocity, acceleration, time and
motion held over), so a replayed mover is the one that answered, bit for
bit. A MOVES record holds each mover's state after the request's last move
of it (replay keeps the last row of each id).
"""

from __future__ import annotations

import struct
from array import array
from typing import Any, Final

import msgpack
from librt.strings import BytesWriter

from engine.geometry import Plane, Position, Quat, Vec3
from engine.world.batch import MOVER_STATE_BYTES, write_mover_state
from engine import Mover
from engine.world.transient import TS

from service.persistence.journal import Journal

__all__ = [
    "MOVES", "REGISTER", "UPDATE", "HANDOVER_IN", "REMOVE", "HANDOVER_OUT", "HANDING_OVER", "HANDOVER_FAILED",
    "KIND_NAMES", "RECORD_HEAD",
    "MoverLog", "MoverState", "decode_state", "apply_state", "mover_state_bytes",
]

MOVES: Final = 1
REGISTER: Final = 2
UPDATE: Final = 3
HANDOVER_IN: Final = 4
REMOVE: Final = 5
HANDOVER_OUT: Final = 6
HANDING_OVER: Final = 7
HANDOVER_FAILED: Final = 8
KIND_NAMES: Final = {MOVES: "moves", REGISTER: "register", UPDATE: "update", HANDOVER_IN: "handover-in",
                     REMOVE: "remove", HANDOVER_OUT: "handover-out", HANDING_OVER: "handing-over",
                     HANDOVER_FAILED: "handover-failed"}
RECORD_HEAD: Final = struct.Struct("<BI")
_STATE: Final = struct.Struct("<4q24d")
assert _STATE.size == MOVER_STATE_BYTES


def mover_state_bytes(mover: Mover) -> bytes:
    """`mover`'s whole state (engine.world.batch.write_mover_state) as bytes."""
    w = BytesWriter()
    write_mover_state(w, mover)
    return w.getvalue()


def _transient_flag(bit: int) -> Any:
    """A read-only property: whether the state's transient bits have `bit` (engine.world.transient.TS)."""
    def read(self: MoverState) -> bool:
        return bool(self.transient & bit)
    return property(read)


class MoverState:
    """A mover's state decoded from MOVER_STATE_BYTES bytes."""

    __slots__ = ("cell_id", "transient", "contact_plane_cell_id", "missile", "colliding_with_environment",
                 "position", "contact_plane", "sliding_normal", "velocity", "acceleration", "held_time", "held_motion")

    def __init__(self, raw: bytes) -> None:
        v = _STATE.unpack(raw)
        self.cell_id: int = v[0]
        self.transient: int = v[1]
        self.contact_plane_cell_id: int = v[2]
        self.missile = bool(v[3] & 1)
        self.colliding_with_environment = bool(v[3] & 2)
        self.position = Position.at(v[0], Vec3(v[4], v[5], v[6]), Quat(v[7], v[8], v[9], v[10]))
        self.contact_plane = Plane(Vec3(v[11], v[12], v[13]), v[14])
        self.sliding_normal = Vec3(v[15], v[16], v[17])
        self.velocity = Vec3(v[18], v[19], v[20])
        self.acceleration = Vec3(v[21], v[22], v[23])
        self.held_time: float = v[24]
        self.held_motion = Vec3(v[25], v[26], v[27])

    contact = _transient_flag(TS.CONTACT)
    on_walkable = _transient_flag(TS.ON_WALKABLE)
    sliding = _transient_flag(TS.SLIDING)
    water_contact = _transient_flag(TS.WATER_CONTACT)


def decode_state(raw: bytes) -> MoverState:
    if len(raw) != MOVER_STATE_BYTES:
        raise ValueError(f"a mover state is {MOVER_STATE_BYTES} bytes, not {len(raw)}")
    return MoverState(raw)


def apply_state(mover: Mover, state: MoverState) -> None:
    """Give an engine mover (added at `state.position`) the rest of `state`: it then moves on as the one
    that wrote it would have."""
    mover.transient = state.transient
    mover.contact_plane = state.contact_plane
    mover.contact_plane_cell_id = state.contact_plane_cell_id
    mover.sliding_normal = state.sliding_normal
    mover.velocity = state.velocity
    mover.acceleration = state.acceleration
    mover.held_time = state.held_time
    mover.held_motion = state.held_motion
    mover.missile = state.missile
    mover.colliding_with_environment = state.colliding_with_environment


class MoverLog:
    """The core's writer of records: the moves of the request running are gathered (`moved`, `moved_rows`)
    and become one MOVES record at `commit` (or before a record of another kind, keeping the order)."""

    __slots__ = ("journal", "_ids", "_seqs", "_states", "_count", "_row_states")

    def __init__(self, journal: Journal) -> None:
        self.journal = journal
        self._ids = array("Q")
        self._seqs = array("Q")
        self._states = BytesWriter()
        self._count = 0
        self._row_states = BytesWriter()

    def row_states(self) -> BytesWriter:
        """The writer a column batch's engine rows put each mover's state in (BatchRows.states), emptied: one
        for every request, so that its buffer is not grown from nothing again (a copy at each doubling) for
        each. Its bytes are valid until the next request's call; `moved_rows` is given a copy."""
        w = self._row_states
        w.truncate(0)
        return w

    @property
    def always(self) -> bool:
        """Whether each request's records are synced before its reply (and its States published after)."""
        return self.journal.always

    # -- moves -----------------------------------------------------------------------------------------
    def moved(self, mover_id: int, seq: int, mover: Mover) -> None:
        """One resolved move of the map form: the mover as it stands after it."""
        self._ids.append(mover_id)
        self._seqs.append(seq)
        write_mover_state(self._states, mover)
        self._count += 1

    def moved_rows(self, ids: bytes, seqs: bytes, states: bytes, n: int) -> None:
        """`n` resolved moves of a column batch: their ids and seqs (uint64, little-endian) and states (the
        engine's, beside its rows), one each."""
        if n:
            if self._count:
                self._flush()
            self.journal.append(RECORD_HEAD.pack(MOVES, n), ids, seqs, states, moves=n)

    def _flush(self) -> None:
        n = self._count
        if not n:
            return
        parts = (RECORD_HEAD.pack(MOVES, n), self._ids.tobytes(), self._seqs.tobytes(), self._states.getvalue())
        self._ids = array("Q")
        self._seqs = array("Q")
        self._states.truncate(0)  # (its bytes were copied: the buffer is kept, not grown again)
        self._count = 0
        self.journal.append(*parts, moves=n)

    # -- other changes ---------------------------------------------------------------------------------
    def movers(self, kind: int, mover_id: int, seq: int, mover: Mover, spec: dict[str, Any]) -> None:
        """A register, update or hand-over in: the mover's state and its spec (as a map)."""
        self._flush()
        head = RECORD_HEAD.pack(kind, 1) + struct.pack("<QQ", mover_id, seq)
        self.journal.append(head + mover_state_bytes(mover) + msgpack.packb([spec], use_bin_type=True))

    def removed(self, mover_id: int) -> None:
        self._flush()
        self.journal.append(RECORD_HEAD.pack(REMOVE, 1) + struct.pack("<Q", mover_id))

    def handing_over(self, mover_id: int, landblock: int) -> None:
        """A hand-over to `landblock`'s owner is about to be sent: on disk before it goes (after the mover's
        moves so far in this request), so that a start after a kill knows to ask that owner whether it
        took the mover, rather than hold it twice."""
        self._flush()
        self.journal.append(RECORD_HEAD.pack(HANDING_OVER, 1) + struct.pack("<QI", mover_id, landblock))
        self.journal.commit(durable=True)

    def handed_over(self, mover_id: int, landblock: int) -> None:
        """The mover left for `landblock`'s owner."""
        self._flush()
        self.journal.append(RECORD_HEAD.pack(HANDOVER_OUT, 1) + struct.pack("<QI", mover_id, landblock))

    def handover_failed(self, mover_id: int) -> None:
        """No owner took the mover: it stays here, as before the move."""
        self._flush()
        self.journal.append(RECORD_HEAD.pack(HANDOVER_FAILED, 1) + struct.pack("<Q", mover_id))

    def commit(self, durable: bool = False) -> None:
        """The request is done: its records go to the journal, synced now under `always` or `durable`."""
        self._flush()
        self.journal.commit(durable)
