"""Engine exceptions to protocol errors.

Mapped by class name along the exception's MRO, so the service neither
depends on engine.errors' exact module layout nor breaks if a subclass is
added: an unknown EngineError still becomes `engine_error`.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

from service.protocol.errors import ProtocolError
from service.protocol.wire import ErrorKind

__all__ = ["to_protocol_error", "wire_path"]

#: a request path that ends in an offset (`move.offset[0]`, `moves[3].offset`)
_OFFSET = re.compile(r"(^|\.)offset(\[\d+\])?$")

_BY_CLASS = {
    "UnknownCellError": ErrorKind.UNKNOWN_CELL,
    "LandblockNotLoadedError": ErrorKind.LANDBLOCK_NOT_LOADED,
    "NonFiniteError": ErrorKind.NON_FINITE,
    "OutOfRangeError": ErrorKind.BAD_VALUE,
    "UnknownMoverError": ErrorKind.UNKNOWN_MOVER,
}


def wire_path(field: str, fields: Mapping[str, str]) -> str | None:
    """The request path of an engine error's `field` ("target.origin[2]"), given what the
    engine's argument names are in the request (`{"target": "moves[3].to"}`): the longest
    name that `field` starts with, replaced. None when no name matches."""
    best = ""
    for name in fields:
        if len(name) > len(best) and field.startswith(name) and field[len(name):len(name) + 1] in ("", ".", "["):
            best = name
    if not best:
        return None
    return fields[best] + field[len(best):]


def to_protocol_error(
    exc: BaseException,
    path: str | None = None,
    *,
    key_error_kind: str | None = None,
    fields: Mapping[str, str] | None = None,
) -> ProtocolError:
    """The ProtocolError for an exception the engine raised.

    `key_error_kind` is what a bare KeyError means in the caller's context
    (e.g. load_landblock raises KeyError for a landblock its source lacks).
    `fields` maps the engine's argument names to request paths (wire_path):
    an error naming its field gets that field's path instead of `path`.
    """
    if isinstance(exc, ProtocolError):
        return exc
    field = getattr(exc, "field", None)
    text = _describe(exc)
    if fields is not None and isinstance(field, str):
        wire = wire_path(field, fields)
        if wire is not None:
            path = wire
            text = _renamed(text, field, wire)  # the message names the request's field too
    names = [c.__name__ for c in type(exc).__mro__]
    for name in names:
        kind = _BY_CLASS.get(name)
        if kind is not None:
            return ProtocolError(kind, text, path)
    if "EngineError" in names:
        return ProtocolError(ErrorKind.ENGINE_ERROR, _describe(exc), path)
    if isinstance(exc, KeyError) and key_error_kind is not None:
        return ProtocolError(key_error_kind, _describe(exc), path)
    if isinstance(exc, ValueError):
        return ProtocolError(ErrorKind.ENGINE_ERROR, _describe(exc), path)
    return ProtocolError(ErrorKind.INTERNAL, f"internal error: {_describe(exc)}", path)


def _renamed(text: str, field: str, wire: str) -> str:
    """`text` naming the request's field `wire` where it named the engine's `field`. A target worked out
    from an offset is called the target: its value is not the number the request gave."""
    name = wire
    if field.startswith("target") and _OFFSET.search(wire):
        name = f"{wire} (the target: current position + offset)"
    if text.startswith(f"{field}:"):
        return name + text[len(field):]
    return text.replace(f" {field}:", f" {name}:", 1)


def _describe(exc: BaseException) -> str:
    """The exception's message for the error's text; its class is the error's kind, never in the text."""
    text = str(exc.args[0]) if isinstance(exc, KeyError) and exc.args else str(exc)
    return text if text else type(exc).__name__
