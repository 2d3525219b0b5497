"""Spatial queries on the bus: `<prefix>/lb/<XXYY>/{sight,ray,ground,place}`.

Each op has a single form (`{"sight": {...}}`) and a batch form (`{"sights": [...]}`); docs/protocol.md,
"Spatial queries". Requests are decoded here with the readers moves use (codec, validate) on the callback
thread; the closure `query_work` returns runs with the engine lock held and only reads the world
(engine.World.sight/ray/ground/place and their batched forms): nothing a query does changes any mover.

The position a query starts from (sight's and ray's `from`, ground's and place's `position`) must lie in
the key's landblock, as a move's mover must: in a deployment of several instances the key routes the
query to the instance owning that landblock. The sweeps themselves cross landblock borders as far as the
instance has land loaded (`landblock_not_loaded` past that).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from engine.geometry import Plane, Position, Quat, Vec3
from engine.queries.results import Blocker, Ground, PlacementResult, RayHit, SightResult
from engine.limits import MAX_RAY_RADIUS, MIN_SPHERE_RADIUS

from .codec import decode_mover_spec, decode_plane, decode_position, encode_plane, encode_position, encode_vec
from .engine_errors import to_protocol_error
from .errors import ProtocolError
from .query_columns import (
    QUERY_COLUMNS,
    QueryColumnRequest,
    is_query_columns,
    parse_query_columns,
    query_column_count,
    run_query_columns,
)
from .validate import as_bool, as_float, as_list, as_map, as_str, as_uint, field_path, get_field, opt_field
from .wire import MAX_BATCH, PROTOCOL_VERSION, ErrorKind

__all__ = [
    "QUERY_OPS",
    "BATCH_FIELDS",
    "query_work",
    "query_count",
    "encode_answer",
    "decode_ground",
    "decode_ray_hit",
    "decode_sight",
    "decode_placement",
]

#: the query ops and the field of their batch form
BATCH_FIELDS = {"sight": "sights", "ray": "rays", "ground": "grounds", "place": "places"}
QUERY_OPS = tuple(BATCH_FIELDS)
_PLACEMENT_MODES = ("enter_world", "teleport")

Item = tuple[Any, ...]
IdMap = Callable[[int, str], int]  # (wire mover id, its request path) -> engine id (raises ProtocolError)
Encode = Callable[[Any], Any]


# -- request decoding ------------------------------------------------------------------
def _radius(m: dict[str, Any], path: str, required: bool) -> float | None:
    raw = get_field(m, "radius", path) if required else opt_field(m, "radius")
    if raw is None:
        return None
    p = field_path(path, "radius")
    r = as_float(raw, p)
    if not MIN_SPHERE_RADIUS <= r <= MAX_RAY_RADIUS:
        raise ProtocolError(ErrorKind.BAD_VALUE, f"{p}: must be from {MIN_SPHERE_RADIUS:g} to {MAX_RAY_RADIUS:g} m, "
                            f"got {r}", p)
    return r


def _opt_id(m: dict[str, Any], key: str, path: str) -> int | None:
    raw = opt_field(m, key)
    return None if raw is None else as_uint(raw, field_path(path, key))


def _in_landblock(pos: Position, lb: int, path: str) -> None:
    if (pos.cell_id >> 16) & 0xFFFF != lb:
        raise ProtocolError(
            ErrorKind.WRONG_LANDBLOCK,
            f"{path}: cell {pos.cell_id:08X} is not in landblock {lb:04X} (the key's); send it to that landblock's key",
            path,
            landblock=(pos.cell_id >> 16) & 0xFFFF,
        )


def _decode_item(op: str, value: Any, path: str, lb: int) -> Item:
    m = as_map(value, path)
    if op == "ground":
        pos = decode_position(get_field(m, "position", path), field_path(path, "position"))
        _in_landblock(pos, lb, field_path(path, "position"))
        raw_drop = opt_field(m, "max_drop")
        drop = None if raw_drop is None else as_float(raw_drop, field_path(path, "max_drop"))
        if drop is not None and drop < 0.0:
            raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}.max_drop: must not be negative", field_path(path, "max_drop"))
        return (pos, drop)
    if op == "place":
        spec = decode_mover_spec(get_field(m, "mover", path), field_path(path, "mover"))
        pos = decode_position(get_field(m, "position", path), field_path(path, "position"))
        _in_landblock(pos, lb, field_path(path, "position"))
        raw_mode = opt_field(m, "mode")
        mode = "enter_world" if raw_mode is None else as_str(raw_mode, field_path(path, "mode"))
        if mode not in _PLACEMENT_MODES:
            p = field_path(path, "mode")
            raise ProtocolError(ErrorKind.BAD_VALUE, f"{p}: must be one of {', '.join(_PLACEMENT_MODES)}, got {mode!r}", p)
        raw_slide = opt_field(m, "slide")
        slide = True if raw_slide is None else as_bool(raw_slide, field_path(path, "slide"))
        return (spec, pos, mode, slide)
    start = decode_position(get_field(m, "from", path), field_path(path, "from"))
    _in_landblock(start, lb, field_path(path, "from"))
    end = decode_position(get_field(m, "to", path), field_path(path, "to"))
    if op == "ray":
        return (start, end, _radius(m, path, True), _opt_id(m, "target", path))
    return (start, end, _radius(m, path, False), _opt_id(m, "target", path), _opt_id(m, "viewer", path))


def query_count(msg: dict[str, Any], op: str) -> int:
    """How many queries a request holds (1 for the single form)."""
    if is_query_columns(msg):
        return query_column_count(msg, op)
    batch = msg.get(BATCH_FIELDS[op])
    return len(batch) if isinstance(batch, list) else 1


def _parse(op: str, msg: dict[str, Any], lb: int | None) -> tuple[bool, list[Item]]:
    """(single, items), or ProtocolError naming the offending field."""
    if lb is None:
        raise ProtocolError(ErrorKind.BAD_VALUE, f"a {op} query needs a literal landblock in its key, not a wildcard")
    many = BATCH_FIELDS[op]
    has_one, has_many = msg.get(op) is not None, msg.get(many) is not None  # nil is as good as absent
    if has_one == has_many:
        raise ProtocolError(
            ErrorKind.MISSING_FIELD if not has_one else ErrorKind.BAD_VALUE,
            f"a {op} request holds exactly one of {op!r} (one query) and {many!r} (a batch)",
            op,
        )
    if has_one:
        return True, [_decode_item(op, msg[op], op, lb)]
    raw = as_list(msg[many], many, MAX_BATCH)
    return False, [_decode_item(op, v, field_path(many, i), lb) for i, v in enumerate(raw)]


# -- running ---------------------------------------------------------------------------
def _engine_id(ids: IdMap, wire_id: int | None, path: str) -> int:
    return 0 if wire_id is None else ids(wire_id, path)


def _run_one(op: str, world: Any, item: Item, ids: IdMap, target_path: str, viewer_path: str = "") -> Any:
    """One query; `target_path` and `viewer_path` name its ids in the request (`sights[3].target`,
    `columns.target[3]`), for their errors."""
    if op == "ground":
        return world.ground(item[0], item[1])
    if op == "place":
        return world.place(item[0], item[1], item[2], item[3])
    if op == "ray":
        return world.ray(item[0], item[1], item[2], target_id=_engine_id(ids, item[3], target_path))
    return world.sight(item[0], item[1], item[2], target_id=_engine_id(ids, item[3], target_path),
                       viewer_id=_engine_id(ids, item[4], viewer_path))


def _run_path(op: str, world: Any, item: Item, ids: IdMap, path: str) -> Any:
    """One query of the single or batch form; `path` names it (`sight`, `sights[3]`)."""
    return _run_one(op, world, item, ids, f"{path}.target", f"{path}.viewer")


def _fields(op: str, path: str) -> dict[str, str]:
    """Engine argument names -> request paths, for errors that name their field."""
    if op in ("ground", "place"):
        return {"position": f"{path}.position", "spec": f"{path}.mover"}
    return {"a": f"{path}.from", "b": f"{path}.to", "start": f"{path}.from", "end": f"{path}.to"}


def query_work(op: str, lb: int | None, msg: dict[str, Any], world: Any, ids: IdMap,
               blocker_id: Callable[[int], int]) -> Callable[[], dict[str, Any]]:
    """Decode a query request now (ProtocolError on bad input); the closure runs it on the engine and
    returns the reply map. A batch answers per item: an item the engine refuses (an unknown cell, an
    unloaded landblock) gets `{"error": Error}` in its place and the others their answers. A column
    request (service/query_columns.py) is answered in columns, item by item as the map form would."""
    if is_query_columns(msg):
        return _column_work(op, lb, msg, world, ids, blocker_id)
    single, items = _parse(op, msg, lb)
    encode = _encoder(op, blocker_id)
    many = BATCH_FIELDS[op]

    def run() -> dict[str, Any]:
        if single:
            try:
                answer = _run_path(op, world, items[0], ids, op)
            except ProtocolError:
                raise
            except Exception as e:
                raise to_protocol_error(e, op, fields=_fields(op, op)) from None
            return {"v": PROTOCOL_VERSION, op: encode(answer)}
        out: list[Any] = []
        for i, item in enumerate(items):
            path = field_path(many, i)
            try:
                out.append(encode(_run_path(op, world, item, ids, path)))
            except ProtocolError as e:
                out.append({"error": e.to_wire()})
            except Exception as e:
                out.append({"error": to_protocol_error(e, path, fields=_fields(op, path)).to_wire()})
        return {"v": PROTOCOL_VERSION, many: out}

    return run


# -- the column form (service/query_columns.py) -----------------------------------------
def _place_options(msg: dict[str, Any]) -> dict[str, Any]:
    """A column place's top-level fields: one `mover` shape, `mode` and `slide` for every item."""
    spec = decode_mover_spec(get_field(msg, "mover", ""), "mover")
    raw_mode = opt_field(msg, "mode")
    mode = "enter_world" if raw_mode is None else as_str(raw_mode, "mode")
    if mode not in _PLACEMENT_MODES:
        raise ProtocolError(ErrorKind.BAD_VALUE, f"mode: must be one of {', '.join(_PLACEMENT_MODES)}, got {mode!r}", "mode")
    raw_slide = opt_field(msg, "slide")
    return {"mover": spec, "mode": mode, "slide": True if raw_slide is None else as_bool(raw_slide, "slide")}


def _column_item(req: QueryColumnRequest, i: int) -> Item:
    """Item i of a column request as the map form decodes the same values (Python floats, the
    identity orientation where none is given, None where a default applies)."""
    a = req.arrays

    def position(cell: str, origin: str, orientation: str | None = None) -> Position:
        x, y, z = a[origin][i].tolist()
        q = a[orientation][i].tolist() if orientation is not None and orientation in a else [0.0] * 4
        return Position.at(int(a[cell][i]), Vec3(x, y, z), Quat(*q) if any(q) else Quat())

    def opt(name: str, zero_is_none: bool = True) -> Any:
        col = a.get(name)
        if col is None:
            return None
        v = col[i].item()
        return None if zero_is_none and v == 0 else v

    if req.op == "ground":
        return (position("cell", "origin"), opt("max_drop"))
    if req.op == "place":
        o = req.options
        return (o["mover"], position("cell", "origin", "orientation"), o["mode"], o["slide"])
    start, end = position("from_cell", "from_origin"), position("to_cell", "to_origin")
    if req.op == "ray":
        return (start, end, opt("radius", False), opt("target"))
    return (start, end, opt("radius"), opt("target"), opt("viewer"))


_COLUMN_FIELDS = {"ground": {"position": "cell"}, "place": {"position": "cell", "spec": "cell"},
                  "ray": {"start": "from_cell", "end": "to_cell"}, "sight": {"a": "from_cell", "b": "to_cell"}}


def _column_error(op: str, e: Exception, i: int) -> ProtocolError:
    """An engine error of item i, its path the item's cell column of the position it concerns."""
    named = getattr(e, "field", None)
    top = named.split(".")[0].split("[")[0] if isinstance(named, str) else ""
    column = _COLUMN_FIELDS[op].get(top, QUERY_COLUMNS[op].count)
    return to_protocol_error(e, f"columns.{column}[{i}]")


def _column_work(op: str, lb: int | None, msg: dict[str, Any], world: Any, ids: IdMap,
                 blocker_id: Callable[[int], int]) -> Callable[[], dict[str, Any]]:
    if lb is None:
        raise ProtocolError(ErrorKind.BAD_VALUE, f"a {op} query needs a literal landblock in its key, not a wildcard")
    req = parse_query_columns(op, msg, lb, _place_options if op == "place" else None)

    def run() -> dict[str, Any]:
        return run_query_columns(
            req, lambda i: _column_item(req, i),
            lambda i, item: _run_one(op, world, item, ids, f"columns.target[{i}]", f"columns.viewer[{i}]"),
            lambda e, i: _column_error(op, e, i), blocker_id)

    return run


# -- answers: encoding (service) and decoding (clients) ---------------------------------
def _encode_blocker(b: Blocker | None, blocker_id: Callable[[int], int]) -> dict[str, Any] | None:
    if b is None:
        return None
    return {"kind": b.kind, "object_id": None if b.object_id is None else blocker_id(b.object_id)}


def _encoder(op: str, blocker_id: Callable[[int], int]) -> Encode:
    def ground(g: Ground | None) -> dict[str, Any] | None:
        if g is None:
            return None
        return {"z": g.z, "plane": encode_plane(g.plane), "cell": g.cell, "walkable": g.walkable, "water_depth": g.water_depth}

    def ray(r: RayHit) -> dict[str, Any]:
        return {"hit": r.hit, "position": encode_position(r.position), "cell": r.cell, "normal": encode_vec(r.normal),
                "distance": r.distance, "blocker": _encode_blocker(r.blocker, blocker_id)}

    def sight(s: SightResult) -> dict[str, Any]:
        return {"clear": s.clear, "stop": None if s.stop is None else encode_position(s.stop), "normal": encode_vec(s.normal),
                "cell": s.cell, "blocker": _encode_blocker(s.blocker, blocker_id)}

    def place(p: PlacementResult) -> dict[str, Any]:
        return {"ok": p.ok, "placement_result": p.placement_result,
                "position": None if p.position is None else encode_position(p.position), "contact": p.contact,
                "on_walkable": p.on_walkable, "contact_plane": encode_plane(p.contact_plane),
                "contact_plane_cell": p.contact_plane_cell, "water_contact": p.water_contact}

    encoders: dict[str, Encode] = {"ground": ground, "ray": ray, "sight": sight, "place": place}
    return encoders[op]


def encode_answer(op: str, answer: Any) -> Any:
    """An answer of `op` in its wire form (docs/protocol.md), object ids as the answer holds them."""
    return _encoder(op, lambda i: i)(answer)


def _vec(v: Any) -> Vec3 | None:
    return None if v is None else Vec3(float(v[0]), float(v[1]), float(v[2]))


def _pos(v: Any, path: str) -> Position | None:
    return None if v is None else decode_position(v, path, default_orientation=Quat())


def _blocker(v: Any) -> Blocker | None:
    return None if v is None else Blocker(str(v["kind"]), None if v.get("object_id") is None else int(v["object_id"]))


def decode_ground(v: Any) -> Ground | None:
    """A Ground answer (or null) as the engine's Ground (or None)."""
    if v is None:
        return None
    plane: Plane = decode_plane(v["plane"], "ground.plane")
    return Ground(float(v["z"]), plane, int(v["cell"]), bool(v["walkable"]), float(v["water_depth"]))


def decode_ray_hit(v: Any) -> RayHit:
    pos = _pos(v["position"], "ray.position")
    assert pos is not None
    return RayHit(bool(v["hit"]), pos, int(v["cell"]), _vec(v.get("normal")), float(v["distance"]), _blocker(v.get("blocker")))


def decode_sight(v: Any) -> SightResult:
    cell = v.get("cell")
    return SightResult(bool(v["clear"]), _pos(v.get("stop"), "sight.stop"), _vec(v.get("normal")),
                       None if cell is None else int(cell), _blocker(v.get("blocker")))


def decode_placement(v: Any) -> PlacementResult:
    plane = v.get("contact_plane")
    cell = v.get("contact_plane_cell")
    return PlacementResult(
        bool(v["ok"]), str(v["placement_result"]), _pos(v.get("position"), "place.position"), bool(v.get("contact", False)),
        bool(v.get("on_walkable", False)), None if plane is None else decode_plane(plane, "place.contact_plane"),
        None if cell is None else int(cell), bool(v.get("water_contact", False)),
    )
