"""Decoding request messages: the envelope, then each operation's fields.

The envelope check (size, msgpack, map, version) fails the whole request;
inside a batch each move is decoded on its own so one bad item only fails
itself.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import msgpack

from engine import limits
from engine.constants import HUGE_QUANTUM
from engine.errors import EngineError
from engine.geometry import Plane, Position, Quat, Vec3
from engine.world.types import MoverSpec

from .codec import decode_mover_spec, decode_plane, decode_position
from .errors import ProtocolError
from .validate import (
    as_bool,
    as_float,
    as_list,
    as_map,
    as_quat,
    as_uint,
    as_vec3,
    field_path,
    get_field,
    opt_field,
    plain_floats3,
    plain_unit_quat,
)
from .wire import MAX_BATCH, MAX_PAYLOAD, PROTOCOL_VERSION, ErrorKind

__all__ = [
    "decode_envelope",
    "Target",
    "MoveItem",
    "ItemError",
    "MoveBatch",
    "PUBLISH_MODES",
    "parse_moves",
    "RegisterRequest",
    "parse_register",
    "parse_id",
    "parse_update",
    "HandoverRequest",
    "parse_handover",
]

MAX_TAG_LEN = 256


def decode_envelope(payload: bytes | None, *, allow_empty: bool = False) -> dict[str, Any]:
    """Bytes to the request map, checking size, encoding and `v`."""
    if not payload:
        if allow_empty:
            return {"v": PROTOCOL_VERSION}
        raise ProtocolError(ErrorKind.MALFORMED, "empty payload: expected a msgpack map")
    if len(payload) > MAX_PAYLOAD:
        raise ProtocolError(ErrorKind.TOO_LARGE, f"payload of {len(payload)} bytes exceeds {MAX_PAYLOAD}")
    try:
        msg = msgpack.unpackb(payload, raw=False, strict_map_key=False)
    except Exception as e:  # msgpack raises several unrelated types (ExtraData, ValueError, ...)
        raise ProtocolError(ErrorKind.MALFORMED, f"payload is not valid msgpack: {type(e).__name__}: {e}") from None
    if not isinstance(msg, dict):
        raise ProtocolError(ErrorKind.MALFORMED, f"payload is msgpack but not a map ({type(msg).__name__})")
    msg = as_map(msg, "")
    v = msg.get("v")
    if v is None:
        raise ProtocolError(ErrorKind.MISSING_FIELD, "v: protocol version is missing", "v")
    if isinstance(v, bool) or not isinstance(v, int):
        raise ProtocolError(ErrorKind.WRONG_TYPE, "v: protocol version must be an integer", "v")
    if v != PROTOCOL_VERSION:
        raise ProtocolError(
            ErrorKind.UNSUPPORTED_VERSION, f"protocol version {v} is not supported (this service speaks {PROTOCOL_VERSION})", "v"
        )
    return msg


def _parse_tag(m: dict[str, Any], path: str) -> int | str | None:
    tag = m.get("tag")
    if tag is None:
        return None
    p = field_path(path, "tag")
    if isinstance(tag, bool) or not isinstance(tag, (int, str)):
        raise ProtocolError(ErrorKind.WRONG_TYPE, f"{p}: expected integer or string", p)
    if isinstance(tag, str) and len(tag) > MAX_TAG_LEN:
        raise ProtocolError(ErrorKind.TOO_LARGE, f"{p}: longer than {MAX_TAG_LEN} characters", p)
    if isinstance(tag, int) and not -(1 << 63) <= tag < (1 << 64):
        raise ProtocolError(ErrorKind.BAD_VALUE, f"{p}: out of 64-bit range", p)
    return tag


@dataclass(slots=True)
class Target:
    """A move's `to`: cell and orientation default to the mover's current ones."""

    cell: int | None
    origin: Vec3
    orientation: Quat | None

    def resolve(self, current: Position) -> Position:
        cell = current.cell_id if self.cell is None else self.cell
        q = current.frame.orientation if self.orientation is None else self.orientation
        return Position.at(cell, self.origin, q)


@dataclass(slots=True)
class MoveItem:
    """One move: exactly one of `to`, `offset` (transition) or `motion` + `dt` (physics step)."""

    id: int
    tag: int | str | None
    path: str
    to: Target | None = None
    offset: Vec3 | None = None
    motion: Vec3 | None = None
    dt: float | None = None
    velocity: Vec3 | None = None


@dataclass(slots=True)
class ItemError:
    """A batch item that failed; `id` and `tag` when they could be read."""

    error: ProtocolError
    id: int | None = None
    tag: int | str | None = None

    def to_wire(self) -> dict[str, Any]:
        out: dict[str, Any] = {"id": self.id, "error": self.error.to_wire()}
        if self.tag is not None:
            out["tag"] = self.tag
        return out


@dataclass(slots=True)
class MoveBatch:
    single: bool  # sent as {"move": ...}: reply {"state": ...}, not {"results": [...]}
    items: list[MoveItem | ItemError]
    #: `"publish": "batch"`: the request's States go out as one message on P/states, not one per mover
    publish_batch: bool = False


PUBLISH_MODES = ("each", "batch")


def _parse_publish(msg: dict[str, Any]) -> bool:
    """The request's `publish` field: True for "batch", False for "each" or absent."""
    mode = msg.get("publish")
    if mode is None or mode == "each":
        return False
    if mode == "batch":
        return True
    if not isinstance(mode, str):
        raise ProtocolError(ErrorKind.WRONG_TYPE, "publish: expected a string (each or batch)", "publish")
    raise ProtocolError(ErrorKind.BAD_VALUE, f"publish: {mode[:40]!r} is not one of each, batch", "publish")


def _parse_target(value: Any, path: str) -> Target:
    m = as_map(value, path)
    cell_raw = opt_field(m, "cell")
    q_raw = opt_field(m, "orientation")
    return Target(
        cell=None if cell_raw is None else as_uint(cell_raw, field_path(path, "cell"), 32),
        origin=Vec3(*as_vec3(get_field(m, "origin", path), field_path(path, "origin"))),
        orientation=None if q_raw is None else Quat(*as_quat(q_raw, field_path(path, "orientation"))),
    )


def _plain_vec(v: Any) -> Vec3 | None:
    t = plain_floats3(v)
    return None if t is None else Vec3(*t)


def _plain_move(m: Any, path: str) -> MoveItem | None:
    """The common shapes of a move, read without the per-field readers: an `offset` or a `to` with
    floats, an optional tag and velocity, no other key. None when the move is anything else, or
    anything is off; the full reader (`parse_move_item`) then decides, so every error and its message
    come from one place."""
    if type(m) is not dict:
        return None
    mid = m.get("id")
    if type(mid) is not int or mid < 0 or mid >= 1 << 64:
        return None
    tag = m.get("tag")
    if tag is not None and not ((type(tag) is int and -(1 << 63) <= tag < 1 << 64)
                                or (type(tag) is str and len(tag) <= MAX_TAG_LEN)):
        return None
    # every key is a known one (so all are strings and nothing is ignored silently)
    if len(m) != 2 + ("tag" in m) + ("velocity" in m):
        return None
    item = MoveItem(mid, tag, path)
    vel = m.get("velocity")
    if vel is not None:
        item.velocity = _plain_vec(vel)
        if item.velocity is None:
            return None
    off = m.get("offset")
    if off is not None:
        item.offset = _plain_vec(off)
        return item if item.offset is not None else None
    to = m.get("to")
    if type(to) is not dict or len(to) != 1 + ("cell" in to) + ("orientation" in to):
        return None
    origin = _plain_vec(to.get("origin"))
    cell = to.get("cell")
    if origin is None or (cell is not None and (type(cell) is not int or cell < 0 or cell >= 1 << 32)):
        return None
    q = to.get("orientation")
    quat = None
    if q is not None:
        t = plain_unit_quat(q)
        if t is None:
            return None
        quat = Quat(*t)
    item.to = Target(cell, origin, quat)
    return item


def parse_move_item(value: Any, path: str) -> MoveItem:
    plain = _plain_move(value, path)
    return plain if plain is not None else read_move_item(value, path)


def read_move_item(value: Any, path: str) -> MoveItem:
    """A move through the per-field readers: any shape, and the error that names the field."""
    m = as_map(value, path)
    item = MoveItem(
        id=as_uint(get_field(m, "id", path), field_path(path, "id")),
        tag=_parse_tag(m, path),
        path=path,
    )
    given = [k for k in ("to", "offset", "motion") if m.get(k) is not None]
    if len(given) != 1:
        what = "none" if not given else " and ".join(given)
        raise ProtocolError(
            ErrorKind.MISSING_FIELD if not given else ErrorKind.BAD_VALUE,
            f"{path or 'move'}: give exactly one of to, offset, motion (got {what})",
            path or None,
        )
    kind = given[0]
    if kind == "to":
        item.to = _parse_target(m["to"], field_path(path, "to"))
    elif kind == "offset":
        item.offset = Vec3(*as_vec3(m["offset"], field_path(path, "offset")))
    else:
        item.motion = Vec3(*as_vec3(m["motion"], field_path(path, "motion")))
        _checked(limits.check_motion, item.motion, field_path(path, "motion"))
        dt = as_float(get_field(m, "dt", path), field_path(path, "dt"))
        if dt <= 0.0 or dt > HUGE_QUANTUM:
            # the longest frame the client resolves (engine.constants.HUGE_QUANTUM)
            p = field_path(path, "dt")
            raise ProtocolError(ErrorKind.BAD_VALUE, f"{p}: must be in (0, {HUGE_QUANTUM:g}] seconds, got {dt}", p)
        item.dt = dt
    vel = m.get("velocity")
    if vel is not None:
        if kind == "motion":
            p = field_path(path, "velocity")
            raise ProtocolError(ErrorKind.BAD_VALUE, f"{p}: a physics step integrates its own velocity", p)
        # its speed limit is the engine's to check (World.move), as for the fast path's moves
        item.velocity = Vec3(*as_vec3(vel, field_path(path, "velocity")))
    return item


def _checked(check: Any, value: Any, path: str) -> None:
    """Run an engine.limits check on a decoded value; its refusal as the field's error."""
    try:
        check(value, path)
    except EngineError as e:
        kind = ErrorKind.NON_FINITE if type(e).__name__ == "NonFiniteError" else ErrorKind.BAD_VALUE
        raise ProtocolError(kind, str(e), e.field or path) from None


def _item_or_error(value: Any, path: str) -> MoveItem | ItemError:
    try:
        return parse_move_item(value, path)
    except ProtocolError as e:
        mid = tag = None
        if isinstance(value, dict):
            raw_id, raw_tag = value.get("id"), value.get("tag")
            if isinstance(raw_id, int) and not isinstance(raw_id, bool) and 0 <= raw_id < (1 << 64):
                mid = raw_id
            if isinstance(raw_tag, (int, str)) and not isinstance(raw_tag, bool):
                tag = raw_tag
        return ItemError(e, mid, tag)


def parse_moves(msg: dict[str, Any]) -> MoveBatch:
    """`{"move": Move}` or `{"moves": [Move, ...]}`."""
    has_one, has_many = msg.get("move") is not None, msg.get("moves") is not None
    if has_one == has_many:
        raise ProtocolError(
            ErrorKind.MISSING_FIELD if not has_one else ErrorKind.BAD_VALUE,
            "give exactly one of move (one move) or moves (a batch)",
        )
    publish_batch = _parse_publish(msg)
    if has_one:
        return MoveBatch(True, [parse_move_item(msg["move"], "move")], publish_batch)
    items = as_list(msg["moves"], "moves", MAX_BATCH)
    return MoveBatch(False, [_item_or_error(v, field_path("moves", i)) for i, v in enumerate(items)], publish_batch)


@dataclass(slots=True)
class RegisterRequest:
    id: int | None
    spec: MoverSpec
    position: Position
    contact_plane: Plane | None
    contact_plane_cell: int | None
    sliding_normal: Vec3 | None = None
    water_contact: bool = False


def _contact(msg: dict[str, Any], position: Position) -> tuple[Plane | None, int | None]:
    raw = msg.get("contact_plane")
    if raw is None:
        return None, None
    plane = decode_plane(raw, "contact_plane")
    cell_raw = msg.get("contact_plane_cell")
    cell = position.cell_id if cell_raw is None else as_uint(cell_raw, "contact_plane_cell", 32)
    return plane, cell


def parse_register(msg: dict[str, Any]) -> RegisterRequest:
    raw_id = msg.get("id")
    mover_id = None if raw_id is None else as_uint(raw_id, "id")
    if mover_id == 0:
        raise ProtocolError(ErrorKind.BAD_VALUE, "id: 0 is reserved (omit id to have one assigned)", "id")
    spec = decode_mover_spec(get_field(msg, "mover", ""), "mover")
    position = decode_position(get_field(msg, "position", ""), "position")
    try:
        limits.check_start(position, "position", limits.start_slack(spec))
    except EngineError as e:
        raise ProtocolError(ErrorKind.BAD_VALUE, str(e), e.field or "position") from None
    plane, cell = _contact(msg, position)
    if plane is not None:
        _checked(limits.check_plane, plane, "contact_plane")
    sn = msg.get("sliding_normal")
    sliding = None if sn is None else Vec3(*as_vec3(sn, "sliding_normal"))
    if sliding is not None:
        _checked(limits.check_unit_vector, sliding, "sliding_normal")
    wc = msg.get("water_contact")
    return RegisterRequest(
        mover_id, spec, position, plane, cell, sliding,
        False if wc is None else as_bool(wc, "water_contact"),
    )


def parse_id(msg: dict[str, Any]) -> int:
    return as_uint(get_field(msg, "id", ""), "id")


def parse_update(msg: dict[str, Any]) -> tuple[int, MoverSpec]:
    return parse_id(msg), decode_mover_spec(get_field(msg, "mover", ""), "mover")


@dataclass(slots=True)
class HandoverRequest:
    """A mover's state passed from one instance to the next landblock's owner."""

    id: int
    seq: int
    spec: MoverSpec
    position: Position
    contact_plane: Plane | None
    contact_plane_cell: int | None
    sliding_normal: Vec3 | None
    water_contact: bool
    source: str


def parse_handover(msg: dict[str, Any]) -> HandoverRequest:
    reg = parse_register(msg)
    if reg.id is None:
        raise ProtocolError(ErrorKind.MISSING_FIELD, "id: required field is missing", "id")
    seq = as_uint(get_field(msg, "seq", ""), "seq")
    src = msg.get("from")
    return HandoverRequest(
        reg.id, seq, reg.spec, reg.position, reg.contact_plane, reg.contact_plane_cell, reg.sliding_normal,
        reg.water_contact, str(src) if src else "?",
    )
