"""The engine's value types to and from their wire maps: service/protocol/messages.py's declarations applied.

Only the engine's plain value types are used here (geometry and `engine.world.types`), so the client
library shares this codec without pulling in the World. Readers validate as they go and raise
ProtocolError naming the field; writers trust their input.
"""

from __future__ import annotations

from typing import Any

import msgpack

from engine.geometry import Plane, Position, Quat, Vec3
from engine import MoverSpec, MoveResult

from service.protocol.messages import MAX_SPHERES, MOVER_SPEC, PLANE, POSITION, STATE, TARGET
from service.protocol.state_packer import pack_State

__all__ = [
    "decode_position",
    "decode_plane",
    "decode_mover_spec",
    "encode_position",
    "encode_plane",
    "encode_vec",
    "encode_mover_spec",
    "encode_state",
    "pack_state",
    "decode_state",
    "read_state",
    "MAX_SPHERES",
]


# -- reading ------------------------------------------------------------------------------------------
def decode_position(value: Any, path: str, *, default_cell: int | None = None,
                    default_orientation: Quat | None = None) -> Position:
    """A Position map; with `default_cell`, its cell may be left out (the orientation always may: identity,
    or `default_orientation`)."""
    if default_cell is None and default_orientation is None:
        return POSITION.read(value, path)  # type: ignore[no-any-return]
    t = TARGET.read(value, path)
    cell = default_cell if t.cell is None else t.cell
    if cell is None:
        return POSITION.read(value, path)  # type: ignore[no-any-return]  # raises missing_field for `cell`
    return Position.at(cell, t.origin, t.orientation or default_orientation or Quat())


def decode_plane(value: Any, path: str) -> Plane:
    return PLANE.read(value, path)  # type: ignore[no-any-return]


def decode_mover_spec(value: Any, path: str) -> MoverSpec:
    """A MoverSpec map (the trace format's `object` block)."""
    return MOVER_SPEC.read(value, path)  # type: ignore[no-any-return]


StateTuple = tuple[int, int, int | str | None, MoveResult]

#: the State read without the per-field readers (generated from STATE); None when anything is off
_plain_state: Any = lambda m: STATE.fast_reader(m, "state")  # noqa: E731 - the generated reader, path fixed


def read_state(value: Any, path: str = "state") -> StateTuple:
    """A State map to (id, seq, tag, MoveResult) through the per-field readers: what any sender may write,
    and errors naming the field."""
    return STATE.read(value, path)  # type: ignore[no-any-return]


_fast_state = STATE.fast_reader


def decode_state(value: Any, path: str = "state") -> StateTuple:
    """A State map back to (id, seq, tag, MoveResult): the client's side."""
    plain = _fast_state(value, path)
    return plain if plain is not None else read_state(value, path)  # type: ignore[no-any-return]


# -- writing ------------------------------------------------------------------------------------------
def encode_vec(v: Vec3 | None) -> list[float] | None:
    return None if v is None else [v.x, v.y, v.z]


encode_position = POSITION.encode_fn()
_encode_plane = PLANE.encode_fn()
encode_mover_spec = MOVER_SPEC.encode_fn()


def encode_plane(p: Plane | None) -> dict[str, Any] | None:
    return None if p is None else _encode_plane(p)


#: `pack_state(mover_id, seq, r, collide_ids, tag=None)`: the State's msgpack bytes, written from STATE's
#: fields (floats as float64; ids, seq, cell and landblock in fixed-width integers, as msgpack allows;
#: the tag, when given, last). This runs once per move: its code is generated into a module
#: (service/protocol/generate.py), which the compiled install compiles.
pack_state = pack_State


def encode_state(mover_id: int, seq: int, r: MoveResult, collide_ids: list[int],
                 tag: int | str | None = None) -> dict[str, Any]:
    """The State map: what a move resolved to, as published and replied (the packed State, read back)."""
    return msgpack.unpackb(pack_state(mover_id, seq, r, collide_ids, tag), raw=False)  # type: ignore[no-any-return]
