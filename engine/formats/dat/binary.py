"""A bounds-checked little-endian cursor over one dat record's bytes.

Every read checks that the record still holds the bytes the field needs, so a
record shorter than its fields raises `DatError` naming the dat path, the file
id and the field, instead of an IndexError or struct.error deep in a parser.
Floats are the dat's float32 values widened exactly to Python floats.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field
from typing import Any

from .errors import DatError

__all__ = ["RecordReader"]

_U8 = struct.Struct("<B")
_U16 = struct.Struct("<H")
_I16 = struct.Struct("<h")
_U32 = struct.Struct("<I")
_I32 = struct.Struct("<i")
_F32 = struct.Struct("<f")
_F64 = struct.Struct("<d")
_VEC3 = struct.Struct("<3f")
_VEC4 = struct.Struct("<4f")


@dataclass(slots=True)
class RecordReader:
    """Cursor over `data` (one dat file's bytes, offset 0 = record start).

    `path`, `file_id` and `record` only label error messages.
    """

    data: bytes | memoryview
    path: str | None = None
    file_id: int | None = None
    record: str = "record"
    pos: int = 0
    _view: memoryview = field(init=False, repr=False)

    def __post_init__(self) -> None:
        view = memoryview(self.data)
        self._view = view if view.format == "B" and view.ndim == 1 else view.cast("B")

    # -- errors -------------------------------------------------------------

    def error(self, message: str) -> DatError:
        """A DatError about this record (the caller raises it)."""
        return DatError(f"{self.record}: {message}", path=self.path, file_id=self.file_id)

    def own_id(self) -> int:
        """The id a record repeats first; one other than the file's own id
        (when known) means we were pointed at the wrong bytes."""
        return self.check_own_id(self.u32("id"))

    def check_own_id(self, stored: int) -> int:
        if self.file_id is not None and stored != self.file_id:
            raise self.error(f"record starts with id 0x{stored:08X}, not its own id")
        return stored

    def _need(self, size: int, what: str) -> int:
        start = self.pos
        if size < 0 or start + size > len(self._view):
            raise self.error(
                f"record is {len(self._view)} bytes but {what} needs {size} bytes at offset {start} "
                "(truncated or corrupt record)"
            )
        self.pos = start + size
        return start

    # -- scalars ------------------------------------------------------------

    def u8(self, what: str = "byte") -> int:
        return _U8.unpack_from(self._view, self._need(1, what))[0]

    def u16(self, what: str = "ushort") -> int:
        return _U16.unpack_from(self._view, self._need(2, what))[0]

    def i16(self, what: str = "short") -> int:
        return _I16.unpack_from(self._view, self._need(2, what))[0]

    def u32(self, what: str = "uint") -> int:
        return _U32.unpack_from(self._view, self._need(4, what))[0]

    def i32(self, what: str = "int") -> int:
        return _I32.unpack_from(self._view, self._need(4, what))[0]

    def f32(self, what: str = "float") -> float:
        return _F32.unpack_from(self._view, self._need(4, what))[0]

    def f64(self, what: str = "double") -> float:
        return _F64.unpack_from(self._view, self._need(8, what))[0]

    def vec3(self, what: str = "vector") -> list[float]:
        return list(_VEC3.unpack_from(self._view, self._need(12, what)))

    def vec4(self, what: str = "quaternion") -> list[float]:
        return list(_VEC4.unpack_from(self._view, self._need(16, what)))

    def array(self, fmt: str, count: int, what: str) -> tuple[Any, ...]:
        """`count` items of one struct code (`"H"`, `"B"`, `"f"`, ...)."""
        s = struct.Struct(f"<{count}{fmt}")
        return s.unpack_from(self._view, self._need(s.size, what))

    def tag(self, what: str = "tag") -> str:
        """A four-character tag stored as a little-endian uint (so `BPnN` is the bytes `NnPB`)."""
        return self.raw(4, what)[::-1].decode("latin-1")

    def raw(self, size: int, what: str = "bytes") -> bytes:
        start = self._need(size, what)
        return bytes(self._view[start : start + size])

    def compressed_u32(self, what: str = "packed count") -> int:
        """The client's packed uint: 1 byte (<0x80), 2 bytes (0x80 set) or 4 bytes (0xC0 set)."""
        b0 = self.u8(what)
        if not b0 & 0x80:
            return b0
        b1 = self.u8(what)
        if not b0 & 0x40:
            return ((b0 & 0x7F) << 8) | b1
        low = self.u16(what)
        return ((((b0 & 0x3F) << 8) | b1) << 16) | low

    def packed_data_id(self, known_type: int, what: str = "packed data id") -> int:
        """A data id stored as 2 bytes, or 4 when the first ushort has 0x8000, added to `known_type`."""
        first = self.u16(what)
        if first & 0x8000:
            second = self.u16(what)
            return known_type + (((first & 0x3FFF) << 16) | second)
        return known_type + first

    # -- structure ----------------------------------------------------------

    def skip(self, size: int, what: str = "skipped bytes") -> None:
        self._need(size, what)

    def align4(self) -> None:
        """Advance to the next multiple of 4 from the record start (the dat pads some structures)."""
        # Padding missing at the very end of a record is tolerated: nothing follows it,
        # and a missing pad in the middle makes the next field's read fail anyway.
        self.pos = min(self.pos + (-self.pos) % 4, len(self._view))

    def count(self, value: int, min_item_size: int, what: str) -> int:
        """Check a stored item count against the bytes left, so corrupt counts fail fast."""
        if value < 0 or value * min_item_size > self.remaining:
            raise self.error(
                f"{what} count {value} cannot fit in the {self.remaining} bytes left at offset {self.pos} "
                "(truncated or corrupt record)"
            )
        return value

    @property
    def remaining(self) -> int:
        return len(self._view) - self.pos

    def at_end(self) -> bool:
        return self.pos >= len(self._view)
