"""A map's msgpack bytes written directly by a function generated from its declaration (service/protocol/schema.py)
into a module of its own (service/protocol/generate.py).

The per-move State is written this way: fixed-size values (ids, seq, cell, reals, booleans) and the
constant bytes around them (keys, headers) are packed in one `struct` call per run, the few strings and
string lists a field takes are packed once and looked up (dicts that pack what they lack), and a nil or a
value is one piece each; the pieces, the optional fields' included, are joined once. Constant bytes are
literals of the generated source (loaded as the code's constants, not looked up by name). The bytes
decode to exactly the map the declaration's `encode_fn` gives.
"""

from __future__ import annotations

from service.protocol.schema import Field, Map
from service.protocol.schema_kinds import Kind, Packed, Quaternion, SourceGen, Vector, packb

__all__ = ["packer_module"]

_NIL = b"\xc0"


def packer_module(m: Map, args: str, returns: str, imports: tuple[str, ...], doc: str) -> str:
    """The source of a module defining a function of `args`, `pack_<Map name>`, writing `m`'s msgpack
    bytes (fields whose `src` reads the arguments, nested maps flattened, fixed-size values packed
    together; `omit` fields last, the map's entry count counting them when given), and the constants
    it refers to. A module of its own, so that mypyc can compile it (service/protocol/generate.py
    writes it). `args` may carry annotations and `returns` is the return annotation; `imports` are the
    lines they need; `doc` is the module's docstring. The constants are `Final`: mypyc keeps those in C
    variables instead of the module's dict."""
    g, fn = _generate(m, args, f" -> {returns}")
    missing = [name for name in g.ns if name.startswith("_") and name not in g.sources and name != "_packb"]
    if missing:
        raise ValueError(f"{m.name}: constants {missing} have no source form")
    out = [f'"""{doc}"""', "", "from __future__ import annotations", "", "from struct import Struct",
           "from typing import Any, Final", "", *imports,
           "from service.protocol.schema_kinds import packb as _packb, packed_new", "",
           "__all__ = [" + repr(fn) + "]", ""]
    for name, (annotation, source) in g.sources.items():
        out.append(f"{name}: Final[{annotation}] = {source}" if annotation else f"{name}: Final = {source}")
    out += ["", ""] + g.lines
    return "\n".join(out) + "\n"


def _generate(m: Map, args: str, returns: str = "") -> tuple[SourceGen, str]:
    """The packer's generated source (in `g.lines`) and its function's name."""
    g = SourceGen()
    g.ns.update(_packb=packb)
    out = Packed(g)
    always = [f for f in m.fields if not f.omit]
    omissible = [f for f in m.fields if f.omit]
    count = f"{len(always)}" + "".join(f" + ({f.source('')} is not None)" for f in omissible)
    out.fixed(b"\xde", "H", count)
    for f in always:
        _pack_field(g, f, f.source(""), out, True)
    for f in omissible:  # in the one join with the rest: no second copy of the bytes
        inner = Packed(g)
        _pack_field(g, f, f.source(""), inner, False)
        out.expr(f"(b'' if {f.source('')} is None else {inner.join()})")
    fn = f"pack_{m.name}"
    g.emit(0, f"def {fn}({args}){returns}:")
    for line in out.pre:
        g.emit(1, line)
    g.emit(1, f"return {out.join()}")
    return g, fn


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
    key = packb(f.name)
    if f.nullable:  # the key goes into both branches: one piece, not two
        local = _hoisted(g, src, out, hoist)
        inner = Packed(g)
        inner.const(key)
        _pack_value(g, f.kind, local, inner, False)
        out.expr(f"({key + _NIL!r} if {local} is None else {inner.join()})")
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
