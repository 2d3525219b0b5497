"""Column messages put together from their columns' bytes.

A column reply or publication is `{"v": 1, "n": ..., "columns": {name: bin, ...}, "errors"?: [...]}`
(docs/protocol.md, "Column batches"). Most of its bytes are the columns themselves; packing the map
with msgpack copies them into the packer's growing buffer and again into the result. Here the
message's few headers are written by hand and joined with the columns in one copy. The bytes are
exactly what `service.protocol.frames.pack` gives for the same map (msgpack's smallest header for
each integer, string, binary, map and array; tests/service/protocol/test_column_frames.py holds
the two to each other).
"""

from __future__ import annotations

from typing import Any, Final

import msgpack

from service.protocol.columns import PUBLICATION_ID, REPLY_COLUMNS
from service.protocol.wire import PROTOCOL_VERSION

__all__ = ["rows_message", "REPLY_NAMES", "PUBLICATION_NAMES"]

_V: Final = msgpack.packb("v") + msgpack.packb(PROTOCOL_VERSION)
_N: Final = msgpack.packb("n")
_COLUMNS: Final = msgpack.packb("columns")
_ERRORS: Final = msgpack.packb("errors")
_NO_ERRORS: Final = msgpack.packb([])
#: the packed names of the columns
_KEYS: Final = {name: msgpack.packb(name) for name in
                (PUBLICATION_ID.name, *(c.name for c in REPLY_COLUMNS), "collide_ids")}


def _uint(n: int) -> bytes:
    """A non-negative integer as msgpack packs it (positive fixint, uint8/16/32/64)."""
    if n < 0x80:
        return bytes((n,))
    if n < 0x100:
        return b"\xcc" + bytes((n,))
    if n < 0x10000:
        return b"\xcd" + n.to_bytes(2, "big")
    if n < 0x100000000:
        return b"\xce" + n.to_bytes(4, "big")
    return b"\xcf" + n.to_bytes(8, "big")


def _map_header(size: int) -> bytes:
    if size < 16:
        return bytes((0x80 | size,))
    if size < 0x10000:
        return b"\xde" + size.to_bytes(2, "big")
    return b"\xdf" + size.to_bytes(4, "big")


def _bin_header(size: int) -> bytes:
    if size < 0x100:
        return b"\xc4" + bytes((size,))
    if size < 0x10000:
        return b"\xc5" + size.to_bytes(2, "big")
    return b"\xc6" + size.to_bytes(4, "big")


#: The columns of a reply, in order: the result columns, then the collided movers' wire ids; a
#: publication has its `id` column first.
REPLY_NAMES: Final = (*(c.name for c in REPLY_COLUMNS), "collide_ids")
PUBLICATION_NAMES: Final = (PUBLICATION_ID.name, *REPLY_NAMES)
_ROW_BYTES: Final = {c.name: c.item_bytes for c in (PUBLICATION_ID, *REPLY_COLUMNS)}
_COLLIDE_IDS: Final = "collide_ids"

#: Message frames by (publication, n, rows, collide_ids' bytes, errors given): the message's parts with
#: an empty slot for each column's bytes. A service answers batches of a few sizes, over and over.
_FRAMES: dict[tuple[bool, int, int, int, bool], list[bytes]] = {}
_FRAMES_KEPT = 256


def _frame(names: tuple[str, ...], n: int, rows: int, collide_bytes: int, errors: bool) -> list[bytes]:
    """The message head, then each column's packed name and binary header, each followed by a slot for
    its bytes."""
    parts = [(b"\x84" if errors else b"\x83") + _V + _N + _uint(n) + _COLUMNS + _map_header(len(names))]
    for name in names:
        size = collide_bytes if name == _COLLIDE_IDS else rows * _ROW_BYTES[name]
        parts += (_KEYS[name] + _bin_header(size), b"")
    return parts


def rows_message(n: int, rows: int, columns: list[bytes], errors: list[dict[str, Any]] | None = None, *,
                 publication: bool = False) -> bytes:
    """`{"v": 1, "n": n, "columns": {...}}`, with `"errors": errors` last when given, packed: `columns`
    holds the bytes of REPLY_NAMES' columns in that order (PUBLICATION_NAMES' for a publication), each
    `rows` rows long but the last (collide_ids)."""
    key = (publication, n, rows, len(columns[-1]), errors is not None)
    frame = _FRAMES.get(key)
    if frame is None:
        if len(_FRAMES) >= _FRAMES_KEPT:
            _FRAMES.clear()
        frame = _FRAMES[key] = _frame(PUBLICATION_NAMES if publication else REPLY_NAMES, *key[1:])
    parts = frame.copy()
    parts[2::2] = columns  # ValueError unless there are as many as the frame's columns
    if errors is not None:
        parts += (_ERRORS, msgpack.packb(errors, use_bin_type=True) if errors else _NO_ERRORS)
    return b"".join(parts)
