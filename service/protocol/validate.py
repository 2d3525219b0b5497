"""Typed readers for decoded msgpack values that name the field they reject.

Every reader takes the value and its path ("moves[2].to.origin") and either
returns a clean Python value or raises ProtocolError with the right kind.
msgpack gives us dicts, lists, str, bytes, int, float, bool and None; bool is
an int subclass in Python, so numbers reject it explicitly.
"""

from __future__ import annotations

import math
from typing import Any

from engine.limits import FLOAT32_MAX

from service.protocol.errors import ProtocolError
from service.protocol.wire import ErrorKind

__all__ = [
    "field_path",
    "as_map",
    "as_list",
    "as_float",
    "as_uint",
    "as_bool",
    "as_str",
    "as_vec3",
    "as_quat",
    "get_field",
    "opt_field",
]

_TYPE_NAMES = {
    dict: "map",
    list: "array",
    str: "string",
    bytes: "binary",
    bool: "boolean",
    int: "integer",
    float: "float",
    type(None): "nil",
}


def _type_name(value: Any) -> str:
    return _TYPE_NAMES.get(type(value), type(value).__name__)


def field_path(path: str, key: str | int) -> str:
    if isinstance(key, int):
        return f"{path}[{key}]"
    return f"{path}.{key}" if path else key


def _wrong(path: str, expected: str, value: Any) -> ProtocolError:
    return ProtocolError(
        ErrorKind.WRONG_TYPE, f"{path or 'message'}: expected {expected}, got {_type_name(value)}", path or None
    )


def as_map(value: Any, path: str) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise _wrong(path, "map", value)
    for k in value:
        if not isinstance(k, str):
            raise ProtocolError(ErrorKind.WRONG_TYPE, f"{path or 'message'}: map keys must be strings", path or None)
    return value


def as_list(value: Any, path: str, max_len: int | None = None) -> list[Any]:
    if not isinstance(value, list):
        raise _wrong(path, "array", value)
    if max_len is not None and len(value) > max_len:
        raise ProtocolError(ErrorKind.TOO_LARGE, f"{path}: {len(value)} items, at most {max_len} allowed", path)
    return value


def as_float(value: Any, path: str) -> float:
    """A finite number that fits single precision (the client computes in float32)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise _wrong(path, "number", value)
    try:
        f = float(value)
    except OverflowError:  # an integer beyond any float
        f = math.inf if value > 0 else -math.inf
    if not math.isfinite(f):
        raise ProtocolError(ErrorKind.NON_FINITE, f"{path}: {value!r} is not a finite number", path)
    if abs(f) > FLOAT32_MAX:
        raise ProtocolError(
            ErrorKind.BAD_VALUE, f"{path}: {value!r} does not fit single precision (|x| <= {FLOAT32_MAX:.8g})", path
        )
    return f


def as_uint(value: Any, path: str, bits: int = 64) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise _wrong(path, "unsigned integer", value)
    if value < 0 or value >= (1 << bits):
        raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}: {value} is not a {bits}-bit unsigned integer", path)
    return value


def as_bool(value: Any, path: str) -> bool:
    if not isinstance(value, bool):
        raise _wrong(path, "boolean", value)
    return value


def as_str(value: Any, path: str) -> str:
    if not isinstance(value, str):
        raise _wrong(path, "string", value)
    return value


def _floats(value: Any, path: str, n: int) -> tuple[float, ...]:
    items = as_list(value, path)
    if len(items) != n:
        raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}: expected {n} numbers, got {len(items)}", path)
    return tuple(as_float(v, field_path(path, i)) for i, v in enumerate(items))


def as_vec3(value: Any, path: str) -> tuple[float, float, float]:
    x, y, z = _floats(value, path, 3)
    return (x, y, z)


def as_quat(value: Any, path: str) -> tuple[float, float, float, float]:
    """A unit quaternion [w, x, y, z]; non-unit ones are refused, not fixed up."""
    w, x, y, z = _floats(value, path, 4)
    n = math.sqrt(w * w + x * x + y * y + z * z)
    if abs(n - 1.0) > 1e-3:
        raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}: quaternion length {n:.6g} is not 1", path)
    return (w, x, y, z)


def get_field(obj: dict[str, Any], key: str, path: str) -> Any:
    """A required field (nil counts as missing)."""
    value = obj.get(key)
    if value is None:
        p = field_path(path, key)
        raise ProtocolError(ErrorKind.MISSING_FIELD, f"{p}: required field is missing", p)
    return value


def opt_field(obj: dict[str, Any], key: str) -> Any:
    """An optional field: None when absent or nil."""
    return obj.get(key)
