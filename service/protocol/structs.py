"""msgspec Structs generated from the wire schema's map declarations (service/protocol/schema.py), so that a
message read with msgspec is declared once: a field added to a `Map` is a field of its Struct.

`struct_of(map, ...)` makes the Struct with `msgspec.defstruct`: the map's fields in its order, each
with the type and `msgspec.Meta` bounds its kind states:

- a number: within float32's range (NaN and ±infinity fail that bound too), and its `Range` when given;
- an unsigned integer of 8 to 32 bits: 0 to its largest value; of 64 bits: not negative (Meta takes
  int64 bounds only, and msgpack holds no integer of 2**64 or more);
- a tag: an integer, or a string of at most 256 characters;
- a vector: a tuple of 3 such numbers, a quaternion: of 4 (its unit length is not a bound);
- a string from a set: that set (a Literal); a list: of its items' type, within its lengths;
- a nested map: its own generated Struct; a value of any kind, or a field written but never read: Any.

A required field (`required`, not belonging to another) has no default; a nullable one, or one whose
default is None, is `T | None = None`; any other takes its default, and a nil there is refused (the
full reader takes nil for absent: callers fall back on it, or their post-pass says so). What a map
says beyond its values (one_of, rules, checks, a field's further check, `with_field`, `excludes`) is
its caller's post-pass. What a Struct needs that a map cannot say is an explicit option of the call.

Structs are made once per map and options: a nested map's Struct is the same type as that map's own
made with the same options (service/protocol/move_structs.py's TargetS is MoveS's `to`).
"""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence
from typing import Annotated, Any, Literal

import msgspec

from engine.limits import FLOAT32_MAX

from service.protocol.schema import Field, Map
from service.protocol.schema_kinds import (
    MAX_TAG_LEN,
    Bool,
    Enum,
    Int,
    Kind,
    ListOf,
    Number,
    Quaternion,
    Str,
    Tag,
    UInt,
    Value,
    Vector,
)

__all__ = ["struct_of", "field_names"]

# typing's forms, made from values at run time (mypy sees these calls as Any, not as types to check)
_ANNOTATED: Any = Annotated
_LITERAL: Any = Literal
_TUPLE: Any = tuple
_LIST: Any = list

#: a real: within float32's range, which NaN and ±infinity fail too
REAL: Any = _ANNOTATED[float, msgspec.Meta(ge=-FLOAT32_MAX, le=FLOAT32_MAX)]

#: (map, name, options) to the Struct made for them
_MADE: dict[tuple[Any, ...], type[msgspec.Struct]] = {}


def struct_of(decl: Map, *, name: str | None = None, first: Sequence[tuple[str, Any]] = (),
              leave_out: Collection[str] = (), required: Collection[str] = (), types: Mapping[str, Any] | None = None,
              written_order: bool = False, forbid_unknown_fields: bool = False,
              gc: bool = True) -> type[msgspec.Struct]:
    """The Struct of `decl`'s fields. Options, for what the map cannot say (a path names a field, a
    nested map's with dots: `position.orientation`; a path naming no field is an error):

    - `first`: fields (name, type) before the map's, such as an envelope's `v`;
    - `leave_out`: fields not in the Struct (an unknown key then, refused with `forbid_unknown_fields`);
    - `required`: fields required though the map gives them a default;
    - `types`: a field's type instead of its kind's (a field read by the post-pass: Any);
    - `written_order`: the order the service writes the map in (Map.encode_fn, packing.packer_module:
      `omit` fields last; the maps inside it in their own order), where msgspec looks for each key
      first (the one after the last it matched);
    - `forbid_unknown_fields`, `gc`: msgspec's options, for this Struct and the nested ones.

    Every field is keyword-only in the Struct's constructor (`kw_only`: a required field may follow an
    optional one, as in the declaration); decoding does not use the constructor."""
    overrides = dict(types or {})
    named = {*leave_out, *required, *overrides}
    found = _declared_paths(decl, "")
    unknown = sorted(p for p in named if p not in found)
    if unknown:
        raise ValueError(f"{decl.name}: no field {', '.join(unknown)} to override")
    return _made(decl, name or decl.name, tuple(first), frozenset(leave_out), frozenset(required),
                 tuple(sorted(overrides.items(), key=lambda item: item[0])), written_order, forbid_unknown_fields, gc)


def field_names(struct: type[msgspec.Struct]) -> tuple[str, ...]:
    """A Struct's field names in its order."""
    return tuple(struct.__struct_fields__)


def _declared_paths(decl: Map, prefix: str) -> set[str]:
    """Every field's path in `decl` and the maps inside it (through lists too)."""
    paths: set[str] = set()
    for f in decl.fields:
        path = prefix + f.name
        paths.add(path)
        inner = _map_in(f.kind)
        if inner is not None:
            paths |= _declared_paths(inner, path + ".")
    return paths


def _map_in(kind: Kind) -> Map | None:
    """The map a field's value is, or holds a list of."""
    if isinstance(kind, ListOf):
        kind = kind.item
    return kind if isinstance(kind, Map) else None


def _made(decl: Map, name: str, first: tuple[tuple[str, Any], ...], leave_out: frozenset[str],
          required: frozenset[str], types: tuple[tuple[str, Any], ...], written_order: bool,
          forbid_unknown_fields: bool, gc: bool) -> type[msgspec.Struct]:
    key = (decl, name, first, leave_out, required, types, written_order, forbid_unknown_fields, gc)
    made = _MADE.get(key)
    if made is None:
        fields = [*first, *(_field(f, leave_out, required, dict(types), forbid_unknown_fields, gc)
                            for f in _ordered(decl, written_order) if f.name not in leave_out)]
        made = _MADE[key] = msgspec.defstruct(name, fields, module=__name__, kw_only=True,
                                              forbid_unknown_fields=forbid_unknown_fields, gc=gc)
    return made


def _ordered(decl: Map, written_order: bool) -> list[Field]:
    if not written_order:
        return list(decl.fields)
    return [f for f in decl.fields if not f.omit] + [f for f in decl.fields if f.omit]


def _inner(options: Collection[str], field: str) -> frozenset[str]:
    """The paths below `field`, relative to its map."""
    return frozenset(p[len(field) + 1:] for p in options if p.startswith(field + "."))


def _field(f: Field, leave_out: frozenset[str], required: frozenset[str], types: dict[str, Any],
           forbid_unknown_fields: bool, gc: bool) -> tuple[Any, ...]:
    """(name, type) or (name, type, default) of one field."""
    if f.name not in types and not f.read:  # written only: the full reader ignores it, whatever it is
        return (f.name, Any, None)
    t = types[f.name] if f.name in types else _value_type(f, leave_out, required, types, forbid_unknown_fields, gc)
    if f.name in required or (f.required and f.with_field is None):
        return (f.name, t)
    if t is Any:  # any value, nil included
        return (f.name, t, None)
    if f.nullable or f.default is None:
        return (f.name, t | None, None)
    return (f.name, t, f.default)


def _value_type(f: Field, leave_out: frozenset[str], required: frozenset[str], types: dict[str, Any],
                forbid_unknown_fields: bool, gc: bool) -> Any:
    """The type of the field's kind; a map's (or a list of maps') with the options below the field."""
    inner = _map_in(f.kind)
    if inner is None:
        return _type_of(f.kind)
    below = {p[len(f.name) + 1:]: v for p, v in types.items() if p.startswith(f.name + ".")}
    t = _made(inner, inner.name, (), _inner(leave_out, f.name), _inner(required, f.name),
              tuple(sorted(below.items(), key=lambda item: item[0])), False, forbid_unknown_fields, gc)
    return _list_of(t, f.kind) if isinstance(f.kind, ListOf) else t


def _type_of(kind: Kind) -> Any:
    """The Struct type of a value of `kind` (not a map)."""
    if isinstance(kind, Number):
        return _real(kind)
    if isinstance(kind, UInt):
        if kind.bits >= 64:
            return _ANNOTATED[int, msgspec.Meta(ge=0)]
        return _ANNOTATED[int, msgspec.Meta(ge=0, le=(1 << kind.bits) - 1)]
    if isinstance(kind, Int):
        return int
    if isinstance(kind, Bool):
        return bool
    if isinstance(kind, Str):
        return str
    if isinstance(kind, Enum):
        return _LITERAL[kind.values]
    if isinstance(kind, Tag):  # its integer's 64-bit range is beyond Meta's (and msgpack's) bounds
        return int | _ANNOTATED[str, msgspec.Meta(max_length=MAX_TAG_LEN)]
    if isinstance(kind, Vector):  # its `check` (an engine limit) is the post-pass's
        return _TUPLE[REAL, REAL, REAL]
    if isinstance(kind, Quaternion):  # its unit length is the post-pass's
        return _TUPLE[REAL, REAL, REAL, REAL]
    if isinstance(kind, ListOf):
        return _list_of(_type_of(kind.item), kind)
    if isinstance(kind, Value):
        return Any
    raise TypeError(f"no Struct type for a {type(kind).__name__}: give the field's type in `types`")


def _real(kind: Number) -> Any:
    """float32's range, narrowed by the number's own."""
    r = kind.range
    if r is None:
        return REAL
    hi = FLOAT32_MAX if r.hi is None else min(r.hi, FLOAT32_MAX)
    if r.lo is None:
        meta = msgspec.Meta(ge=-FLOAT32_MAX, le=hi)
    elif r.lo_open:
        meta = msgspec.Meta(gt=max(r.lo, -FLOAT32_MAX), le=hi)
    else:
        meta = msgspec.Meta(ge=max(r.lo, -FLOAT32_MAX), le=hi)
    return _ANNOTATED[float, meta]


def _list_of(item: Any, kind: ListOf) -> Any:
    """A list of `item`s, within the kind's lengths (a bound of none left out)."""
    t = _LIST[item]
    if not kind.min_len and kind.max_len is None:
        return t
    return _ANNOTATED[t, msgspec.Meta(min_length=kind.min_len or None, max_length=kind.max_len)]
