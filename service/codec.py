"""The engine's value types to and from their wire maps (docs/protocol.md).

Only the engine's plain value types are used here (geometry and
`engine.world.types`), so the client library can share this codec without
pulling in the World. Decoders validate as they go and raise ProtocolError
naming the field; encoders trust their input.
"""

from __future__ import annotations

from math import isfinite
from struct import Struct
from typing import Any

import msgpack

from engine.errors import EngineError
from engine.geometry import Plane, Position, Quat, Vec3
from engine.limits import check_mover_spec
from engine.world.types import CylSphereSpec, MoverSpec, MoveResult, ObjectState, SphereSpec

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
    get_field,
    opt_field,
    plain_floats3,
    plain_unit_quat,
)
from .wire import ErrorKind

__all__ = [
    "decode_position",
    "decode_plane",
    "decode_mover_spec",
    "encode_position",
    "encode_plane",
    "encode_vec",
    "encode_mover_spec",
    "encode_state",
    "pack_state",
    "decode_state",
    "read_state",
    "MAX_SPHERES",
]

MAX_SPHERES = 32


# -- decoding (requests) --------------------------------------------------
def decode_position(
    value: Any,
    path: str,
    *,
    default_cell: int | None = None,
    default_orientation: Quat | None = None,
) -> Position:
    """`{"cell", "origin", "orientation"}`; cell/orientation may default."""
    m = as_map(value, path)
    raw_cell = opt_field(m, "cell")
    if raw_cell is None:
        if default_cell is None:
            get_field(m, "cell", path)  # raises missing_field
        cell = default_cell
    else:
        cell = as_uint(raw_cell, field_path(path, "cell"), 32)
    origin = Vec3(*as_vec3(get_field(m, "origin", path), field_path(path, "origin")))
    raw_q = opt_field(m, "orientation")
    if raw_q is None:
        q = default_orientation if default_orientation is not None else Quat()
    else:
        q = Quat(*as_quat(raw_q, field_path(path, "orientation")))
    assert cell is not None
    return Position.at(cell, origin, q)


def decode_plane(value: Any, path: str) -> Plane:
    m = as_map(value, path)
    nx, ny, nz = as_vec3(get_field(m, "normal", path), field_path(path, "normal"))
    d = as_float(get_field(m, "d", path), field_path(path, "d"))
    if abs((nx * nx + ny * ny + nz * nz) ** 0.5 - 1.0) > 1e-3:
        raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}.normal: not a unit vector", field_path(path, "normal"))
    return Plane(Vec3(nx, ny, nz), d)


def _positive(value: Any, path: str) -> float:
    f = as_float(value, path)
    if f <= 0.0:
        raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}: must be positive, got {f}", path)
    return f


def _non_negative(value: Any, path: str) -> float:
    f = as_float(value, path)
    if f < 0.0:
        raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}: must not be negative, got {f}", path)
    return f


def _opt(m: dict[str, Any], key: str, path: str, reader: Any, default: Any) -> Any:
    raw = opt_field(m, key)
    return default if raw is None else reader(raw, field_path(path, key))


def decode_mover_spec(value: Any, path: str) -> MoverSpec:
    """A MoverSpec map (the trace format's `object` block)."""
    m = as_map(value, path)
    sp_path = field_path(path, "spheres")
    raw_spheres = as_list(get_field(m, "spheres", path), sp_path, MAX_SPHERES)
    if not raw_spheres:
        raise ProtocolError(ErrorKind.BAD_VALUE, f"{sp_path}: at least one sphere is needed", sp_path)
    spheres = []
    for i, raw in enumerate(raw_spheres):
        p = field_path(sp_path, i)
        s = as_map(raw, p)
        spheres.append(
            SphereSpec(
                as_vec3(get_field(s, "center", p), field_path(p, "center")),
                _positive(get_field(s, "radius", p), field_path(p, "radius")),
            )
        )
    cyl_path = field_path(path, "cyl_spheres")
    cyls = []
    for i, raw in enumerate(as_list(opt_field(m, "cyl_spheres") or [], cyl_path, MAX_SPHERES)):
        p = field_path(cyl_path, i)
        c = as_map(raw, p)
        cyls.append(
            CylSphereSpec(
                as_vec3(get_field(c, "origin", p), field_path(p, "origin")),
                _positive(get_field(c, "radius", p), field_path(p, "radius")),
                _non_negative(get_field(c, "height", p), field_path(p, "height")),
            )
        )
    st_path = field_path(path, "state")
    names = [as_str(v, field_path(st_path, i)) for i, v in enumerate(as_list(opt_field(m, "state") or [], st_path, 32))]
    for i, n in enumerate(names):
        if n not in ObjectState.BY_NAME:
            p = field_path(st_path, i)
            raise ProtocolError(
                ErrorKind.BAD_VALUE, f"{p}: unknown ObjectInfoState flag {n!r} (known: {', '.join(ObjectState.BY_NAME)})", p
            )
    creature_raw = opt_field(m, "creature")
    spec = MoverSpec(
        spheres=spheres,
        step_up_height=_opt(m, "step_up_height", path, _non_negative, 0.4),
        step_down_height=_opt(m, "step_down_height", path, _non_negative, 0.4),
        state=names,
        step_down=_opt(m, "step_down", path, as_bool, True),
        ethereal=_opt(m, "ethereal", path, as_bool, False),
        scale=_opt(m, "scale", path, _positive, 1.0),
        gravity=_opt(m, "gravity", path, as_bool, True),
        creature=None if creature_raw is None else as_bool(creature_raw, field_path(path, "creature")),
        cyl_spheres=cyls,
        sledding=_opt(m, "sledding", path, as_bool, False),
    )
    try:  # sizes within the engine's limits (docs/protocol.md, "Limits")
        check_mover_spec(spec, path)
    except EngineError as e:
        raise ProtocolError(ErrorKind.BAD_VALUE, str(e), e.field or path) from None
    return spec


# -- encoding (replies, states) -------------------------------------------
def encode_vec(v: Vec3 | None) -> list[float] | None:
    return None if v is None else [v.x, v.y, v.z]


def encode_position(p: Position) -> dict[str, Any]:
    o, q = p.frame.origin, p.frame.orientation
    return {"cell": p.cell_id, "origin": [o.x, o.y, o.z], "orientation": [q.w, q.x, q.y, q.z]}


def encode_plane(p: Plane | None) -> dict[str, Any] | None:
    if p is None:
        return None
    return {"normal": [p.normal.x, p.normal.y, p.normal.z], "d": p.d}


def encode_mover_spec(s: MoverSpec) -> dict[str, Any]:
    return {
        "spheres": [{"center": list(sp.center), "radius": sp.radius} for sp in s.spheres],
        "step_up_height": s.step_up_height,
        "step_down_height": s.step_down_height,
        "state": list(s.state),
        "step_down": s.step_down,
        "ethereal": s.ethereal,
        "scale": s.scale,
        "gravity": s.gravity,
        "creature": s.creature,
        "sledding": s.sledding,
        "cyl_spheres": [{"origin": list(c.origin), "radius": c.radius, "height": c.height} for c in s.cyl_spheres],
    }


def encode_state(
    mover_id: int, seq: int, r: MoveResult, collide_ids: list[int], tag: int | str | None = None
) -> dict[str, Any]:
    """The State map: what a move resolved to, as published and replied."""
    # written out (no helper calls): this runs once per move
    pos = r.position
    o, q = pos.frame.origin, pos.frame.orientation
    cp, cn, sn = r.contact_plane, r.collision_normal, r.sliding_normal
    out: dict[str, Any] = {
        "id": mover_id,
        "seq": seq,
        "ok": r.ok,
        "position": {"cell": pos.cell_id, "origin": [o.x, o.y, o.z], "orientation": [q.w, q.x, q.y, q.z]},
        "landblock": (pos.cell_id >> 16) & 0xFFFF,
        "transition_state": r.transition_state,
        "contact": r.contact,
        "on_walkable": r.on_walkable,
        "contact_plane": None if cp is None else {"normal": [cp.normal.x, cp.normal.y, cp.normal.z], "d": cp.d},
        "contact_plane_cell": r.contact_plane_cell,
        "collision_normal": None if cn is None else [cn.x, cn.y, cn.z],
        "sliding_normal": None if sn is None else [sn.x, sn.y, sn.z],
        "water_contact": r.water_contact,
        "frames_stationary_fall": r.frames_stationary_fall,
        "transient_state": list(r.transient_state),
        "collide_objects": collide_ids,
    }
    if tag is not None:
        out["tag"] = tag
    return out


# -- the State packed directly (the service's per-move path) --------------------
def _key(name: str) -> bytes:
    return bytes(msgpack.packb(name))


def _uint(n: int) -> bytes:
    """A non-negative int as msgpack packs it (the smallest form)."""
    if n < 0x80:
        return _BYTE[n]
    if n < 0x100:
        return b"\xcc" + _BYTE[n]
    if n < 0x10000:
        return b"\xcd" + n.to_bytes(2, "big")
    if n < 0x100000000:
        return b"\xce" + n.to_bytes(4, "big")
    return b"\xcf" + n.to_bytes(8, "big")


class _Fixed:
    """A Struct format whose constant bytes are given with it: `pack` takes only the values."""

    def __init__(self) -> None:
        self.fmt = ">"
        self.args: list[bytes] = []

    def const(self, b: bytes) -> _Fixed:
        self.fmt += f"{len(b)}s"
        self.args.append(b)
        return self

    def value(self, code: str) -> _Fixed:
        self.fmt += code
        return self


_BYTE = [bytes((i,)) for i in range(0x100)]
_NIL, _TRUE, _FALSE = b"\xc0", b"\xc3", b"\xc2"
_F64, _U64, _U32, _U16 = b"\xcb", b"\xcf", b"\xce", b"\xcd"


def _head(entries: int) -> tuple[Struct, list[bytes]]:
    """id, seq, ok, position and landblock, up to the transition_state key; ints in fixed widths."""
    f = (_Fixed().const(b"\xde" + entries.to_bytes(2, "big") + _key("id") + _U64).value("Q")
         .const(_key("seq") + _U64).value("Q").const(_key("ok")).value("B")
         .const(_key("position") + b"\x83" + _key("cell") + _U32).value("I")
         .const(_key("origin") + b"\x93" + _F64).value("d").const(_F64).value("d").const(_F64).value("d")
         .const(_key("orientation") + b"\x94" + _F64).value("d").const(_F64).value("d").const(_F64).value("d")
         .const(_F64).value("d")
         .const(_key("landblock") + _U16).value("H").const(_key("transition_state")))
    return Struct(f.fmt), f.args


_HEAD, _HC = _head(16)
_HEAD_TAGGED, _HC_TAGGED = _head(17)
#: contact, on_walkable and the contact_plane key, for each (contact, on_walkable)
_CONTACT = {(c, w): _key("contact") + (_TRUE if c else _FALSE) + _key("on_walkable") + (_TRUE if w else _FALSE)
            + _key("contact_plane") for c in (False, True) for w in (False, True)}
_PF = (_Fixed().const(b"\x82" + _key("normal") + b"\x93" + _F64).value("d").const(_F64).value("d")
       .const(_F64).value("d").const(_key("d") + _F64).value("d"))
_PLANE, _PC = Struct(_PF.fmt), _PF.args
_K_PLANE_CELL, _K_COLLISION, _K_SLIDING = _key("contact_plane_cell"), _key("collision_normal"), _key("sliding_normal")
_PLANE_CELL = Struct(f">{len(_K_PLANE_CELL) + 1}sI")
_K_WATER, _K_FSF = _key("water_contact"), _key("frames_stationary_fall")
_WATER = {w: _K_WATER + (_TRUE if w else _FALSE) + _K_FSF for w in (False, True)}
_K_TRANSIENT, _K_COLLIDE, _K_TAG = _key("transient_state"), _key("collide_objects"), _key("tag")
_NO_COLLISIONS = _K_COLLIDE + b"\x90"
_VEC3 = Struct(">2sd1sd1sd")
_STRINGS: dict[str, bytes] = {}  # transition state names, packed
_NAME_LISTS: dict[tuple[str, ...], bytes] = {}  # transient state lists, packed with their key


def _str(s: str) -> bytes:
    b = _STRINGS.get(s)
    if b is None:
        b = bytes(msgpack.packb(s))
        if len(_STRINGS) < 64:  # the names are a handful; anything else is packed each time
            _STRINGS[s] = b
    return b


def _names(names: list[str]) -> bytes:
    t = tuple(names)
    b = _NAME_LISTS.get(t)
    if b is None:
        b = _K_TRANSIENT + bytes(msgpack.packb(names))
        if len(_NAME_LISTS) < 256:
            _NAME_LISTS[t] = b
    return b


def _vec_bytes(v: Vec3 | None) -> bytes:
    return _NIL if v is None else _VEC3.pack(b"\x93\xcb", v.x, _F64, v.y, _F64, v.z)


def pack_state(mover_id: int, seq: int, r: MoveResult, collide_ids: list[int], tag: int | str | None = None) -> bytes:
    """`msgpack.packb(encode_state(...))` without building the map: the same map when decoded (floats as
    float64, as the service always sends them; ids, seq, cell and landblock in fixed-width integers, as
    msgpack allows), in a few Struct calls instead of a dict and its packing. One `join` of one tuple
    (no list grown part by part): this runs once per move."""
    pos = r.position
    o, q = pos.frame.origin, pos.frame.orientation
    cell = pos.cell_id
    c = _HC if tag is None else _HC_TAGGED
    cp, cpc, fsf = r.contact_plane, r.contact_plane_cell, r.frames_stationary_fall
    ts = r.transition_state
    names = r.transient_state
    packed = b"".join((
        (_HEAD if tag is None else _HEAD_TAGGED).pack(
            c[0], mover_id, c[1], seq, c[2], 0xC3 if r.ok else 0xC2, c[3], cell, c[4], o.x, c[5], o.y, c[6], o.z,
            c[7], q.w, c[8], q.x, c[9], q.y, c[10], q.z, c[11], (cell >> 16) & 0xFFFF, c[12]),
        _STRINGS.get(ts) or _str(ts),
        _CONTACT[r.contact, r.on_walkable],
        _NIL if cp is None else _PLANE.pack(_PC[0], cp.normal.x, _PC[1], cp.normal.y, _PC[2], cp.normal.z, _PC[3], cp.d),
        _K_PLANE_CELL + _NIL if cpc is None else _PLANE_CELL.pack(_K_PLANE_CELL + _U32, cpc),
        _K_COLLISION,
        _vec_bytes(r.collision_normal),
        _K_SLIDING,
        _vec_bytes(r.sliding_normal),
        _WATER[r.water_contact],
        _NIL if fsf is None else _uint(fsf) if fsf >= 0 else bytes(msgpack.packb(fsf)),
        _NAME_LISTS.get(tuple(names)) or _names(names),
        _K_COLLIDE + bytes(msgpack.packb(collide_ids)) if collide_ids else _NO_COLLISIONS,
    ))
    if tag is None:
        return packed
    return packed + _K_TAG + bytes(msgpack.packb(tag, use_bin_type=True))


def _vec_or_none(v: Any, path: str) -> Vec3 | None:
    return None if v is None else Vec3(*as_vec3(v, path))


def _opt_int(v: Any) -> int | None:
    return None if v is None else int(v)


def _plain_vec(v: Any) -> Vec3 | None:
    t = plain_floats3(v)
    return None if t is None else Vec3(*t)


def _plain_state(m: Any) -> tuple[int, int, int | str | None, MoveResult] | None:
    """`decode_state` for a State as this service writes it, without the per-field readers; None when
    anything is off (then the full reader decides and names the field)."""
    if type(m) is not dict:
        return None
    mover_id, seq, pos = m.get("id"), m.get("seq"), m.get("position")
    if type(mover_id) is not int or type(seq) is not int or type(pos) is not dict or len(pos) != 3:
        return None
    cell, origin, raw_q = pos.get("cell"), plain_floats3(pos.get("origin")), pos.get("orientation")
    if type(cell) is not int or not (0 <= mover_id < 1 << 64 and 0 <= seq < 1 << 64 and 0 <= cell < 1 << 32):
        return None
    q = plain_unit_quat(raw_q)
    if origin is None or q is None:
        return None
    ok, contact, walk, ts = m.get("ok"), m.get("contact"), m.get("on_walkable"), m.get("transition_state")
    if type(ok) is not bool or type(contact) is not bool or type(walk) is not bool or type(ts) is not str:
        return None
    plane: Plane | None = None
    cp = m.get("contact_plane")
    if cp is not None:
        if type(cp) is not dict or len(cp) != 2:
            return None
        n, d = plain_floats3(cp.get("normal")), cp.get("d")
        if n is None or type(d) is not float or not isfinite(d):
            return None
        nx, ny, nz = n
        if abs((nx * nx + ny * ny + nz * nz) ** 0.5 - 1.0) > 1e-3:
            return None
        plane = Plane(Vec3(nx, ny, nz), d)
    cpc = m.get("contact_plane_cell")
    if cpc is not None and (type(cpc) is not int or not 0 <= cpc < 1 << 32):
        return None
    raw_cn, raw_sn = m.get("collision_normal"), m.get("sliding_normal")
    cn, sn = _plain_vec(raw_cn), _plain_vec(raw_sn)
    if (cn is None and raw_cn is not None) or (sn is None and raw_sn is not None):
        return None
    fsf, trans, coll = m.get("frames_stationary_fall"), m.get("transient_state"), m.get("collide_objects")
    if (fsf is not None and type(fsf) is not int) or type(trans) is not list or type(coll) is not list:
        return None
    if not all(type(t) is str for t in trans) or not all(type(i) is int for i in coll):
        return None
    result = MoveResult(
        ok, Position.at(cell, Vec3(*origin), Quat(*q)), ts, contact, walk,
        plane, cpc, cn, sn, bool(m.get("water_contact")), fsf, trans, coll,
    )
    return mover_id, seq, m.get("tag"), result


def decode_state(value: Any, path: str = "state") -> tuple[int, int, int | str | None, MoveResult]:
    """A State map back to (id, seq, tag, MoveResult): the client's side."""
    plain = _plain_state(value)
    return plain if plain is not None else read_state(value, path)


def read_state(value: Any, path: str = "state") -> tuple[int, int, int | str | None, MoveResult]:
    """`decode_state` through the per-field readers: what any sender may write, and errors naming the field."""
    m = as_map(value, path)
    plane_raw = opt_field(m, "contact_plane")
    cpc = opt_field(m, "contact_plane_cell")
    ts = as_str(get_field(m, "transition_state", path), field_path(path, "transition_state"))
    result = MoveResult(
        ok=as_bool(get_field(m, "ok", path), field_path(path, "ok")),
        position=decode_position(get_field(m, "position", path), field_path(path, "position")),
        transition_state=ts,
        contact=as_bool(get_field(m, "contact", path), field_path(path, "contact")),
        on_walkable=as_bool(get_field(m, "on_walkable", path), field_path(path, "on_walkable")),
        contact_plane=None if plane_raw is None else decode_plane(plane_raw, field_path(path, "contact_plane")),
        contact_plane_cell=None if cpc is None else as_uint(cpc, field_path(path, "contact_plane_cell"), 32),
        collision_normal=_vec_or_none(opt_field(m, "collision_normal"), field_path(path, "collision_normal")),
        sliding_normal=_vec_or_none(opt_field(m, "sliding_normal"), field_path(path, "sliding_normal")),
        water_contact=bool(opt_field(m, "water_contact")),
        frames_stationary_fall=_opt_int(opt_field(m, "frames_stationary_fall")),
        transient_state=[str(s) for s in (opt_field(m, "transient_state") or [])],
        collide_objects=[int(i) for i in (opt_field(m, "collide_objects") or [])],
    )
    tag = opt_field(m, "tag")
    return (
        as_uint(get_field(m, "id", path), field_path(path, "id")),
        as_uint(get_field(m, "seq", path), field_path(path, "seq")),
        tag,
        result,
    )
