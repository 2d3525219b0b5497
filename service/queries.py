"""The queries on the bus, run: `<prefix>/lb/<XXYY>/{sight,ray,ground,place,path,random_point}`.

What each query's request and answer hold is declared in service/protocol/ (docs/protocol.md, "Spatial
queries" and "Paths"); this module only runs them. A request is read on the callback thread (the
protocol's readers); the closure `query_work` returns runs with the engine lock held and only reads the
world (engine.World.sight/ray/ground/place/path): nothing a query does changes any mover. A path's
registered walker probes the way itself and is put back exactly as it was.

The position a query starts from (sight's, ray's and path's `from`, ground's and place's `position`, a
registered walker's own position) must lie in the key's landblock, as a move's mover must: in a
deployment of several instances the key routes the query to the instance owning that landblock. The
sweeps cross landblock borders as far as the instance has land loaded (`landblock_not_loaded` past that;
a path answers `not_loaded` instead).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from engine.geometry import Position, Quat, Vec3

from service.engine_errors import to_protocol_error
from service.protocol.errors import ProtocolError
from service.protocol import BATCH_FIELDS, QUERIES, QUERY_COLUMNS, Item, count_items, read_request, write_answer
from service.protocol.fields import in_landblock
from service.protocol.query_columns import (
    QueryColumnRequest,
    is_query_columns,
    parse_query_columns,
    query_column_count,
    run_query_columns,
)
from service.protocol.validate import field_path
from service.protocol.wire import PROTOCOL_VERSION, ErrorKind

__all__ = ["query_work", "query_count", "DEFAULT_PATH_WORK"]

#: the graph building (placements and walks, about 20 us each on the compiled engine) one path query may do
#: before it answers `building`, keeping what it built: about 0.2 s of the engine thread, which everyone's
#: moves wait behind (`acphys serve --path-work`)
DEFAULT_PATH_WORK = 10_000

IdMap = Callable[[int, str], int]  # (wire mover id, its request path) -> engine id (raises ProtocolError)


def query_count(msg: dict[str, Any], op: str) -> int:
    """How many queries a request holds (1 for the single form)."""
    if is_query_columns(msg):
        return query_column_count(msg, op)
    return count_items(op, msg)


# -- running: one engine call per op --------------------------------------------------------------------
def _id(ids: IdMap, wire_id: int | None, path: str) -> int:
    return 0 if wire_id is None else ids(wire_id, path)


def _sight(world: Any, item: Item, ids: IdMap, at: Callable[[str], str], lb: int) -> Any:
    start, end, radius, target, viewer = item
    return world.sight(start, end, radius, target_id=_id(ids, target, at("target")), viewer_id=_id(ids, viewer, at("viewer")))


def _ray(world: Any, item: Item, ids: IdMap, at: Callable[[str], str], lb: int) -> Any:
    start, end, radius, target = item
    return world.ray(start, end, radius, target_id=_id(ids, target, at("target")))


def _ground(world: Any, item: Item, ids: IdMap, at: Callable[[str], str], lb: int) -> Any:
    return world.ground(*item)


def _place(world: Any, item: Item, ids: IdMap, at: Callable[[str], str], lb: int) -> Any:
    return world.place(*item)


def _path(world: Any, item: Item, ids: IdMap, at: Callable[[str], str], lb: int, work: int | None = None) -> Any:
    spec, wire_id, start, goal, max_distance, budget, avoid_movers = item
    walker = spec
    if spec is None:  # a registered walker starts where it stands, which must be in the key's landblock
        walker = ids(wire_id, at("id"))
        in_landblock(world.mover(walker).position, lb, at("id"))
    return world.path(walker, start, goal, max_distance=max_distance, budget=budget, avoid_movers=avoid_movers, work=work)


def _random_point(world: Any, item: Item, ids: IdMap, at: Callable[[str], str], lb: int, work: int | None = None) -> Any:
    spec, wire_id, near, radius, seed, budget, avoid_movers = item
    walker = spec
    if spec is None:  # a registered walker wanders from where it stands, which must be in the key's landblock
        walker = ids(wire_id, at("id"))
        in_landblock(world.mover(walker).position, lb, at("id"))
    return world.random_point(walker, near, radius, seed=seed, budget=budget, avoid_movers=avoid_movers, work=work)


_RUN: dict[str, Callable[[Any, Item, IdMap, Callable[[str], str], int], Any]] = {
    "sight": _sight, "ray": _ray, "ground": _ground, "place": _place, "path": _path, "random_point": _random_point}
assert set(_RUN) == set(QUERIES), "every declared query is run here"

#: the engine's argument names -> the request's field names, for errors that name their field
_ENGINE_FIELDS = {
    "sight": {"a": "from", "b": "to", "start": "from", "end": "to"},
    "ray": {"a": "from", "b": "to", "start": "from", "end": "to"},
    "ground": {"position": "position", "spec": "mover"},
    "place": {"position": "position", "spec": "mover"},
    "path": {"start": "from", "goal": "to"},
    "random_point": {"near": "near", "radius": "radius"},
}
#: ... and in the column form, the column that names an item's value (the count column for the others)
_ENGINE_COLUMNS = {
    "sight": {"a": "from_cell", "b": "to_cell"}, "ray": {"start": "from_cell", "end": "to_cell"},
    "ground": {"position": "cell"}, "place": {"position": "cell", "spec": "cell"},
    "path": {"start": "from_cell", "goal": "to_cell"},
    "random_point": {"near": "near_cell", "radius": "radius"},
}


def _map_error(op: str, e: Exception, path: str) -> ProtocolError:
    """An engine error of the query at `path` (`sight`, `sights[3]`), its path the field it names."""
    return to_protocol_error(e, path, fields={name: field_path(path, wire) for name, wire in _ENGINE_FIELDS[op].items()})


def _column_error(op: str, e: Exception, i: int) -> ProtocolError:
    """An engine error of item i, its path the item's cell column of the position it concerns."""
    named = getattr(e, "field", None)
    top = named.split(".")[0].split("[")[0] if isinstance(named, str) else ""
    column = _ENGINE_COLUMNS[op].get(top, QUERY_COLUMNS[op].count)
    return to_protocol_error(e, f"columns.{column}[{i}]")


def _runner(op: str, path_work: int | None) -> Callable[[Any, Item, IdMap, Callable[[str], str], int], Any]:
    if op == "path":
        return lambda world, item, ids, at, lb: _path(world, item, ids, at, lb, path_work)
    if op == "random_point":
        return lambda world, item, ids, at, lb: _random_point(world, item, ids, at, lb, path_work)
    return _RUN[op]


def query_work(op: str, lb: int | None, msg: dict[str, Any], world: Any, ids: IdMap,
               blocker_id: Callable[[int], int], *, path_work: int | None = None) -> Callable[[], dict[str, Any]]:
    """Read a query request now (ProtocolError on bad input); the closure runs it on the engine and
    returns the reply map. A batch answers per item: an item the engine refuses (an unknown cell, an
    unloaded landblock) gets `{"error": Error}` in its place and the others their answers. A column
    request (service/protocol/query_columns.py) is answered in columns, item by item as the map form would.
    `path_work` bounds each path's graph building (World.path's `work`)."""
    if is_query_columns(msg):
        return _column_work(op, lb, msg, world, ids, blocker_id, path_work)
    single, items = read_request(op, msg, lb)
    assert lb is not None  # read_request refuses a wildcard
    key_lb, run_op = lb, _runner(op, path_work)

    def answer(item: Item, path: str) -> Any:
        try:
            result = run_op(world, item, ids, lambda name: field_path(path, name), key_lb)
        except ProtocolError:
            raise
        except Exception as e:
            raise _map_error(op, e, path) from None
        return write_answer(op, result, blocker_id)

    def run() -> dict[str, Any]:
        if single:
            return {"v": PROTOCOL_VERSION, op: answer(items[0], op)}
        many = BATCH_FIELDS[op]
        out: list[Any] = []
        for i, item in enumerate(items):
            try:
                out.append(answer(item, field_path(many, i)))
            except ProtocolError as e:
                out.append({"error": e.to_wire()})
        return {"v": PROTOCOL_VERSION, many: out}

    return run


# -- the column form (service/protocol/query_columns.py) -----------------------------------------
def _column_item(req: QueryColumnRequest, i: int) -> Item:
    """Item i of a column request as the map form reads the same values (Python floats, the identity
    orientation where none is given, None where a default applies)."""
    a, o = req.arrays, req.options

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
        return (o["mover"], position("cell", "origin", "orientation"), o["mode"], o["slide"])
    if req.op == "random_point":
        return (o["mover"], None, position("near_cell", "near_origin"), opt("radius", False), opt("seed", False),
                o["budget"], o["avoid_movers"])
    start, end = position("from_cell", "from_origin"), position("to_cell", "to_origin")
    if req.op == "path":
        return (o["mover"], None, start, end, o["max_distance"], o["budget"], o["avoid_movers"])
    if req.op == "ray":
        return (start, end, opt("radius", False), opt("target"))
    return (start, end, opt("radius"), opt("target"), opt("viewer"))


def _column_work(op: str, lb: int | None, msg: dict[str, Any], world: Any, ids: IdMap,
                 blocker_id: Callable[[int], int], path_work: int | None) -> Callable[[], dict[str, Any]]:
    if lb is None:
        raise ProtocolError(ErrorKind.BAD_VALUE, f"a {op} query needs a literal landblock in its key, not a wildcard")
    req = parse_query_columns(op, msg, lb)
    key_lb, run_op = lb, _runner(op, path_work)

    def run() -> dict[str, Any]:
        return run_query_columns(
            req, lambda i: _column_item(req, i),
            lambda i, item: run_op(world, item, ids, lambda name: f"columns.{name}[{i}]", key_lb),
            lambda e, i: _column_error(op, e, i), blocker_id)

    return run
