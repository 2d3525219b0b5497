"""A move's reply read straight from its bytes: `{"v", "state": State}` (docs/protocol.md, "State") decoded by
msgspec into typed Structs, then into the MoverState the client returns.

Why: `Client.move` and `Client.step` read one such reply per call. msgpack would build a dict of
every field (each key a new string, hashed and interned) and the State's generated reader
(service/protocol/messages.py, STATE) would then test each value's type in Python; msgspec checks the
same types and bounds in C without building the dict.

Only the shape the service writes is read here: every field STATE declares, with the types and bounds
its fast reader accepts, and no other key (the Structs are generated from STATE's declaration,
service/protocol/structs.py). Anything else (a reply that is not a State, an error, a
field out of bounds, an unknown key) gives None, and the caller reads the reply the usual way
(request_channel.read_reply, then MoverState.from_wire), which answers or raises as it always did:
this module can make a reply cheaper to read, never read it differently.
"""

from __future__ import annotations

from math import isfinite, sqrt
from collections.abc import Callable
from typing import Any

import msgspec

from engine.geometry import Frame, Plane, Position, Quat, Vec3
from service.protocol.codec import StateTuple
from service.protocol.messages import PLANE, STATE
from service.protocol.structs import struct_of

from clients.types import MoverState

__all__ = ["decode_state_reply"]

#: STATE's Struct (service/protocol/structs.py), with what the declaration cannot say of the reply
_StateS = struct_of(
    STATE, name="StateReplyState",
    # the service always writes it; a State without it is left to the usual reader (its default)
    required=("position.orientation",),
    # its numbers unbounded: the unit length checked below refuses what float32's bounds would (NaN,
    # ±infinity, beyond float32), and the bounds cost a reply ~330 instructions (callgrind)
    types={"position.orientation": tuple[float, float, float, float]},
    # the order the service writes the fields in (codec.pack_state): msgspec looks for the next key
    # where the last one matched first
    written_order=True,
    forbid_unknown_fields=True, gc=False)
#: the reply envelope: its other keys (`v`) are not read, as the usual path does not read them
_StateReplyS = msgspec.defstruct("StateReply", [("state", _StateS)], gc=False)

_decode: Callable[[bytes], Any] = msgspec.msgpack.Decoder(_StateReplyS).decode
#: STATE's own build and rules: the values become the same objects the usual reader makes
_build_state: Callable[..., StateTuple] = STATE.build  # type: ignore[assignment]
_plane_rules = tuple(r.holds for r in PLANE.rules)


def decode_state_reply(payload: bytes) -> MoverState | None:
    """The MoverState of a State reply in the shape the service writes; None for anything else (the
    caller then reads the reply the usual way, and gets its answer or error from there)."""
    try:
        s = _decode(payload).state
    except (msgspec.DecodeError, msgspec.ValidationError):
        return None
    p = s.position
    w, x, y, z = p.orientation
    n2 = w * w + x * x + y * y + z * z
    if not (isfinite(n2) and abs(sqrt(n2) - 1.0) <= 1e-3):  # STATE's unit quaternion, within 1e-3
        return None
    ox, oy, oz = p.origin
    position = Position(p.cell, Frame(Vec3(ox, oy, oz), Quat(w, x, y, z)))  # Position.at, one call fewer
    plane = None
    if s.contact_plane is not None:
        (a, b, c), d = s.contact_plane.normal, s.contact_plane.d
        plane = Plane(Vec3(a, b, c), d)
        for holds in _plane_rules:
            if not holds(plane):
                return None
    cn = None if s.collision_normal is None else Vec3(*s.collision_normal)
    sn = None if s.sliding_normal is None else Vec3(*s.sliding_normal)
    return MoverState(*_build_state(
        s.id, s.seq, s.tag, s.ok, position, s.transition_state, s.contact, s.on_walkable, plane,
        s.contact_plane_cell, cn, sn, s.water_contact, s.frames_stationary_fall, s.transient_state,
        s.collide_objects))
