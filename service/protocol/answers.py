"""The kinds of value a query's answer holds: each written by the service and read back by the client.

An answer declaration (service/protocol/queries.py) is a tuple of `Out`s, one per field of the engine's
result class, named as the wire names it. The service writes an answer with `write(value, blocker_id)`
(`blocker_id` maps the engine's object ids to the wire's); the client reads it back with `read(raw)`, to
the same engine type, without checking what the service wrote.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from engine.geometry import Position, Quat, Vec3
from engine import Blocker

from service.protocol.codec import decode_plane, decode_position, encode_plane, encode_position, encode_vec

__all__ = ["Out", "IdMap", "REAL", "COUNT", "FLAG", "TEXT", "CELL", "POSITION", "VECTOR", "PLANE", "BLOCKER",
           "POSITIONS", "out"]

#: the engine's object id of a blocker -> the id the wire names it by
IdMap = Callable[[int], int]


@dataclass(frozen=True, slots=True)
class OutKind:
    """How an answer value is written (`write(value, ids)`) and read back (`read(raw)`); `doc` is its type
    as protocol.md spells it."""

    doc: str
    write: Callable[[Any, IdMap], Any]
    read: Callable[[Any], Any]


@dataclass(frozen=True, slots=True)
class Out:
    """One field of an answer: its wire name (the result class's attribute of the same name) and kind."""

    name: str
    kind: OutKind


def out(*fields: tuple[str, OutKind]) -> tuple[Out, ...]:
    return tuple(Out(name, kind) for name, kind in fields)


def _position(raw: Any) -> Position | None:
    return None if raw is None else decode_position(raw, "answer", default_orientation=Quat())


def _blocker_out(b: Blocker | None, ids: IdMap) -> dict[str, Any] | None:
    if b is None:
        return None
    return {"kind": b.kind, "object_id": None if b.object_id is None else ids(b.object_id)}


def _blocker_in(raw: Any) -> Blocker | None:
    if raw is None:
        return None
    object_id = raw.get("object_id")
    return Blocker(str(raw["kind"]), None if object_id is None else int(object_id))


REAL = OutKind("float", lambda v, ids: v, lambda raw: float(raw))
COUNT = OutKind("uint", lambda v, ids: v, lambda raw: int(raw))
FLAG = OutKind("bool", lambda v, ids: v, lambda raw: bool(raw) if raw is not None else False)
TEXT = OutKind("string or null", lambda v, ids: v, lambda raw: None if raw is None else str(raw))
#: a cell id, or null
CELL = OutKind("uint32 or null", lambda v, ids: v, lambda raw: None if raw is None else int(raw))
POSITION = OutKind("Position or null", lambda v, ids: None if v is None else encode_position(v), _position)
VECTOR = OutKind("Vector or null", lambda v, ids: encode_vec(v),
                 lambda raw: None if raw is None else Vec3(float(raw[0]), float(raw[1]), float(raw[2])))
PLANE = OutKind("Plane or null", lambda v, ids: encode_plane(v),
                lambda raw: None if raw is None else decode_plane(raw, "answer.plane"))
BLOCKER = OutKind("Blocker or null", _blocker_out, _blocker_in)
POSITIONS = OutKind("[Position, ...]", lambda v, ids: [encode_position(p) for p in v],
                    lambda raw: [_position(p) for p in raw])
