"""Reading the queries off the wire: the service reads requests, the client reads answers.

Both work from the declarations of service/protocol/queries.py. A request is read whole before anything
runs: the first field that is wrong refuses it with a ProtocolError naming its path (`grounds[3].
position.origin[2]`), so a batch is either all read or all refused. An answer is read without checks:
the service wrote it from the same declaration.
"""

from __future__ import annotations

from typing import Any

from service.protocol.errors import ProtocolError
from service.protocol.validate import as_list, as_map, field_path, get_field, opt_field
from service.protocol.wire import ErrorKind
from service.protocol.fields import Field, in_landblock
from service.protocol.queries import QUERIES, QueryKind

__all__ = ["Item", "read_request", "read_item", "read_options", "read_answer", "count_items"]

#: a query as read: its fields' values in declaration order (None, or the field's default, when absent)
Item = tuple[Any, ...]


def read_fields(fields: tuple[Field, ...], m: dict[str, Any], path: str, lb: int | None) -> Item:
    """The values of `fields` from the map `m` at `path`, in order; a start is checked against the key's
    landblock `lb` as soon as it is read."""
    values: list[Any] = []
    for f in fields:
        raw = get_field(m, f.name, path) if f.required else opt_field(m, f.name)
        if raw is None:
            values.append(f.default)
            continue
        p = field_path(path, f.name)
        value = f.kind.read(raw, p)
        if f.start and lb is not None:
            in_landblock(value, lb, p)
        values.append(value)
    return tuple(values)


def read_item(kind: QueryKind, value: Any, path: str, lb: int) -> Item:
    """One query of `kind` (the map at `path`) as its item tuple."""
    m = as_map(value, path)
    if kind.check is not None:
        kind.check(m, path)
    return read_fields(kind.fields, m, path, lb)


def read_options(kind: QueryKind, msg: dict[str, Any]) -> dict[str, Any]:
    """A column request's top-level fields (a place's `mover`, `mode`, `slide`), by name."""
    fields = kind.columns.options
    return dict(zip((f.name for f in fields), read_fields(fields, msg, "", None), strict=True))


def _need_literal(op: str, lb: int | None) -> int:
    if lb is None:
        raise ProtocolError(ErrorKind.BAD_VALUE, f"a {op} query needs a literal landblock in its key, not a wildcard")
    return lb


def read_request(op: str, msg: dict[str, Any], lb: int | None) -> tuple[bool, list[Item]]:
    """A map-form request of `op` (single or batch) sent to landblock `lb`'s key: (single, items)."""
    kind = QUERIES[op]
    key_lb = _need_literal(op, lb)
    has_one, has_many = msg.get(op) is not None, msg.get(kind.batch) is not None  # nil is as good as absent
    if has_one == has_many:
        raise ProtocolError(
            ErrorKind.MISSING_FIELD if not has_one else ErrorKind.BAD_VALUE,
            f"a {op} request holds exactly one of {op!r} (one query) and {kind.batch!r} (a batch)",
            op,
        )
    if has_one:
        return True, [read_item(kind, msg[op], op, key_lb)]
    raw = as_list(msg[kind.batch], kind.batch, kind.max_batch)
    return False, [read_item(kind, v, field_path(kind.batch, i), key_lb) for i, v in enumerate(raw)]


def count_items(op: str, msg: dict[str, Any]) -> int:
    """How many queries a map-form request holds (1 for the single form)."""
    batch = msg.get(QUERIES[op].batch)
    return len(batch) if isinstance(batch, list) else 1


def read_answer(op: str, raw: Any) -> Any:
    """An answer of `op` as the engine's result (None for a null ground)."""
    kind = QUERIES[op]
    if raw is None and kind.nullable:
        return None
    return kind.result(**{o.name: o.kind.read(raw.get(o.name)) for o in kind.answer})
