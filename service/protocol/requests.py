"""Decoding request messages: the envelope, then each operation's fields.

The envelope check (size, msgpack, map, version) fails the whole request;
inside a batch each move is decoded on its own so one bad item only fails
itself. Moves are read with msgspec (service/protocol/move_structs.py); the
mover messages with the readers messages.py's declarations generate.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import msgpack

from service.protocol.errors import ProtocolError
from service.protocol.messages import (
    HANDOVER,
    ID_REQUEST,
    MOVE_REQUEST,
    PUBLISH_MODES,
    REGISTER,
    UPDATE,
    HandoverRequest,
    MoveItem,
    RegisterRequest,
    Target,
)
from service.protocol.schema_kinds import MAX_TAG_LEN, Tag
from service.protocol.move_structs import read_move, read_moves
from service.protocol.validate import as_list, as_map
from service.protocol.wire import MAX_BATCH, MAX_PAYLOAD, PROTOCOL_VERSION, ErrorKind
from engine import MoverSpec

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
    "MAX_TAG_LEN",
]


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
        raise ProtocolError(ErrorKind.MALFORMED, f"payload is not valid msgpack: {str(e) or 'it cannot be decoded'}") from None
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


_PUBLISH = MOVE_REQUEST.by_name["publish"].kind


def _parse_publish(msg: dict[str, Any]) -> bool:
    """The request's `publish` field: True for "batch", False for "each" or absent."""
    mode = msg.get("publish")
    if mode is None or mode == "each":
        return False
    return _PUBLISH.read(mode, "publish") == "batch"


def read_move_item(value: Any, path: str) -> MoveItem:
    """One move of a request map to its MoveItem, or the ProtocolError naming the field: msgspec's
    Structs and the post-pass of service/protocol/move_structs.py."""
    return read_move(value, path)


#: the same reader by its earlier name: the fast reader and the per-field one it stood in front of are one now
parse_move_item = read_move_item


def _plain_move(value: Any, path: str) -> MoveItem | None:
    """The move, or None where it is refused (for a caller that wants no error, only the verdict)."""
    try:
        return read_move(value, path)
    except ProtocolError:
        return None


def _item_error(e: ProtocolError, value: Any) -> ItemError:
    """A batch item's error, with its `id` and `tag` echoed when they are ones the protocol allows."""
    mid = tag = None
    if isinstance(value, dict):
        raw_id, raw_tag = value.get("id"), value.get("tag")
        if isinstance(raw_id, int) and not isinstance(raw_id, bool) and 0 <= raw_id < (1 << 64):
            mid = raw_id
        try:  # echoed only when it is a tag the protocol allows (a 3 MB string is not sent back)
            tag = Tag().read(raw_tag, "tag") if raw_tag is not None else None
        except ProtocolError:
            tag = None
    return ItemError(e, mid, tag)


def parse_single_move(msg: dict[str, Any]) -> tuple[MoveItem, bool]:
    """`{"move": Move}` (the caller has seen `move` and no `moves`): the move, and whether its State is
    published on P/states (`"publish": "batch"`). What `parse_moves` gives, without the batch around it."""
    _single(msg)
    batch = _parse_publish(msg)  # checked first, as in parse_moves
    return read_move(msg["move"], "move"), batch


def _single(msg: dict[str, Any]) -> bool:
    """Whether the request is one move (`move`), not a batch (`moves`); refused when neither or both."""
    has_one, has_many = msg.get("move") is not None, msg.get("moves") is not None
    if has_one == has_many:
        raise ProtocolError(
            ErrorKind.MISSING_FIELD if not has_one else ErrorKind.BAD_VALUE,
            "give exactly one of move (one move) or moves (a batch)",
        )
    return has_one


def parse_moves(msg: dict[str, Any]) -> MoveBatch:
    """`{"move": Move}` or `{"moves": [Move, ...]}`; in a batch each move is read on its own (a bad one
    fails only itself, as its ItemError)."""
    has_one = _single(msg)
    publish_batch = _parse_publish(msg)
    if has_one:
        return MoveBatch(True, [read_move(msg["move"], "move")], publish_batch)
    values = as_list(msg["moves"], "moves", MAX_BATCH)
    read = read_moves(values, "moves")
    return MoveBatch(False, [_item_error(r, v) if isinstance(r, ProtocolError) else r for r, v in zip(read, values, strict=True)],
                     publish_batch)


def parse_register(msg: dict[str, Any]) -> RegisterRequest:
    return REGISTER.read(msg, "")  # type: ignore[no-any-return]


def parse_id(msg: dict[str, Any]) -> int:
    return ID_REQUEST.read(msg, "")  # type: ignore[no-any-return]


def parse_update(msg: dict[str, Any]) -> tuple[int, MoverSpec]:
    return UPDATE.read(msg, "")  # type: ignore[no-any-return]


def parse_handover(msg: dict[str, Any]) -> HandoverRequest:
    return HANDOVER.read(msg, "")  # type: ignore[no-any-return]
