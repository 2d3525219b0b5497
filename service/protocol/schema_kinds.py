"""The value kinds of the wire schema (service/protocol/schema.py): what a field's value may be.

Each `Kind` reads a value the full way (`read`, naming the field on refusal), writes the source of its
check into a generated fast reader (`fast`), and knows how to encode and pack it. `SourceGen` collects
that generated source and the constants it refers to.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from struct import Struct
from typing import Any

import msgpack

from engine.limits import FLOAT32_MAX

from service.protocol.errors import ProtocolError
from service.protocol.validate import (
    as_bool,
    as_float,
    as_list,
    as_quat,
    as_str,
    as_uint,
    as_vec3,
    field_path,
)
from service.protocol.wire import ErrorKind

__all__ = [
    "SourceGen", "Kind", "UInt", "Int", "Range", "POSITIVE", "NON_NEGATIVE", "Number", "Bool", "Str", "Enum", "Value",
    "Tag", "Vector", "Quaternion", "ListOf", "MAX_TAG_LEN", "Packed", "packb", "packed_new",
]

MAX_TAG_LEN = 256


class SourceGen:
    """Python source being generated, and the names it refers to."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.ns: dict[str, Any] = {"ProtocolError": ProtocolError, "field_path": field_path, "isfinite": math.isfinite,
                                   "sqrt": math.sqrt, "F32": FLOAT32_MAX}
        #: each constant's definition as module source (`annotation`, `expression`), where it has one:
        #: what `module_source` writes for a generated module (service/protocol/packing.py)
        self.sources: dict[str, tuple[str | None, str]] = {}
        self._n = 0

    def var(self, stem: str = "v") -> str:
        self._n += 1
        return f"{stem}{self._n}"

    def const(self, value: Any, stem: str = "K", source: str | None = None, annotation: str | None = None) -> str:
        """A name for `value` in the generated code; `source` is an expression that makes the same value in
        a module of its own (with `annotation`, the type a checker needs, such as an empty dict's)."""
        name = self.var(f"_{stem}")
        self.ns[name] = value
        if source is not None:
            self.sources[name] = (annotation, source)
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

    def fast(self, g: SourceGen, ind: int, x: str, path: str) -> str:
        raise NotImplementedError

    def encode(self, g: SourceGen, src: str) -> str:
        return src

    def pack(self, g: SourceGen, src: str, out: Packed) -> None:
        """Append the msgpack bytes of `src` to `out` (default: msgpack's own packing)."""
        out.expr(f"_packb({self.encode(g, src)})")



class UInt(Kind):
    def __init__(self, bits: int = 64) -> None:
        self.bits = bits
        self.doc = f"uint{bits}"

    def read(self, value: Any, path: str) -> int:
        return as_uint(value, path, self.bits)

    def fast(self, g: SourceGen, ind: int, x: str, path: str) -> str:
        g.emit(ind, f"if type({x}) is not int or {x} < 0 or {x} >= {1 << self.bits}: return None")
        return x

    def pack(self, g: SourceGen, src: str, out: Packed) -> None:
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

    def fast(self, g: SourceGen, ind: int, x: str, path: str) -> str:
        g.emit(ind, f"if type({x}) is not int: return None")
        return x

    def pack(self, g: SourceGen, src: str, out: Packed) -> None:
        # 0..127 (a counter's usual values) looked up with the key before them; any other packed
        prefix = out.take_prefix()
        small = g.const(tuple(prefix + packb(i) for i in range(128)), "small",
                        source=f"tuple({prefix!r} + _packb(i) for i in range(128))")
        out.expr(f"({small}[{src}] if 0 <= {src} < 128 else {prefix!r} + _packb({src}))")


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

    def fast(self, g: SourceGen, ind: int, x: str, path: str) -> str:
        if self.range is not None:  # none of the maps read fast (the State's) has one
            raise TypeError("a number with a range has no fast reader")
        g.emit(ind, f"if type({x}) is not float or not (-F32 <= {x} <= F32): return None")
        return x

    def pack(self, g: SourceGen, src: str, out: Packed) -> None:
        out.fixed(b"\xcb", "d", src)  # every real as float64, whatever its value


class _Exact(Kind):
    """A value of one msgpack type, read by validate.py's reader for it (the fast reader: its exact type)."""

    type_name = ""

    def read(self, value: Any, path: str) -> Any:
        return (as_bool if self.type_name == "bool" else as_str)(value, path)

    def fast(self, g: SourceGen, ind: int, x: str, path: str) -> str:
        g.emit(ind, f"if type({x}) is not {self.type_name}: return None")
        return x


class Bool(_Exact):
    doc = type_name = "bool"

    def pack(self, g: SourceGen, src: str, out: Packed) -> None:
        out.flag(src)


class Str(_Exact):
    doc = "string"
    type_name = "str"

    def pack(self, g: SourceGen, src: str, out: Packed) -> None:
        # the handful of names a field takes, packed once each (with the key before them)
        out.expr(lookup(g, {}, src, src, out.take_prefix(), 64))


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

    def fast(self, g: SourceGen, ind: int, x: str, path: str) -> str:
        g.emit(ind, f"if type({x}) is not str or {x} not in {g.const(frozenset(self.values))}: return None")
        return x


class Value(Kind):
    """Any value, as it comes (reply fields this code writes but never reads back)."""

    def __init__(self, doc: str) -> None:
        self.doc = doc

    def read(self, value: Any, path: str) -> Any:
        return value

    def fast(self, g: SourceGen, ind: int, x: str, path: str) -> str:
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

    def fast(self, g: SourceGen, ind: int, x: str, path: str) -> str:
        g.emit(ind, f"if not ((type({x}) is int and {-(1 << 63)} <= {x} < {1 << 64}) "
                    f"or (type({x}) is str and len({x}) <= {MAX_TAG_LEN})): return None")
        return x

    def pack(self, g: SourceGen, src: str, out: Packed) -> None:
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

    def fast(self, g: SourceGen, ind: int, x: str, path: str) -> str:
        a, b, c = g.var("a"), g.var("b"), g.var("c")
        g.emit(ind, f"if type({x}) is not list or len({x}) != 3: return None")
        g.emit(ind, f"{a}, {b}, {c} = {x}")
        # a NaN fails every comparison; an infinity or a number beyond float32 the bounds
        g.emit(ind, f"if not (type({a}) is float and type({b}) is float and type({c}) is float and -F32 <= {a} <= F32 "
                    f"and -F32 <= {b} <= F32 and -F32 <= {c} <= F32): return None")
        if self.check is not None:  # none of the maps read fast (the State's) has one
            raise TypeError("a checked vector has no fast reader")
        return f"({a}, {b}, {c})" if self.build is None else f"{g.const(self.build, 'build')}({a}, {b}, {c})"

    def encode(self, g: SourceGen, src: str) -> str:
        return f"{g.const(_vec_list, 'vec')}({src})"

    def pack(self, g: SourceGen, src: str, out: Packed) -> None:
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

    def fast(self, g: SourceGen, ind: int, x: str, path: str) -> str:
        w, a, b, c, n2 = g.var("w"), g.var("a"), g.var("b"), g.var("c"), g.var("n")
        g.emit(ind, f"if type({x}) is not list or len({x}) != 4: return None")
        g.emit(ind, f"{w}, {a}, {b}, {c} = {x}")
        g.emit(ind, f"if not (type({w}) is float and type({a}) is float and type({b}) is float and type({c}) is float): "
                    "return None")
        g.emit(ind, f"{n2} = {w} * {w} + {a} * {a} + {b} * {b} + {c} * {c}")
        # finite components of a unit-length quaternion all lie within [-1.001, 1.001]
        g.emit(ind, f"if not (isfinite({n2}) and abs(sqrt({n2}) - 1.0) <= 1e-3): return None")
        return f"{g.const(self.build, 'build')}({w}, {a}, {b}, {c})"

    def encode(self, g: SourceGen, src: str) -> str:
        return f"[{src}.w, {src}.x, {src}.y, {src}.z]"

    def pack(self, g: SourceGen, src: str, out: Packed) -> None:
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

    def fast(self, g: SourceGen, ind: int, x: str, path: str) -> str:
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

    def encode(self, g: SourceGen, src: str) -> str:
        if isinstance(self.item, (Str, UInt, Int, Bool)):
            return f"list({src})"
        e = g.var("e")
        return f"[{self.item.encode(g, e)} for {e} in {src}]"

    def pack(self, g: SourceGen, src: str, out: Packed) -> None:
        prefix = out.take_prefix()
        if isinstance(self.item, Str):  # a few distinct lists (transient flags): packed once each, key and all
            out.expr(lookup(g, {}, f"tuple({src})", src, prefix, 256))
        else:  # an empty array, or the list packed
            empty = prefix + b"\x90"
            out.expr(f"({prefix!r} + _packb({src}) if {src} else {empty!r})")


def packb(value: Any) -> bytes:
    """msgpack's bytes of `value` (strings as str, bytes as bin)."""
    return bytes(msgpack.packb(value, use_bin_type=True))


def lookup(g: SourceGen, cache: dict[Any, bytes], key: str, value: str, prefix: bytes, limit: int) -> str:
    """An expression of `value`'s bytes after `prefix`, looked up in `cache` by `key` (both expressions),
    packed and kept there when missing while the cache holds fewer than `limit` (a field takes a handful
    of values: any past them is packed each time). An exact dict's `get`: cheaper than a subclass's
    `__missing__`, whose subscript Python does not specialize."""
    c = g.const(cache, "cache", source="{}", annotation="dict[Any, bytes]")
    return f"({c}.get({key}) or {g.const(packed_new, 'new', source='packed_new')}({c}, {key}, {value}, {prefix!r}, {limit}))"


def packed_new(cache: dict[Any, bytes], key: Any, value: Any, prefix: bytes, limit: int) -> bytes:
    """`value` packed after `prefix`, kept in `cache` under `key` while it holds fewer than `limit` (a
    generated packer's lookup, when the value is new)."""
    b = prefix + packb(value)
    if len(cache) < limit:
        cache[key] = b
    return b


#: msgpack's true and false, as Packed writes a boolean
_TRUE, _FALSE = b"\xc3", b"\xc2"


class Packed:
    """Bytes being put together: runs of constants and fixed-size values become one Struct each.

    Constant bytes are written into the generated source as literals (a local constant to the code,
    cheaper to load than a name), beside each other merged into one."""

    def __init__(self, g: SourceGen) -> None:
        self.g = g
        self.parts: list[str] = []
        self.pre: list[str] = []  # statements the parts need first (locals)
        self._codes: list[str] = []  # the pending run: each argument's Struct code
        self._args: list[str | bytes] = []  # ... and the argument: an expression, or constant bytes
        self._flags: dict[int, str] = {}  # argument index: the boolean it packs

    def const(self, b: bytes) -> None:
        if not b:
            return
        if self._args and isinstance(self._args[-1], bytes):  # one constant, not two beside each other
            b = self.take_prefix() + b
        self._codes.append(f"{len(b)}s")
        self._args.append(b)

    def flag(self, cond: str) -> None:
        """A boolean: one byte, true or false."""
        self._codes.append("B")
        self._args.append(f"(0xC3 if {cond} else 0xC2)")
        self._flags[len(self._args) - 1] = cond

    def fixed(self, prefix: bytes, code: str, value: str) -> None:
        self.const(prefix)
        self._codes.append(code)
        self._args.append(value)

    def take_prefix(self) -> bytes:
        """The constant bytes at the end of the pending run, taken out of it (the next piece includes them)."""
        if not self._args or not isinstance(self._args[-1], bytes):
            return b""
        self._codes.pop()
        taken = self._args.pop()
        assert isinstance(taken, bytes)
        return taken

    def expr(self, e: str) -> None:
        self._flush()
        self.parts.append(e)

    def _flush(self) -> None:
        if not self._args:
            return
        if all(isinstance(a, bytes) or i in self._flags for i, a in enumerate(self._args)) and len(self._flags) <= 3:
            # constants and a few booleans: every combination written out, chosen by the booleans
            self.parts.append(self._choice({}))
        else:
            fmt = ">" + "".join(self._codes)
            s = self.g.const(Struct(fmt).pack, "pack", source=f"Struct({fmt!r}).pack")
            self.parts.append(f"{s}({', '.join(repr(a) if isinstance(a, bytes) else a for a in self._args)})")
        self._codes, self._args, self._flags = [], [], {}

    def _choice(self, values: dict[int, bool]) -> str:
        """The run's bytes given the booleans in `values`, the others chosen by nested conditionals."""
        undecided = [i for i in self._flags if i not in values]
        if not undecided:
            run = b""
            for i, a in enumerate(self._args):
                if i in values:
                    run += _TRUE if values[i] else _FALSE
                elif isinstance(a, bytes):  # every other argument is (see _flush)
                    run += a
            return repr(run)
        i = undecided[0]
        return f"({self._choice({**values, i: True})} if {self._flags[i]} else {self._choice({**values, i: False})})"

    def join(self) -> str:
        self._flush()
        if len(self.parts) <= 2:
            return " + ".join(self.parts) if self.parts else "b''"
        return f"b''.join(({', '.join(self.parts)},))"
