"""msgspec straight from the bytes: the service's move Structs (service/protocol/move_structs.py) in typed
envelopes, decoded from a request's msgpack, for the wire-decoding benchmark (benchmarks/bench_wire_decoding.py).

The service converts the map msgpack.unpackb gave (service/bus/node.py decodes every request with
decode_envelope before it knows the operation); these decoders skip that step, so the benchmark shows what
handing the request's bytes to msgspec would save. The post-pass and the error mapping are the service's own
(move_structs.move_item and protocol_error); the column form's envelope and a register's id, which the
service still reads from the map, are decoded here the same way, each column a memoryview of the bytes.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

import msgpack
import msgspec
import numpy as np

from service.protocol.column_request import ColumnRequest, _bad_reals
from service.protocol.columns import REQUEST_COLUMNS
from service.protocol.errors import ProtocolError
from service.protocol.messages import MoveItem
from service.protocol.move_structs import MoveS, move_item
from service.protocol.move_structs import protocol_error as _protocol_error
from service.protocol.wire import MAX_BATCH, MAX_PAYLOAD, PROTOCOL_VERSION, ErrorKind

__all__ = ["decode_structs", "decode_single", "decode_batch", "decode_batch_typed", "decode_columns", "decode_register_id",
           "protocol_error"]

# -- the envelopes around the service's MoveS ----------------------------------------------------------
class MoveRequestS(msgspec.Struct):
    """The whole request typed: one bad move fails the decoding of all (the fast path)."""

    v: int
    move: MoveS | None = None
    moves: Annotated[list[MoveS], msgspec.Meta(max_length=MAX_BATCH)] | None = None
    publish: Literal["each", "batch"] | None = None


class MoveRequestRawS(msgspec.Struct):
    """The request with its moves left as msgpack bytes, each decoded on its own (a bad one fails itself)."""

    v: int
    move: msgspec.Raw | None = None
    moves: Annotated[list[msgspec.Raw], msgspec.Meta(max_length=MAX_BATCH)] | None = None
    publish: Literal["each", "batch"] | None = None


class ColumnsS(msgspec.Struct, forbid_unknown_fields=True):  # type: ignore[call-arg]  # msgspec untyped here
    """Each column a view of the payload's bytes (msgspec decodes `bin` into a memoryview without a copy).
    A column name the form does not know is refused, as parse_column_request refuses it."""

    id: memoryview | None = None
    offset: memoryview | None = None
    to_cell: memoryview | None = None
    to_origin: memoryview | None = None
    to_orientation: memoryview | None = None
    motion: memoryview | None = None
    dt: memoryview | None = None
    velocity: memoryview | None = None


class ColumnRequestS(msgspec.Struct):
    """A column request's envelope; `move` and `moves` only to refuse them beside `columns`."""

    v: int
    kind: Literal["offset", "to", "motion"]
    columns: ColumnsS
    publish: Literal["each", "batch", "columns"] | None = None
    move: msgspec.Raw | None = None
    moves: msgspec.Raw | None = None


class RegisterIdS(msgspec.Struct):
    """A register's `id` alone (the other fields are ignored as unknown keys): 0 is reserved."""

    id: Annotated[int, msgspec.Meta(ge=1)] | None = None


_REQUEST = msgspec.msgpack.Decoder(MoveRequestS)
_REQUEST_RAW = msgspec.msgpack.Decoder(MoveRequestRawS)
_MOVE = msgspec.msgpack.Decoder(MoveS)
_COLUMNS = msgspec.msgpack.Decoder(ColumnRequestS)
_REGISTER_ID = msgspec.msgpack.Decoder(RegisterIdS)


# -- from the bytes to the service's values ---------------------------------------------------------------
def _envelope(payload: bytes) -> None:
    if not payload:
        raise ProtocolError(ErrorKind.MALFORMED, "empty payload: expected a msgpack map")
    if len(payload) > MAX_PAYLOAD:
        raise ProtocolError(ErrorKind.TOO_LARGE, f"payload of {len(payload)} bytes exceeds {MAX_PAYLOAD}")


def _version(v: int) -> None:
    if v != PROTOCOL_VERSION:
        raise ProtocolError(ErrorKind.UNSUPPORTED_VERSION,
                            f"protocol version {v} is not supported (this service speaks {PROTOCOL_VERSION})", "v")


def _one_of(move: Any, moves: Any) -> None:
    if (move is None) == (moves is None):
        raise ProtocolError(ErrorKind.MISSING_FIELD if move is None else ErrorKind.BAD_VALUE,
                            "give exactly one of move (one move) or moves (a batch)")


def decode_structs(payload: bytes) -> MoveRequestS:
    """The typed decoding alone (no post-pass, no engine values): what msgspec itself costs."""
    return _REQUEST.decode(payload)


def decode_single(payload: bytes) -> MoveItem:
    """`{"v": 1, "move": Move}`: the one typed decoding, then the post-pass."""
    _envelope(payload)
    try:
        req = _REQUEST.decode(payload)
    except (msgspec.ValidationError, msgspec.DecodeError) as e:
        raise protocol_error(e, payload) from None
    _version(req.v)
    _one_of(req.move, req.moves)
    if req.move is None:
        raise ProtocolError(ErrorKind.BAD_VALUE, "expected one move")
    return move_item(req.move, "move")


def _item(raw: msgspec.Raw, path: str) -> MoveItem | ProtocolError:
    try:
        return move_item(_MOVE.decode(raw), path)
    except (msgspec.ValidationError, msgspec.DecodeError) as e:
        return protocol_error(e, bytes(raw), path)
    except ProtocolError as e:
        return e


def decode_batch(payload: bytes) -> list[MoveItem | ProtocolError]:
    """`{"v": 1, "moves": [...]}` with each move decoded on its own, as the protocol asks (a bad move
    fails only itself): the envelope with the moves as Raw bytes, then one typed decoding per move."""
    _envelope(payload)
    try:
        req = _REQUEST_RAW.decode(payload)
    except (msgspec.ValidationError, msgspec.DecodeError) as e:
        raise protocol_error(e, payload) from None
    _version(req.v)
    _one_of(req.move, req.moves)
    assert req.moves is not None
    return [_item(raw, f"moves[{i}]") for i, raw in enumerate(req.moves)]


def decode_batch_typed(payload: bytes) -> list[MoveItem | ProtocolError]:
    """The whole batch in one typed decoding; when a move is refused, again move by move
    (`decode_batch`), so that the others still run."""
    _envelope(payload)
    try:
        req = _REQUEST.decode(payload)
    except msgspec.ValidationError as e:
        if str(e).endswith("`") and "- at `$.moves[" in str(e):
            return decode_batch(payload)
        raise protocol_error(e, payload) from None
    except msgspec.DecodeError as e:
        raise protocol_error(e, payload) from None
    _version(req.v)
    _one_of(req.move, req.moves)
    assert req.moves is not None
    out: list[MoveItem | ProtocolError] = []
    for i, m in enumerate(req.moves):
        try:
            out.append(move_item(m, f"moves[{i}]"))
        except ProtocolError as e:
            out.append(e)
    return out


def decode_columns(payload: bytes) -> ColumnRequest:
    """A column request: the typed envelope (each column a memoryview), then parse_column_request's own
    checks of kinds and lengths, and its per-item checks of the values (the same numpy code)."""
    _envelope(payload)
    try:
        req = _COLUMNS.decode(payload)
    except (msgspec.ValidationError, msgspec.DecodeError) as e:
        raise protocol_error(e, payload) from None
    _version(req.v)
    if req.move is not None or req.moves is not None:
        raise ProtocolError(ErrorKind.BAD_VALUE, "give exactly one of move, moves or columns")
    kind, cols = req.kind, req.columns
    given: dict[str, memoryview] = {}
    for col in REQUEST_COLUMNS:
        raw = getattr(cols, col.name)
        path = f"columns.{col.name}"
        if raw is None:
            if kind in col.required:
                raise ProtocolError(ErrorKind.MISSING_FIELD, f"{path}: required for kind {kind}", path)
            continue
        if not col.allowed(kind):
            raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}: not a column of kind {kind}", path)
        if len(raw) % col.item_bytes:
            raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}: {len(raw)} bytes is not a whole number of items", path)
        given[col.name] = raw
    n = len(given["id"]) // 8
    if n > MAX_BATCH:
        raise ProtocolError(ErrorKind.TOO_LARGE, f"columns.id: {n} items, at most {MAX_BATCH} allowed", "columns.id")
    arrays: dict[str, np.ndarray[Any, Any]] = {}
    for col in REQUEST_COLUMNS:
        raw = given.get(col.name)
        if raw is None:
            continue
        if len(raw) // col.item_bytes != n:
            path = f"columns.{col.name}"
            raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}: {len(raw) // col.item_bytes} items, but columns.id has {n}",
                                path)
        arrays[col.name] = np.frombuffer(raw, dtype=col.np_dtype).reshape((n,) if col.width == 1 else (n, col.width))
    out = ColumnRequest(kind, n, arrays, req.publish or "each")
    _bad_reals(out)
    return out


def decode_register_id(payload: bytes) -> int | None:
    try:
        return _REGISTER_ID.decode(payload).id
    except (msgspec.ValidationError, msgspec.DecodeError) as e:
        raise protocol_error(e, payload) from None


# -- msgspec's errors as the protocol's --------------------------------------------------------------
def protocol_error(e: msgspec.ValidationError | msgspec.DecodeError, data: bytes, prefix: str = "") -> ProtocolError:
    """The service's mapping (move_structs.protocol_error), its values read again from the bytes (on the error
    path only; a DecodeError needs none)."""
    value = msgpack.unpackb(data, raw=False, strict_map_key=False) if isinstance(e, msgspec.ValidationError) else None
    return _protocol_error(e, value, prefix)
