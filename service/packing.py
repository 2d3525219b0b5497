"""A map's msgpack bytes written directly by a function generated from its declaration (service/schema.py).

The per-move State is written this way: fixed-size values (ids, seq, cell, reals, booleans) and the
constant bytes around them (keys, headers) are packed in one `struct` call per run, the few strings and
string lists a field takes are packed once and looked up, and a nil or a value is one piece each. The
bytes decode to exactly the map the declaration's `encode_fn` gives.
"""

from __future__ import annotations

from collections.abc import Callable
from struct import Struct
from typing import Any

import msgpack

from .schema import Field, Map
from .schema_kinds import Kind, Quaternion, SourceGen, Vector

__all__ = ["Packed", "make_packer"]

_NIL, _TRUE, _FALSE = b"\xc0", b"\xc3", b"\xc2"


def make_packer(m: Map, args: str) -> Callable[..., bytes]:
    """A function of `args` writing `m`'s msgpack bytes: fields whose `src` reads the arguments,
    nested maps flattened, fixed-size values packed together. `omit` fields come last, and the map's
    entry count counts them when given."""
    g = SourceGen()
    g.ns.update(_packb=_packb, _cached=_cached, _cached_list=_cached_list, _NIL=_NIL, _SMALL=_SMALL)
    out = Packed(g)
    always = [f for f in m.fields if not f.omit]
    omissible = [f for f in m.fields if f.omit]
    count = f"{len(always)}" + "".join(f" + ({f.source('')} is not None)" for f in omissible)
    out.fixed(b"\xde", "H", count)
    for f in always:
        _pack_field(g, f, f.source(""), out, True)
    tail = Packed(g)
    for f in omissible:
        inner = Packed(g)
        _pack_field(g, f, f.source(""), inner, False)
        tail.expr(f"(b'' if {f.source('')} is None else {inner.join()})")
    fn = f"pack_{m.name}"
    g.emit(0, f"def {fn}({args}):")
    for line in out.pre:
        g.emit(1, line)
    g.emit(1, f"return {out.join()}{' + ' + tail.join() if omissible else ''}")
    return g.compile(fn)  # type: ignore[no-any-return]


def _hoisted(g: SourceGen, src: str, out: Packed, hoist: bool) -> str:
    """`src` as a local (evaluated once) where it is an expression and locals may be set up front."""
    if not hoist or src.isidentifier():
        return src
    local = g.var("o")
    out.pre.append(f"{local} = {src}")
    return local


def _pack_field(g: SourceGen, f: Field, src: str, out: Packed, hoist: bool) -> None:
    """The field's key and value. `hoist`: locals may be set at the function's start (not inside a
    branch taken only when an enclosing value is given)."""
    key = _packb(f.name)
    if f.nullable:  # the key goes into both branches: one piece, not two
        local = _hoisted(g, src, out, hoist)
        inner = Packed(g)
        inner.const(key)
        _pack_value(g, f.kind, local, inner, False)
        out.expr(f"({g.const(key + _NIL, 'B')} if {local} is None else {inner.join()})")
    else:
        out.const(key)
        _pack_value(g, f.kind, src, out, hoist)


def _pack_value(g: SourceGen, kind: Kind, src: str, out: Packed, hoist: bool) -> None:
    if isinstance(kind, Map):  # flattened into the enclosing bytes; every field present
        obj = _hoisted(g, src, out, hoist)
        out.const(bytes((0x80 | len(kind.fields),)))
        for f in kind.fields:
            _pack_field(g, f, f.source(obj), out, hoist)
    elif isinstance(kind, (Vector, Quaternion)):
        kind.pack(g, _hoisted(g, src, out, hoist), out)
    else:
        kind.pack(g, src, out)


class Packed:
    """Bytes being put together: runs of constants and fixed-size values become one Struct each."""

    def __init__(self, g: SourceGen) -> None:
        self.g = g
        self.parts: list[str] = []
        self.pre: list[str] = []  # statements the parts need first (locals)
        self._fmt = ""
        self._args: list[str] = []
        self._consts: set[str] = set()
        self._flags: dict[int, str] = {}  # argument index: the boolean it packs

    def const(self, b: bytes) -> None:
        if b:
            if self._args and self._args[-1] in self._consts:  # one constant, not two beside each other
                b = self.take_prefix() + b
            self._fmt += f"{len(b)}s"
            name = self.g.const(b, "B")
            self._consts.add(name)
            self._args.append(name)

    def flag(self, cond: str) -> None:
        """A boolean: one byte, true or false."""
        self._fmt += "B"
        self._args.append(f"(0xC3 if {cond} else 0xC2)")
        self._flags[len(self._args) - 1] = cond

    def fixed(self, prefix: bytes, code: str, value: str) -> None:
        self.const(prefix)
        self._fmt += code
        self._args.append(value)

    def take_prefix(self) -> bytes:
        """The constant bytes at the end of the pending run, taken out of it (the next piece includes them)."""
        taken = b""
        while self._args and self._args[-1] in self._consts:
            name = self._args.pop()
            b = self.g.ns[name]
            self._fmt = self._fmt[: -len(f"{len(b)}s")]
            taken = b + taken
        return taken

    def expr(self, e: str) -> None:
        self._flush()
        self.parts.append(e)

    def _flush(self) -> None:
        if not self._args:
            return
        if all(a in self._consts for a in self._args):  # constants only
            self.parts.append(self.g.const(b"".join(self.g.ns[a] for a in self._args), "B"))
        elif len(self._flags) <= 3 and all(a in self._consts or i in self._flags for i, a in enumerate(self._args)):
            # constants and a few booleans: every combination packed once, looked up
            table = {}
            for bits in range(1 << len(self._flags)):
                values = dict(zip(self._flags, ((bits >> k) & 1 == 1 for k in range(len(self._flags)))))
                table[tuple(values.values())] = b"".join(
                    (_TRUE if values[i] else _FALSE) if i in values else self.g.ns[a] for i, a in enumerate(self._args))
            conds = list(self._flags.values())
            if len(conds) == 1:
                t = self.g.const(table[(True,)], "B")
                f = self.g.const(table[(False,)], "B")
                self.parts.append(f"({t} if {conds[0]} else {f})")
            else:
                self.parts.append(f"{self.g.const(table, 'flags')}[{', '.join(f'bool({c})' for c in conds)}]")
        else:
            s = self.g.const(Struct(">" + self._fmt).pack, "pack")
            self.parts.append(f"{s}({', '.join(self._args)})")
        self._fmt, self._args = "", []
        self._consts, self._flags = set(), {}

    def join(self) -> str:
        self._flush()
        if len(self.parts) <= 2:
            return " + ".join(self.parts) if self.parts else "b''"
        return f"b''.join(({', '.join(self.parts)},))"


def _packb(value: Any) -> bytes:
    return bytes(msgpack.packb(value, use_bin_type=True))


_SMALL = [_packb(i) for i in range(128)]  # positive fixints


def _cached(cache: dict[str, bytes], prefix: bytes, s: str) -> bytes:
    b = prefix + _packb(s)
    if len(cache) < 64:  # the names are a handful; anything else is packed each time
        cache[s] = b
    return b


def _cached_list(cache: dict[tuple[str, ...], bytes], prefix: bytes, names: list[str]) -> bytes:
    b = prefix + _packb(names)
    if len(cache) < 256:
        cache[tuple(names)] = b
    return b
