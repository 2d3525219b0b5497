"""The wire schema machinery: a message declared once drives its reading, its checks and its writing.

A message (or a value inside one) is a `Map` of `Field`s, each with a `Kind` (a number with its range,
an unsigned integer of so many bits, a vector, a quaternion, a string from a set, a list of another kind,
a nested map). From that one declaration (service/messages.py holds every map-form message) come:

- `Map.read(value, path)`: the full reader, any shape a sender may write, and on refusal a ProtocolError
  whose kind and path name the field (`moves[3].to.origin[2]`);
- `Map.fast`: a reader generated as Python source at import time from the same fields: it takes the
  usual shape only (floats as floats, known keys only) and returns None for anything else, so the full
  reader decides and names the field. It runs the same checks and builds the same value;
- `Map.encode(obj)`: the msgpack-ready map of a value (generated too: one dict display per map);
- `Map.packer(...)`: for the per-move State, a function that writes the msgpack bytes directly
  (service/packing.py), generated from the same fields;
- `Field.doc_type` and `Map.required_names`: what docs/protocol.md's tables are checked against
  (tests/test_service_schema.py).

Only the wire constants, validate.py's readers and the standard library are used here.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from engine.limits import FLOAT32_MAX

from .errors import ProtocolError
from .validate import (
    as_bool,
    as_float,
    as_list,
    as_map,
    as_quat,
    as_str,
    as_uint,
    as_vec3,
    field_path,
)
from .wire import ErrorKind

if TYPE_CHECKING:
    from .packing import Packed

__all__ = [
    "Kind", "UInt", "Int", "Range", "POSITIVE", "NON_NEGATIVE", "Value", "UInt", "Number", "Bool", "Str", "Enum", "Tag", "Vector", "Quaternion", "ListOf", "Field", "Map",
    "Rule", "MAX_TAG_LEN",
]

MAX_TAG_LEN = 256


class _Gen:
    """Python source being generated, and the names it refers to."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.ns: dict[str, Any] = {"ProtocolError": ProtocolError, "field_path": field_path, "isfinite": math.isfinite,
                                   "sqrt": math.sqrt, "F32": FLOAT32_MAX}
        self._n = 0

    def var(self, stem: str = "v") -> str:
        self._n += 1
        return f"{stem}{self._n}"

    def const(self, value: Any, stem: str = "K") -> str:
        name = self.var(f"_{stem}")
        self.ns[name] = value
        return name

    def emit(self, indent: int, line: str) -> None:
        self.lines.append("    " * indent + line)

    def compile(self, name: str) -> Any:
        exec(compile("\n".join(self.lines), f"<schema {name}>", "exec"), self.ns)  # noqa: S102 - our own source
        return self.ns[name]


class Kind:
    """What a value is. `read` is the full reader; `fast` emits the fast reader's code for it (the value
    is in `x`; it emits `return None` for anything it cannot vouch for) and gives the expression of the
    read value; `encode` gives the msgpack-ready value of `src` (an expression)."""

    doc = "?"

    def read(self, value: Any, path: str) -> Any:
        raise NotImplementedError

    def fast(self, g: _Gen, ind: int, x: str, path: str) -> str:
        raise NotImplementedError

    def encode(self, g: _Gen, src: str) -> str:
        return src

    def pack(self, g: _Gen, src: str, out: Packed) -> None:
        """Append the msgpack bytes of `src` to `out` (default: msgpack's own packing)."""
        out.expr(f"_packb({self.encode(g, src)})")


class UInt(Kind):
    def __init__(self, bits: int = 64) -> None:
        self.bits = bits
        self.doc = f"uint{bits}"

    def read(self, value: Any, path: str) -> int:
        return as_uint(value, path, self.bits)

    def fast(self, g: _Gen, ind: int, x: str, path: str) -> str:
        g.emit(ind, f"if type({x}) is not int or {x} < 0 or {x} >= {1 << self.bits}: return None")
        return x

    def pack(self, g: _Gen, src: str, out: Packed) -> None:
        # fixed width (msgpack allows any width for a value): the run of fixed-size fields stays one Struct
        code = {64: ("\xcf", "Q"), 32: ("\xce", "I"), 16: ("\xcd", "H"), 8: ("\xcc", "B")}[self.bits]
        out.fixed(code[0].encode("latin-1"), code[1], src)


class Int(Kind):
    """A small signed integer (counters)."""

    doc = "int"

    def read(self, value: Any, path: str) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ProtocolError(ErrorKind.WRONG_TYPE, f"{path}: expected integer", path)
        return value

    def fast(self, g: _Gen, ind: int, x: str, path: str) -> str:
        g.emit(ind, f"if type({x}) is not int: return None")
        return x

    def pack(self, g: _Gen, src: str, out: Packed) -> None:
        out.expr(f"(_SMALL[{src}] if 0 <= {src} < 128 else _packb({src}))")


@dataclass(frozen=True, slots=True)
class Range:
    """Bounds of a number: `lo < x` (or `lo <= x`), `x <= hi`; `text` is how the error message says it."""

    lo: float | None = None
    lo_open: bool = False
    hi: float | None = None
    text: str = ""

    def holds(self, f: float) -> bool:
        if self.lo is not None and (f <= self.lo if self.lo_open else f < self.lo):
            return False
        return self.hi is None or f <= self.hi

    def cond(self, x: str) -> str:
        parts = []
        if self.lo is not None:
            parts.append(f"{x} {'>' if self.lo_open else '>='} {self.lo!r}")
        if self.hi is not None:
            parts.append(f"{x} <= {self.hi!r}")
        return " and ".join(parts) or "True"


POSITIVE = Range(0.0, True, None, "must be positive")
NON_NEGATIVE = Range(0.0, False, None, "must not be negative")


class Number(Kind):
    """A finite number that fits single precision, within `range` when given."""

    def __init__(self, range: Range | None = None, doc: str = "number") -> None:  # noqa: A002 - the word of the doc
        self.range = range
        self.doc = doc

    def read(self, value: Any, path: str) -> float:
        f = as_float(value, path)
        r = self.range
        if r is not None and not r.holds(f):
            raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}: {r.text}, got {f}", path)
        return f

    def fast(self, g: _Gen, ind: int, x: str, path: str) -> str:
        r = "" if self.range is None else f" and {self.range.cond(x)}"
        g.emit(ind, f"if type({x}) is not float or not (-F32 <= {x} <= F32{r}): return None")
        return x

    def pack(self, g: _Gen, src: str, out: Packed) -> None:
        out.fixed(b"\xcb", "d", src)  # every real as float64, whatever its value


class _Exact(Kind):
    """A value of one msgpack type, read by validate.py's reader for it (the fast reader: its exact type)."""

    type_name = ""

    def read(self, value: Any, path: str) -> Any:
        return (as_bool if self.type_name == "bool" else as_str)(value, path)

    def fast(self, g: _Gen, ind: int, x: str, path: str) -> str:
        g.emit(ind, f"if type({x}) is not {self.type_name}: return None")
        return x


class Bool(_Exact):
    doc = type_name = "bool"

    def pack(self, g: _Gen, src: str, out: Packed) -> None:
        out.flag(src)


class Str(_Exact):
    doc = "string"
    type_name = "str"

    def pack(self, g: _Gen, src: str, out: Packed) -> None:
        # the handful of names a field takes, packed once each (with the key before them)
        prefix = g.const(out.take_prefix(), "B")
        cache = g.const({}, "strs")
        out.expr(f"({cache}.get({src}) or _cached({cache}, {prefix}, {src}))")


class Enum(Kind):
    """A string from `values`; `what` names the set in the error message."""

    def __init__(self, values: tuple[str, ...], what: str | None = None, doc: str = "string") -> None:
        self.values = values
        self.what = what
        self.doc = doc

    def read(self, value: Any, path: str) -> str:
        if self.what is None:  # a short set: both errors list it
            if not isinstance(value, str):
                raise ProtocolError(ErrorKind.WRONG_TYPE, f"{path}: expected a string ({' or '.join(self.values)})", path)
            if value not in self.values:
                raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}: {value[:40]!r} is not one of {', '.join(self.values)}",
                                    path)
            return value
        s = as_str(value, path)
        if s not in self.values:
            raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}: unknown {self.what} {s!r} (known: {', '.join(self.values)})",
                                path)
        return s

    def fast(self, g: _Gen, ind: int, x: str, path: str) -> str:
        g.emit(ind, f"if type({x}) is not str or {x} not in {g.const(frozenset(self.values))}: return None")
        return x


class Value(Kind):
    """Any value, as it comes (reply fields this code writes but never reads back)."""

    def __init__(self, doc: str) -> None:
        self.doc = doc

    def read(self, value: Any, path: str) -> Any:
        return value

    def fast(self, g: _Gen, ind: int, x: str, path: str) -> str:
        return x


class Tag(Kind):
    """A request's tag: a 64-bit integer (signed or not) or a string of at most 256 characters."""

    doc = "int or string"

    def read(self, value: Any, path: str) -> int | str:
        if isinstance(value, bool) or not isinstance(value, (int, str)):
            raise ProtocolError(ErrorKind.WRONG_TYPE, f"{path}: expected integer or string", path)
        if isinstance(value, str) and len(value) > MAX_TAG_LEN:
            raise ProtocolError(ErrorKind.TOO_LARGE, f"{path}: longer than {MAX_TAG_LEN} characters", path)
        if isinstance(value, int) and not -(1 << 63) <= value < (1 << 64):
            raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}: out of 64-bit range", path)
        return value

    def fast(self, g: _Gen, ind: int, x: str, path: str) -> str:
        g.emit(ind, f"if not ((type({x}) is int and {-(1 << 63)} <= {x} < {1 << 64}) "
                    f"or (type({x}) is str and len({x}) <= {MAX_TAG_LEN})): return None")
        return x

    def pack(self, g: _Gen, src: str, out: Packed) -> None:
        out.expr(f"_packb({src})")


class Vector(Kind):
    """`[x, y, z]`: three numbers, read as `build(x, y, z)` (Vec3, or a tuple when build is None)."""

    doc = "Vector"

    def __init__(self, build: Callable[..., Any] | None = None,
                 check: Callable[[Any, str], None] | None = None) -> None:
        self.build = build
        self.check = check  # an engine limit, raising ProtocolError naming the path

    def _built(self, t: tuple[float, float, float]) -> Any:
        return t if self.build is None else self.build(*t)

    def read(self, value: Any, path: str) -> Any:
        v = self._built(as_vec3(value, path))
        if self.check is not None:
            self.check(v, path)
        return v

    def fast(self, g: _Gen, ind: int, x: str, path: str) -> str:
        a, b, c = g.var("a"), g.var("b"), g.var("c")
        g.emit(ind, f"if type({x}) is not list or len({x}) != 3: return None")
        g.emit(ind, f"{a}, {b}, {c} = {x}")
        # a NaN fails every comparison; an infinity or a number beyond float32 the bounds
        g.emit(ind, f"if not (type({a}) is float and type({b}) is float and type({c}) is float and -F32 <= {a} <= F32 "
                    f"and -F32 <= {b} <= F32 and -F32 <= {c} <= F32): return None")
        out = f"({a}, {b}, {c})" if self.build is None else f"{g.const(self.build, 'build')}({a}, {b}, {c})"
        if self.check is not None:
            v = g.var()
            g.emit(ind, f"{v} = {out}")
            g.emit(ind, f"{g.const(self.check, 'check')}({v}, {path})")
            return v
        return out

    def encode(self, g: _Gen, src: str) -> str:
        return f"{g.const(_vec_list, 'vec')}({src})"

    def pack(self, g: _Gen, src: str, out: Packed) -> None:
        out.fixed(b"\x93\xcb", "d", f"{src}.x")
        out.fixed(b"\xcb", "d", f"{src}.y")
        out.fixed(b"\xcb", "d", f"{src}.z")


def _vec_list(v: Any) -> list[float]:
    """A Vec3, or three numbers in a tuple or list, as the wire's list."""
    if type(v) is tuple or type(v) is list:
        x, y, z = v
        return [float(x), float(y), float(z)]
    return [v.x, v.y, v.z]


class Quaternion(Kind):
    """`[w, x, y, z]` of unit length (within 1e-3), read as `build(w, x, y, z)`."""

    doc = "[w, x, y, z]"

    def __init__(self, build: Callable[..., Any]) -> None:
        self.build = build

    def read(self, value: Any, path: str) -> Any:
        return self.build(*as_quat(value, path))

    def fast(self, g: _Gen, ind: int, x: str, path: str) -> str:
        w, a, b, c, n2 = g.var("w"), g.var("a"), g.var("b"), g.var("c"), g.var("n")
        g.emit(ind, f"if type({x}) is not list or len({x}) != 4: return None")
        g.emit(ind, f"{w}, {a}, {b}, {c} = {x}")
        g.emit(ind, f"if not (type({w}) is float and type({a}) is float and type({b}) is float and type({c}) is float): "
                    "return None")
        g.emit(ind, f"{n2} = {w} * {w} + {a} * {a} + {b} * {b} + {c} * {c}")
        # finite components of a unit-length quaternion all lie within [-1.001, 1.001]
        g.emit(ind, f"if not (isfinite({n2}) and abs(sqrt({n2}) - 1.0) <= 1e-3): return None")
        return f"{g.const(self.build, 'build')}({w}, {a}, {b}, {c})"

    def encode(self, g: _Gen, src: str) -> str:
        return f"[{src}.w, {src}.x, {src}.y, {src}.z]"

    def pack(self, g: _Gen, src: str, out: Packed) -> None:
        out.fixed(b"\x94\xcb", "d", f"{src}.w")
        for c in "xyz":
            out.fixed(b"\xcb", "d", f"{src}.{c}")


class ListOf(Kind):
    """An array of `item`s: at most `max_len`, at least `min_len` (`min_text` says why)."""

    def __init__(self, item: Kind, max_len: int | None = None, min_len: int = 0, min_text: str = "",
                 doc: str | None = None) -> None:
        self.item = item
        self.max_len = max_len
        self.min_len = min_len
        self.min_text = min_text
        self.doc = doc or f"array of {item.doc}"

    def read(self, value: Any, path: str) -> list[Any]:
        items = as_list(value, path, self.max_len)
        if len(items) < self.min_len:
            raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}: {self.min_text}", path)
        return [self.item.read(v, field_path(path, i)) for i, v in enumerate(items)]

    def fast(self, g: _Gen, ind: int, x: str, path: str) -> str:
        limit = "" if self.max_len is None else f" or len({x}) > {self.max_len}"
        g.emit(ind, f"if type({x}) is not list or len({x}) < {self.min_len}{limit}: return None")
        if isinstance(self.item, (Str, UInt, Int, Bool)):  # plain values: checked in place, the list kept
            e = g.var("e")
            g.emit(ind, f"for {e} in {x}:")
            self.item.fast(g, ind + 1, e, path)
            return x
        out, e, i = g.var("l"), g.var("e"), g.var("i")
        g.emit(ind, f"{out} = []")
        g.emit(ind, f"for {i}, {e} in enumerate({x}):")
        g.emit(ind + 1, f"{out}.append({self.item.fast(g, ind + 1, e, f'field_path({path}, {i})')})")
        return out

    def encode(self, g: _Gen, src: str) -> str:
        if isinstance(self.item, (Str, UInt, Int, Bool)):
            return f"list({src})"
        e = g.var("e")
        return f"[{self.item.encode(g, e)} for {e} in {src}]"

    def pack(self, g: _Gen, src: str, out: Packed) -> None:
        prefix = out.take_prefix()
        if isinstance(self.item, Str):  # a few distinct lists (transient flags): packed once each, key and all
            cache = g.const({}, "lists")
            out.expr(f"({cache}.get(tuple({src})) or _cached_list({cache}, {g.const(prefix, 'B')}, {src}))")
        else:
            empty = g.const(prefix + b"\x90", "B")  # an empty array
            out.expr(f"({g.const(prefix, 'B')} + _packb({src}) if {src} else {empty})")


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


class Map(Kind):
    """A map of `fields`, read into `build(*values)` (values in field order; a list default copied; with
    `with_path`, the map's path first).

    `one_of`: exactly one of these fields is given (checked where the first of them is read; the fast
    reader tries them in the order of `usual`, the commonest first). `rules`:
    checks of the built value. `checks`: further checks that raise ProtocolError themselves (engine
    limits). `label`: how an error at the top (path "") names the message.
    """

    def __init__(self, name: str, fields: tuple[Field, ...], build: Callable[..., Any] | None = None, *,
                 one_of: tuple[str, ...] = (), rules: tuple[Rule, ...] = (),
                 checks: tuple[Callable[[Any, str], None], ...] = (), label: str = "message",
                 doc: str | None = None, with_path: bool = False, usual: tuple[str, ...] = ()) -> None:
        self.name = name
        self.fields = fields
        self.by_name = {f.name: f for f in fields}
        self.build = build
        self.one_of = one_of
        self.rules = rules
        self.checks = checks
        self.label = label
        self.with_path = with_path
        self.usual = usual
        self.doc = doc or name
        self._fast: Callable[[Any, str], Any] | None = None
        self._encode: Callable[[Any], dict[str, Any]] | None = None

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
        built = self.build(path, *values.values()) if self.with_path else self.build(*values.values())
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
            g = _Gen()
            fn = f"fast_{self.name}"
            g.emit(0, f"def {fn}(m, path):")
            g.emit(1, f"return {self.fast(g, 1, 'm', 'path')}")  # the body is emitted before this line
            self._fast = g.compile(fn)
        return self._fast

    def fast(self, g: _Gen, ind: int, x: str, path: str) -> str:
        if self.build is None:
            raise TypeError(f"{self.name}: a map without a build has no fast reader")
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
            if f.name in self.one_of:
                if f.name == self.one_of[0]:
                    self._fast_one_of(g, ind, x, path, n, out)
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
            if f.excludes is not None:
                g.emit(ind + 1, f"if {out[f.excludes[0]]} is not None: return None")
            g.emit(ind + 1, f"{v} = {self._fast_value(g, ind + 1, f, raw, fp)}")
            g.emit(ind + 1, f"{n} += 1")
        g.emit(ind, f"if {n} != len({x}): return None")  # an unknown key: the full reader ignores it or refuses
        built = g.var("m")
        args = ", ".join(([path] if self.with_path else []) + [out[f.name] for f in self.fields if f.read])
        g.emit(ind, f"{built} = {g.const(self.build, 'build')}({args})")
        for r in self.rules:
            g.emit(ind, f"if not {g.const(r.holds, 'rule')}({built}): return None")
        for c in self.checks:
            g.emit(ind, f"{g.const(c, 'check')}({built}, {path})")
        return built

    def _fast_one_of(self, g: _Gen, ind: int, x: str, path: str, n: str, out: dict[str, str]) -> None:
        """The `one_of` fields: the first one given is read and the others not looked at; one of them given
        as well is then a key not counted, so the key count refuses the map (and the full reader says why)."""
        names = sorted(self.one_of, key=lambda k: self.usual.index(k) if k in self.usual else len(self.usual))
        for k in names:
            out[k] = g.var()
        for depth, k in enumerate(names):
            f = self.by_name[k]
            at = ind + depth
            raw = g.var("x")
            g.emit(at, f"{raw} = {x}.get({k!r})")
            last = depth == len(names) - 1
            g.emit(at, f"if {raw} is {'None: return None' if last else 'not None:'}")
            body = at if last else at + 1
            for other in names:
                if other != k:
                    g.emit(body, f"{out[other]} = None")
            g.emit(body, f"{out[k]} = {self._fast_value(g, body, f, raw, f'field_path({path}, {k!r})')}")
            g.emit(body, f"{n} += 1")
            if not last:
                g.emit(at, "else:")

    @staticmethod
    def _fast_value(g: _Gen, ind: int, f: Field, raw: str, fp: str) -> str:
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
            g = _Gen()
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

    def encode(self, g: _Gen, src: str) -> str:
        return f"{g.const(self.encode_fn(), 'enc')}({src})"

    def packer(self, args: str) -> Callable[..., bytes]:
        """A function of `args` writing this map's msgpack bytes directly (service/packing.py)."""
        from .packing import make_packer  # the packer generator needs this module's kinds

        return make_packer(self, args)
