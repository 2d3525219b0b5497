"""The wire schema machinery: a message declared once drives its reading, its checks and its writing.

A message (or a value inside one) is a `Map` of `Field`s, each with a `Kind` (a number with its range,
an unsigned integer of so many bits, a vector, a quaternion, a string from a set, a list of another kind,
a nested map). From that one declaration (service/protocol/messages.py holds every map-form message) come:

- `Map.read(value, path)`: the full reader, any shape a sender may write, and on refusal a ProtocolError
  whose kind and path name the field (`moves[3].to.origin[2]`);
- `Map.fast`: a reader generated as Python source at import time from the same fields: it takes the
  usual shape only (floats as floats, known keys only) and returns None for anything else, so the full
  reader decides and names the field. It runs the same checks and builds the same value (the State's:
  a move request is read with msgspec instead, service/protocol/move_structs.py);
- `Map.encode(obj)`: the msgpack-ready map of a value (generated too: one dict display per map);
- `packing.packer_module(map, ...)`: for the per-move State, a function that writes the msgpack bytes directly
  (service/protocol/packing.py), generated from the same fields;
- `Field.doc_type` and `Map.required_names`: what docs/protocol.md's tables are checked against
  (tests/service/protocol/test_service_schema.py).

The value kinds are in service/protocol/schema_kinds.py; this module holds the maps and their fields.
Only the wire constants, validate.py's readers and the standard library are used here.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import KW_ONLY, dataclass, field
from typing import Any

from service.protocol.errors import ProtocolError
from service.protocol.schema_kinds import Kind, SourceGen, Value
from service.protocol.validate import as_map, field_path
from service.protocol.wire import ErrorKind

__all__ = ["Field", "Map", "Rule"]


@dataclass(frozen=True, slots=True)
class Rule:
    """A check of a map's built value: `holds(value)`, else `error(value, path)` (what it refuses)."""

    holds: Callable[[Any], bool]
    error: Callable[[Any, str], ProtocolError]


@dataclass(frozen=True, slots=True)
class Field:
    """One key of a map.

    `required`: absence (or nil) is `missing_field`; else `default` is the value. `nullable`: the
    value may be nil when written; `omit`: left out when it has none. `src`: the field's value as a Python
    expression over the encoded object `{}` (or over the packer's arguments). `with_field`: the field
    belongs to another one (read only when that one is given, and then required). `excludes`: a field
    it may not come with, and why. `doc`: the type the doc's table gives, when not the kind's own.
    """

    name: str
    kind: Kind
    required: bool = False
    default: Any = None
    nullable: bool = False
    omit: bool = False
    src: str = "{}.{name}"
    with_field: str | None = None
    excludes: tuple[str, str] | None = None
    check: Callable[[Any, str], None] | None = None  # a further check of the read value (an engine limit)
    doc: str | None = None
    read: bool = True  # False: written only (derived from other fields when read)

    @property
    def doc_type(self) -> str:
        return self.doc or self.kind.doc

    def source(self, obj: str) -> str:
        return self.src.replace("{name}", self.name).replace("{}", obj)


# eq=False: a map is the one declaration it is (compared and hashed by identity)
@dataclass(eq=False, repr=False)
class Map(Kind):
    """A map of `fields`, read into `build(*values)` (values in field order; a list default copied).

    `one_of`: exactly one of these fields is given (checked where the first of them is read; a map with
    one has no fast reader). `rules`:
    checks of the built value. `checks`: further checks that raise ProtocolError themselves (engine
    limits). `label`: how an error at the top (path "") names the message. `doc`: the type the doc's
    tables give it (default `name`).
    """

    name: str
    fields: tuple[Field, ...]
    build: Callable[..., Any] | None = None
    _: KW_ONLY
    one_of: tuple[str, ...] = ()
    rules: tuple[Rule, ...] = ()
    checks: tuple[Callable[[Any, str], None], ...] = ()
    label: str = "message"
    doc: str = ""
    by_name: dict[str, Field] = field(init=False)
    # the generated fast reader and encoder, made on first use
    _fast: Callable[[Any, str], Any] | None = field(init=False, default=None)
    _encode: Callable[[Any], dict[str, Any]] | None = field(init=False, default=None)

    def __post_init__(self) -> None:
        self.by_name = {f.name: f for f in self.fields}
        self.doc = self.doc or self.name

    @property
    def required_names(self) -> set[str]:
        return {f.name for f in self.fields if f.required and f.with_field is None}

    # -- the full reader ------------------------------------------------------------------------------
    def _check_one_of(self, m: dict[str, Any], path: str) -> None:
        given = [k for k in self.one_of if m.get(k) is not None]
        if len(given) != 1:
            what = "none" if not given else " and ".join(given)
            raise ProtocolError(ErrorKind.MISSING_FIELD if not given else ErrorKind.BAD_VALUE,
                                f"{path or self.label}: give exactly one of {', '.join(self.one_of)} (got {what})",
                                path or None)

    def read(self, value: Any, path: str) -> Any:
        m = as_map(value, path)
        values: dict[str, Any] = {}
        for f in self.fields:
            if not f.read:
                continue
            if self.one_of and f.name == self.one_of[0]:
                self._check_one_of(m, path)
            if f.with_field is not None and values[f.with_field] is None:
                values[f.name] = None
                continue
            raw = m.get(f.name)
            p = field_path(path, f.name)
            if raw is None:
                if f.required:
                    raise ProtocolError(ErrorKind.MISSING_FIELD, f"{p}: required field is missing", p)
                values[f.name] = list(f.default) if isinstance(f.default, list) else f.default
                continue
            if f.excludes is not None and values[f.excludes[0]] is not None:
                raise ProtocolError(ErrorKind.BAD_VALUE, f"{p}: {f.excludes[1]}", p)
            values[f.name] = v = f.kind.read(raw, p)
            if f.check is not None:
                f.check(v, p)
        if self.build is None:
            return values
        built = self.build(*values.values())
        for r in self.rules:
            if not r.holds(built):
                raise r.error(built, path)
        for c in self.checks:
            c(built, path)
        return built

    # -- the fast reader (generated) ------------------------------------------------------------------
    @property
    def fast_reader(self) -> Callable[[Any, str], Any]:
        """`read` for the usual shape; None where the full reader must decide. Generated once."""
        if self._fast is None:
            g = SourceGen()
            fn = f"fast_{self.name}"
            g.emit(0, f"def {fn}(m, path):")
            g.emit(1, f"return {self.fast(g, 1, 'm', 'path')}")  # the body is emitted before this line
            self._fast = g.compile(fn)
        return self._fast

    def fast(self, g: SourceGen, ind: int, x: str, path: str) -> str:
        if self.build is None or self.one_of:
            raise TypeError(f"{self.name}: only a map with a build and no one_of has a fast reader")
        n = g.var("n")
        g.emit(ind, f"if type({x}) is not dict: return None")
        # the keys read: the required ones counted here, the others as they come
        plain_required = [f for f in self.fields if f.read and f.required and f.with_field is None]
        g.emit(ind, f"{n} = {len(plain_required)}")
        out: dict[str, str] = {}
        for f in self.fields:
            if not f.read:  # written only: ignored when read, as the full reader does
                g.emit(ind, f"{n} += {x}.get({f.name!r}) is not None")
                continue
            fp = f"field_path({path}, {f.name!r})"
            if f.with_field is not None:  # read only when the field it belongs to was given
                v = out[f.name] = g.var()
                g.emit(ind, f"if {out[f.with_field]} is None: {v} = None")
                g.emit(ind, "else:")
                raw = g.var("x")
                g.emit(ind + 1, f"{raw} = {x}.get({f.name!r})")
                g.emit(ind + 1, f"if {raw} is None: {'return None' if f.required else f'{v} = None'}")
                g.emit(ind + 1, "else:")
                g.emit(ind + 2, f"{v} = {self._fast_value(g, ind + 2, f, raw, fp)}")
                g.emit(ind + 2, f"{n} += 1")
                continue
            raw = g.var("x")
            g.emit(ind, f"{raw} = {x}.get({f.name!r})")
            if f in plain_required:  # straight on, no branch (every kind's type test refuses nil, but Value's)
                if isinstance(f.kind, Value):
                    g.emit(ind, f"if {raw} is None: return None")
                out[f.name] = self._fast_value(g, ind, f, raw, fp)
                continue
            v = out[f.name] = g.var()
            default = "[]" if f.default == [] else "None" if f.default is None else g.const(f.default, "d")
            # a nullable field's nil is the usual shape: its key counts
            present = f"; {n} += {f.name!r} in {x}" if f.nullable else ""
            g.emit(ind, f"if {raw} is None: {v} = {default}{present}")
            g.emit(ind, "else:")
            g.emit(ind + 1, f"{v} = {self._fast_value(g, ind + 1, f, raw, fp)}")
            g.emit(ind + 1, f"{n} += 1")
        g.emit(ind, f"if {n} != len({x}): return None")  # an unknown key: the full reader ignores it or refuses
        built = g.var("m")
        args = ", ".join(out[f.name] for f in self.fields if f.read)
        g.emit(ind, f"{built} = {g.const(self.build, 'build')}({args})")
        for r in self.rules:
            g.emit(ind, f"if not {g.const(r.holds, 'rule')}({built}): return None")
        for c in self.checks:
            g.emit(ind, f"{g.const(c, 'check')}({built}, {path})")
        return built

    @staticmethod
    def _fast_value(g: SourceGen, ind: int, f: Field, raw: str, fp: str) -> str:
        """The field's value read fast (its further check run), as an expression."""
        value = f.kind.fast(g, ind, raw, fp)
        if f.check is None:
            return value
        v = g.var()
        g.emit(ind, f"{v} = {value}")
        g.emit(ind, f"{g.const(f.check, 'check')}({v}, {fp})")
        return v

    # -- writing --------------------------------------------------------------------------------------
    def written(self, values: dict[str, Any]) -> dict[str, Any]:
        """A map this code writes from its values (health, stats, ...), checked against the declaration:
        every required field given, none undeclared (a KeyError names the culprit: a bug, not bad input)."""
        unknown = values.keys() - self.by_name.keys()
        missing = {f.name for f in self.fields if f.required} - values.keys()
        if unknown or missing:
            raise KeyError(f"{self.name}: undeclared {sorted(unknown)}, missing {sorted(missing)}")
        return values

    def encode_fn(self) -> Callable[[Any], dict[str, Any]]:
        """`obj` (what the fields' `src` read) to the msgpack-ready map. Generated once."""
        if self._encode is None:
            g = SourceGen()
            fn = f"encode_{self.name}"
            g.emit(0, f"def {fn}(o):")
            parts = []
            for f in self.fields:
                if f.omit:
                    continue
                s = f.source("o")
                if f.nullable:
                    t = g.var("t")
                    conv = f.kind.encode(g, t)
                    parts.append(f"{f.name!r}: {s}" if conv == t else f"{f.name!r}: (None if ({t} := {s}) is None else {conv})")
                else:
                    parts.append(f"{f.name!r}: {f.kind.encode(g, s)}")
            g.emit(1, "d = {" + ", ".join(parts) + "}")
            for f in self.fields:
                if f.omit:
                    t = g.var("t")
                    g.emit(1, f"{t} = {f.source('o')}")
                    g.emit(1, f"if {t} is not None: d[{f.name!r}] = {f.kind.encode(g, t)}")
            g.emit(1, "return d")
            self._encode = g.compile(fn)
        return self._encode

    def encode(self, g: SourceGen, src: str) -> str:
        return f"{g.const(self.encode_fn(), 'enc')}({src})"
