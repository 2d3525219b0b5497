"""The kinds of value a query's fields hold, each able to read itself off the wire and write itself back.

A `Field` of a query declaration (service/protocol/queries.py) names its wire key and its `Kind`; the
readers (service side: refuse what is wrong, naming the field's path) and the writers (client side: the
wire map of a Python value) both come from that one declaration. Reading goes through the readers of
service/protocol/validate.py and service/protocol/codec.py, so every kind and message of protocol.md's Errors is theirs.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from engine.geometry import Position

from service.protocol.codec import decode_mover_spec, decode_position, encode_mover_spec, encode_position
from service.protocol.errors import ProtocolError
from service.protocol.validate import as_bool, as_float, as_str, as_uint
from service.protocol.wire import ErrorKind

__all__ = ["Kind", "Field", "POSITION", "MOVER", "ID", "BOOL", "Real", "Count", "Choice", "in_landblock"]


@dataclass(frozen=True, slots=True)
class Kind:
    """How one kind of value is read (`read(raw, path)`, ProtocolError naming `path`) and written; `doc` is
    its type as protocol.md's prose spells it."""

    doc: str
    read: Callable[[Any, str], Any]
    write: Callable[[Any], Any] = lambda value: value


@dataclass(frozen=True, slots=True)
class Field:
    """One field of a query: its wire `name`, its `kind`, whether it must be given (nil counts as
    absent), what an absent one means, and whether it is the query's start, which must lie in the key's
    landblock (the key routes a query to the owner of its start)."""

    name: str
    kind: Kind
    required: bool = False
    default: Any = None
    start: bool = False


def in_landblock(position: Position, lb: int, path: str) -> None:
    """A start outside the key's landblock is `wrong_landblock`, naming the right one."""
    owner = (position.cell_id >> 16) & 0xFFFF
    if owner != lb:
        raise ProtocolError(
            ErrorKind.WRONG_LANDBLOCK,
            f"{path}: cell {position.cell_id:08X} is not in landblock {lb:04X} (the key's); send it to that landblock's key",
            path,
            landblock=owner,
        )


POSITION = Kind("Position", decode_position, encode_position)
MOVER = Kind("MoverSpec", decode_mover_spec, encode_mover_spec)
#: a mover's id (0 is nobody's: the engine's ids map answers `unknown_mover`)
ID = Kind("uint64", as_uint)
BOOL = Kind("bool", as_bool)


def Real(low: float, high: float, why: Callable[[float], str], *, low_open: bool = False) -> Kind:
    """A float within `low` .. `high` (above `low` when `low_open`); `why(value)` says what is wrong with
    one outside, in the error's words."""
    def read(raw: Any, path: str) -> float:
        value = as_float(raw, path)
        if (value <= low if low_open else value < low) or value > high:
            raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}: {why(value)}", path)
        return value
    return Kind("float", read)


def Count(low: int, high: int, unit: str) -> Kind:
    """A whole number within `low` .. `high` of `unit`s."""
    def read(raw: Any, path: str) -> int:
        value = as_uint(raw, path)
        if not low <= value <= high:
            raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}: must be {low:,} to {high:,} {unit}, got {value:,}", path)
        return value
    return Kind("uint", read)


def Choice(values: tuple[str, ...]) -> Kind:
    """One of `values`, a string."""
    def read(raw: Any, path: str) -> str:
        value = as_str(raw, path)
        if value not in values:
            raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}: must be one of {', '.join(values)}, got {value!r}", path)
        return value
    return Kind(" | ".join(f'"{v}"' for v in values), read)
