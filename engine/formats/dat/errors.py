"""The exceptions the dat reader raises for anything wrong with a dat file."""

from __future__ import annotations

__all__ = ["DatError", "DatFileMissing", "format_file_id"]


def format_file_id(file_id: int | None) -> str:
    """`0x01000001`-style rendering of a dat file id (or a placeholder)."""
    return "(no file id)" if file_id is None else f"0x{file_id & 0xFFFFFFFF:08X}"


class DatError(ValueError):
    """A dat file is missing a record, or is truncated or corrupt.

    The message always names the dat file's path and, when the problem is in
    one record, that record's file id; both are also kept as attributes so a
    caller can react without parsing the text.
    """

    def __init__(self, message: str, *, path: str | None = None, file_id: int | None = None) -> None:
        self.path = path
        self.file_id = file_id
        where = []
        if path is not None:
            where.append(str(path))
        if file_id is not None:
            where.append(f"file {format_file_id(file_id)}")
        prefix = ": ".join(where)
        self.message = f"{prefix}: {message}" if prefix else message
        super().__init__(self.message)

    def __str__(self) -> str:
        return self.message


class DatFileMissing(DatError, KeyError):
    """The dat's directory has no entry for the requested file id.

    Also a KeyError, so `except KeyError` works as it would on a mapping.
    """
