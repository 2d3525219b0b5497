"""The column form of a move batch: its wire schema, declared once.

A column request carries one move kind for N movers as packed
little-endian arrays (msgpack `bin`), and its reply (and the columnar
publication) carries the results the same way (docs/protocol.md, "Column
batches"). `REQUEST_COLUMNS` and `REPLY_COLUMNS` below are the only place
the columns are listed: the service's decoding and validation
(service/protocol/column_request.py), its encoding (service/column_moves.py), the
client's packing and unpacking (clients/batch.py) and the test that reads
docs/protocol.md's column tables all go through them.

Only numpy and the wire constants are imported, so the client library
shares this module without the World.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Final

import numpy as np

from engine.world.rows import NO_CODE, RESULT_COLUMNS, TRANSIENT_SHIFT, TRANSITION_STATES, Status
from engine.world.transient import NAMED_BITS

__all__ = [
    "Column",
    "KINDS",
    "REQUEST_COLUMNS",
    "REPLY_COLUMNS",
    "MISSING_BY_DTYPE",
    "reply_columns",
    "PUBLICATION_ID",
    "REQUEST_BY_NAME",
    "REPLY_BY_NAME",
    "WIRE_DTYPES",
    "Flag",
    "TRANSITION_STATES",
    "TRANSITION_CODE",
    "TRANSIENT_FLAGS",
    "FAILED_STATE",
    "COLUMN_PUBLISH_MODES",
    "MOVE_FORMS",
    "FLOAT32_MAX",
    "pack_columns",
    "unpack_column",
]

#: The wire's names for element types (all little-endian) and their numpy dtypes.
WIRE_DTYPES: Final[dict[str, str]] = {"f64": "<f8", "u64": "<u8", "u32": "<u4", "u16": "<u2", "u8": "|u1"}

# the numpy dtypes made once: a Column's `np_dtype` is read per column per request
_NP_DTYPES: Final[dict[str, np.dtype[Any]]] = {name: np.dtype(code) for name, code in WIRE_DTYPES.items()}

#: The move kinds of a column request (its `kind` field): one kind for every item of the request.
KINDS: Final = ("offset", "to", "motion")

#: Largest magnitude a real in a request may have (float32's largest finite value): the engine resolves
#: in single precision, where anything larger is an infinity.
FLOAT32_MAX: Final = float(np.finfo(np.float32).max)


@dataclass(frozen=True, slots=True)
class Column:
    """One column: `width` values of `dtype` per item, item after item (row-major), little-endian.

    For a request column, `required` and `optional` name the move kinds that must / may give it (a
    column given for a kind in neither is refused). For a reply column, `missing` is what a value
    holds when the item has none (its flag bit clear, or the item failed).
    """

    name: str
    dtype: str  # a key of WIRE_DTYPES
    width: int
    required: tuple[str, ...] = ()
    optional: tuple[str, ...] = ()
    missing: str = ""
    #: the numpy dtype of `dtype` (little-endian), and the bytes one item takes in this column: read per
    #: column per request on both sides, so worked out once here
    np_dtype: np.dtype[Any] = field(init=False, repr=False, compare=False)
    item_bytes: int = field(init=False, repr=False, compare=False)
    #: whether its values are reals (f64): those are checked for NaN, infinity and float32's range
    real: bool = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        wire = _NP_DTYPES[self.dtype]
        object.__setattr__(self, "np_dtype", wire)
        object.__setattr__(self, "item_bytes", wire.itemsize * self.width)
        object.__setattr__(self, "real", self.dtype == "f64")

    def missing_rows(self, n: int) -> np.ndarray[Any, Any]:
        """`n` rows of this column (in native byte order) that all hold the missing value."""
        fill = float("nan") if self.missing == "NaN" else int(self.missing)
        return np.full((n,) if self.width == 1 else (n, self.width), fill, dtype=self.np_dtype.newbyteorder("="))

    def allowed(self, kind: str) -> bool:
        return kind in self.required or kind in self.optional


REQUEST_COLUMNS: Final = (
    Column("id", "u64", 1, required=KINDS),
    Column("offset", "f64", 3, required=("offset",)),
    Column("to_cell", "u32", 1, optional=("to",)),
    Column("to_origin", "f64", 3, required=("to",)),
    Column("to_orientation", "f64", 4, optional=("to",)),
    Column("motion", "f64", 3, required=("motion",)),
    Column("dt", "f64", 1, required=("motion",)),
    Column("velocity", "f64", 3, optional=("offset", "to")),
)

#: What a reply column holds where an item has no value, by its dtype: NaN for reals, 255 for a u8 code,
#: else 0 (an id or a count).
MISSING_BY_DTYPE: Final[dict[str, str]] = {"f64": "NaN", "u8": "255", "u32": "0", "u64": "0"}


def reply_columns(*columns: tuple[str, str, int]) -> tuple[Column, ...]:
    """Reply columns (name, dtype, per item), each missing what its dtype is missing."""
    return tuple(Column(name, dtype, width, missing=MISSING_BY_DTYPE[dtype]) for name, dtype, width in columns)


#: The reply's columns: the engine's batch result columns themselves (engine.world.rows.RESULT_COLUMNS:
#: where it is, how it went, what it stands on, what it hit), so that a reply hands on the buffers the
#: engine wrote.
REPLY_COLUMNS: Final = reply_columns(*RESULT_COLUMNS)

#: The columnar publication's extra column (first): whose row it is.
PUBLICATION_ID: Final = Column("id", "u64", 1, missing=MISSING_BY_DTYPE["u64"])

REQUEST_BY_NAME: Final = {c.name: c for c in REQUEST_COLUMNS}
REPLY_BY_NAME: Final = {c.name: c for c in REPLY_COLUMNS}


class Flag:
    """Bits of the reply's `flags` column: the engine's row status bits themselves (engine.world.rows.Status),
    and the transient-state bits above them, so that a reply's flags are a row's status and its transient
    bits shifted (service/column_moves.py), with no table between the engine and the wire."""

    RESOLVED: Final = Status.RESOLVED  # the item has a result (clear: it failed, see `errors`)
    OK: Final = Status.OK
    CONTACT: Final = Status.CONTACT
    ON_WALKABLE: Final = Status.ON_WALKABLE
    WATER_CONTACT: Final = Status.WATER_CONTACT
    HAS_CONTACT_PLANE: Final = Status.HAS_CONTACT_PLANE
    HAS_CONTACT_PLANE_CELL: Final = Status.HAS_CONTACT_PLANE_CELL
    HAS_COLLISION_NORMAL: Final = Status.HAS_COLLISION_NORMAL
    HAS_SLIDING_NORMAL: Final = Status.HAS_SLIDING_NORMAL
    HAS_FRAMES_STATIONARY_FALL: Final = Status.HAS_FRAMES_STATIONARY_FALL
    #: bits 16..22: the State's `transient_state` names, one bit each (TRANSIENT_FLAGS): the engine's
    #: transient-state bits (engine.world.transient.NAMED_BITS, 0x1 .. 0x40) shifted up
    TRANSIENT_SHIFT: Final = TRANSIENT_SHIFT


#: `transient_state` names in bit order from Flag.TRANSIENT_SHIFT (the State lists them in this order too).
TRANSIENT_FLAGS: Final = tuple(name for name, _bit in NAMED_BITS)

#: `transition_state` codes: the index in this tuple (the engine's rows hold the same index).
TRANSITION_CODE: Final = {name: i for i, name in enumerate(TRANSITION_STATES)}
#: `transition_state` of a failed item.
FAILED_STATE: Final = NO_CODE

#: A column request's `publish` values.
COLUMN_PUBLISH_MODES: Final = ("each", "batch", "columns")
#: Health's `move_forms`: the move request fields an instance understands.
MOVE_FORMS: Final = ("move", "moves", "columns")


def pack_columns(columns: tuple[Column, ...], arrays: dict[str, Any]) -> dict[str, bytes]:
    """`{name: bin}` of the columns given in `arrays` (each cast to its wire dtype, rows in order)."""
    out: dict[str, bytes] = {}
    for col in columns:
        a = arrays.get(col.name)
        if a is not None:
            wire = col.np_dtype
            if not isinstance(a, np.ndarray) or a.dtype != wire:
                a = np.asarray(a, dtype=wire)
            out[col.name] = a.tobytes()  # row-major whatever the array's strides
    return out


def unpack_column(col: Column, data: bytes, n: int) -> np.ndarray[Any, Any]:
    """A column's bytes as an array of shape (n,) for width 1, else (n, width), in native byte order.
    The caller has checked the length (ValueError otherwise)."""
    wire = col.np_dtype
    if len(data) != n * wire.itemsize * col.width:
        raise ValueError(f"column {col.name}: {len(data)} bytes for {n} items of {col.item_bytes}")
    a = np.frombuffer(data, dtype=wire)
    if not wire.isnative:  # a big-endian machine
        a = a.astype(wire.newbyteorder("="))
    return a if col.width == 1 else a.reshape(n, col.width)
