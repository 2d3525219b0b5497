"""Decoding and checking a column request (docs/protocol.md, "Column batches").

Everything that concerns the whole request (the `kind`, a column name the
form does not know, a column's type, byte length or item count, the batch
limit, `publish`) raises
ProtocolError here, before anything runs. Bad values inside a column
(NaN, ±infinity, beyond float32's range, `dt` out of range, a
non-unit orientation) fail only their item: they are found with a few
numpy operations over whole columns and kept as per-item errors.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from engine.constants import HUGE_QUANTUM

from service.protocol.columns import COLUMN_PUBLISH_MODES, FLOAT32_MAX, KINDS, REQUEST_BY_NAME, REQUEST_COLUMNS, Column
from service.protocol.errors import ProtocolError
from service.protocol.wire import MAX_BATCH, ErrorKind

__all__ = ["ColumnRequest", "is_column_request", "column_count", "parse_column_request", "refuse_bad_reals"]

#: How far a given orientation's length may be from 1 (as the map form's `as_quat`).
_UNIT_TOLERANCE = 1e-3

#: A real column's values are all finite and within float32's range when the sum of their squares (one
#: numpy call, `np.vdot`) is below this: a value beyond FLOAT32_MAX squares to more than 1.15e77, NaN
#: or infinity make the sum NaN or infinite. A sum at or above it (values near the limit, or many large
#: ones) only means the values are looked at one by one.
_SQUARES_IN_RANGE = 1e76
_vdot = np.vdot

#: per move kind, the columns it must give and the columns it may give
_REQUIRED = {kind: frozenset(c.name for c in REQUEST_COLUMNS if kind in c.required) for kind in KINDS}
_ALLOWED = {kind: frozenset(c.name for c in REQUEST_COLUMNS if c.allowed(kind)) for kind in KINDS}
_ITEM_BYTES = {c.name: c.item_bytes for c in REQUEST_COLUMNS}
_SHAPED = {c.name: (c.np_dtype, c.width) for c in REQUEST_COLUMNS}
_KNOWN = frozenset(REQUEST_BY_NAME)
_REAL_COLUMNS = tuple(c for c in REQUEST_COLUMNS if c.real)
_ID_BYTES = REQUEST_BY_NAME["id"].item_bytes


@dataclass(slots=True)
class ColumnRequest:
    """A decoded column request: its kind, its columns as arrays, and the items already known bad."""

    kind: str
    n: int
    #: the given columns, by name: shape (n,) or (n, width), native byte order
    arrays: dict[str, np.ndarray[Any, Any]]
    publish: str = "each"
    #: item index -> its error, for items whose values are refused (they are not run)
    bad: dict[int, ProtocolError] = field(default_factory=dict)
    #: the `id` column as Python ints when known (shared with other requests of the same ids: never
    #: changed); None: `arrays["id"]` is read
    ids: list[int] | None = None


def is_column_request(msg: dict[str, Any]) -> bool:
    return msg.get("columns") is not None


def column_count(msg: dict[str, Any]) -> int:
    """How many items a column request holds, by its `id` column's length (0 when unreadable: the
    decoder then refuses it)."""
    cols = msg.get("columns")
    ids = cols.get("id") if isinstance(cols, dict) else None
    return len(ids) // 8 if isinstance(ids, bytes) else 0


def _type_name(value: Any) -> str:
    return {dict: "map", list: "array", str: "string", bytes: "binary", bool: "boolean", int: "integer",
            float: "float", type(None): "nil"}.get(type(value), type(value).__name__)


def _parse_kind(msg: dict[str, Any]) -> str:
    kind = msg.get("kind")
    if kind is None:
        raise ProtocolError(ErrorKind.MISSING_FIELD, "kind: required with columns (offset, to or motion)", "kind")
    if not isinstance(kind, str):
        raise ProtocolError(ErrorKind.WRONG_TYPE, f"kind: expected a string, got {_type_name(kind)}", "kind")
    if kind not in KINDS:
        raise ProtocolError(ErrorKind.BAD_VALUE, f"kind: {kind[:40]!r} is not one of {', '.join(KINDS)}", "kind")
    return kind


def _parse_publish(msg: dict[str, Any]) -> str:
    mode = msg.get("publish")
    if mode is None:
        return "each"
    if not isinstance(mode, str):
        raise ProtocolError(ErrorKind.WRONG_TYPE, f"publish: expected a string, got {_type_name(mode)}", "publish")
    if mode not in COLUMN_PUBLISH_MODES:
        raise ProtocolError(ErrorKind.BAD_VALUE,
                            f"publish: {mode[:40]!r} is not one of {', '.join(COLUMN_PUBLISH_MODES)}", "publish")
    return mode


def _column_bytes(cols: dict[str, Any], col: Column, kind: str) -> bytes | None:
    """The column's bytes, or None when not given; refuses a column of the wrong type or not for `kind`."""
    raw = cols.get(col.name)
    path = f"columns.{col.name}"
    if raw is None:
        if kind in col.required:
            raise ProtocolError(ErrorKind.MISSING_FIELD, f"{path}: required for kind {kind}", path)
        return None
    if not col.allowed(kind):
        raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}: not a column of kind {kind}", path)
    if not isinstance(raw, bytes):
        raise ProtocolError(ErrorKind.WRONG_TYPE,
                            f"{path}: expected binary ({col.width} x {col.dtype} little-endian per item), "
                            f"got {_type_name(raw)}", path)
    if len(raw) % col.item_bytes:
        raise ProtocolError(ErrorKind.BAD_VALUE,
                            f"{path}: {len(raw)} bytes is not a whole number of items of {col.item_bytes} bytes "
                            f"({col.width} x {col.dtype})", path)
    return raw


def refuse_bad_reals(columns: tuple[Column, ...], arrays: dict[str, np.ndarray[Any, Any]], n: int,
                     bad: dict[int, ProtocolError]) -> None:
    """Per-item errors in `bad` for the real columns' NaN, ±infinity and magnitudes beyond float32,
    naming the column, the item and the component; an item's first bad value (in column order) wins.
    Shared with the queries' column form (service/protocol/query_columns.py)."""
    for col in columns:
        if not col.real:
            continue
        a = arrays.get(col.name)
        if a is None or n == 0 or _vdot(a, a) < _SQUARES_IN_RANGE:  # every value finite and in range
            continue
        grid = a.reshape(n, col.width)
        non_finite = ~np.isfinite(grid)
        too_big = np.abs(np.where(non_finite, 0.0, grid)) > FLOAT32_MAX
        for kind, mask in ((ErrorKind.NON_FINITE, non_finite), (ErrorKind.BAD_VALUE, too_big)):
            for i in np.flatnonzero(mask.any(axis=1)).tolist():
                if i in bad:
                    continue
                j = int(np.argmax(mask[i]))
                path = f"columns.{col.name}[{i}]" + (f"[{j}]" if col.width > 1 else "")
                value = float(grid[i, j])
                why = "is not a finite number" if kind == ErrorKind.NON_FINITE else \
                    f"is beyond float32's range (magnitude > {FLOAT32_MAX:.7g})"
                bad[i] = ProtocolError(kind, f"{path}: {value!r} {why}", path)


def _bad_reals(req: ColumnRequest) -> None:
    """Per-item errors for refused values, the first bad value of an item (in column order) winning."""
    arrays = req.arrays
    refuse_bad_reals(_REAL_COLUMNS, arrays, req.n, req.bad)
    if "dt" in arrays or "to_orientation" in arrays:
        _bad_ranges(req)


def _bad_ranges(req: ColumnRequest) -> None:
    """`dt` in (0, HUGE_QUANTUM]; a given orientation of unit length (all zeros: none given for that item)."""
    dt = req.arrays.get("dt")
    if dt is not None:
        for i in np.flatnonzero(~((dt > 0.0) & (dt <= HUGE_QUANTUM))).tolist():
            if i not in req.bad:
                path = f"columns.dt[{i}]"
                req.bad[i] = ProtocolError(ErrorKind.BAD_VALUE,
                                           f"{path}: must be in (0, {HUGE_QUANTUM:g}] seconds, got {dt[i]}", path)
    q = req.arrays.get("to_orientation")
    if q is not None:
        with np.errstate(invalid="ignore", over="ignore"):
            length = np.sqrt((q * q).sum(axis=1))
        given = (q != 0.0).any(axis=1)
        for i in np.flatnonzero(given & ~(np.abs(length - 1.0) <= _UNIT_TOLERANCE)).tolist():
            if i not in req.bad:
                path = f"columns.to_orientation[{i}]"
                req.bad[i] = ProtocolError(ErrorKind.BAD_VALUE,
                                           f"{path}: quaternion length {length[i]:.6g} is not 1 (all zeros: keep the "
                                           "current orientation)", path)


def _refuse_names(cols: dict[Any, Any]) -> None:
    """Refuses the first column name the form does not know."""
    for name in cols:
        if name not in REQUEST_BY_NAME:
            # refused, not ignored: a misspelt optional column (`velocty`) would otherwise run every item
            # without it. The same rule and message as the query column forms' (service/protocol/query_columns.py)
            path = f"columns.{str(name)[:40]}"
            raise ProtocolError(ErrorKind.BAD_VALUE,
                                f"{path}: not a column of move (columns: {', '.join(sorted(REQUEST_BY_NAME))})", path)


def _columns_one_by_one(cols: dict[str, Any], kind: str) -> tuple[dict[str, bytes], int]:
    """The given columns and the item count, each column checked in REQUEST_COLUMNS' order, so that the
    first thing wrong is the one refused: a column missing, not of `kind`, not binary or not whole
    items, then too many items, then a column not as long as `id`. A column given as nil is not given."""
    given: dict[str, bytes] = {}
    for col in REQUEST_COLUMNS:
        raw = _column_bytes(cols, col, kind)
        if raw is not None:
            given[col.name] = raw
    n = len(given["id"]) // _ID_BYTES
    if n > MAX_BATCH:
        raise ProtocolError(ErrorKind.TOO_LARGE, f"columns.id: {n} items, at most {MAX_BATCH} allowed", "columns.id")
    for name, raw in given.items():
        count = len(raw) // _ITEM_BYTES[name]
        if count != n:
            path = f"columns.{name}"
            raise ProtocolError(ErrorKind.BAD_VALUE,
                                f"{path}: {count} items, but columns.id has {n} (every column holds one entry per "
                                "item)", path)
    return given, n


def _checked_columns(cols: dict[str, Any], kind: str) -> tuple[dict[str, bytes], int]:
    """The given columns and the item count. The usual request (every column binary, of `kind`, as long
    as `id`) is told apart with a few set operations and a length per column; anything else goes through
    `_columns_one_by_one`, which finds what is wrong."""
    ids = cols.get("id")
    names = cols.keys()
    if isinstance(ids, bytes) and _REQUIRED[kind] <= names <= _ALLOWED[kind]:
        n = len(ids) // _ID_BYTES
        item_bytes = _ITEM_BYTES
        for name, raw in cols.items():
            if not isinstance(raw, bytes) or len(raw) != n * item_bytes[name]:
                break
        else:
            if n > MAX_BATCH:
                raise ProtocolError(ErrorKind.TOO_LARGE, f"columns.id: {n} items, at most {MAX_BATCH} allowed",
                                    "columns.id")
            return cols, n
    return _columns_one_by_one(cols, kind)


#: Recent requests' id columns as lists of ints, by their bytes: a client sends the same movers' ids
#: request after request, and hashing the bytes costs a tenth of making the ints again.
_ID_LISTS: dict[bytes, list[int]] = {}
_ID_LISTS_KEPT = 64
#: The last few id columns found, newest last: comparing a column's bytes with one of them (a length, then a
#: memcmp that stops at the first byte that differs) costs less than hashing them for `_ID_LISTS`, whose
#: lists they share (callgrind, the batch workload's two alternating requests: 29 instructions a move of
#: the bytes' hash)
_RECENT_IDS: list[tuple[bytes, list[int]]] = []
_RECENT_IDS_KEPT = 4


def _id_list(raw: bytes, ids: np.ndarray[Any, Any]) -> list[int]:
    for kept, got in _RECENT_IDS:
        if kept == raw:
            return got
    found = _ID_LISTS.get(raw)
    if found is None:
        if len(_ID_LISTS) >= _ID_LISTS_KEPT:
            _ID_LISTS.clear()
        found = _ID_LISTS[raw] = ids.tolist()
    _RECENT_IDS.append((raw, found))
    if len(_RECENT_IDS) > _RECENT_IDS_KEPT:
        del _RECENT_IDS[0]
    return found


def parse_column_request(msg: dict[str, Any]) -> ColumnRequest:
    """`{"v": 1, "kind": ..., "columns": {...}, "publish"?}` to a ColumnRequest; ProtocolError for
    anything that concerns the whole request."""
    if msg.get("move") is not None or msg.get("moves") is not None:
        raise ProtocolError(ErrorKind.BAD_VALUE, "give exactly one of move, moves or columns")
    cols = msg.get("columns")
    if not isinstance(cols, dict):
        raise ProtocolError(ErrorKind.WRONG_TYPE, f"columns: expected a map, got {_type_name(cols)}", "columns")
    if not cols.keys() <= _KNOWN:
        _refuse_names(cols)
    kind = msg.get("kind")
    if type(kind) is not str or kind not in KINDS:
        kind = _parse_kind(msg)  # refuses it, or takes a str subclass
    publish = "each" if msg.get("publish") is None else _parse_publish(msg)
    given, n = _checked_columns(cols, kind)
    arrays: dict[str, np.ndarray[Any, Any]] = {}
    for name, raw in given.items():
        dtype, width = _SHAPED[name]
        a = np.frombuffer(raw, dtype)
        arrays[name] = a if width == 1 else a.reshape(n, width)
    req = ColumnRequest(kind, n, arrays, publish, ids=_id_list(given["id"], arrays["id"]))
    _bad_reals(req)
    return req
