"""The queries' vocabulary: each query on `P/lb/XXYY/<op>` declared once, in every form it has.

A `QueryKind` holds all the wire knows of one op: the fields of its map form's query (in the order
they are read, which is the order of the item tuple the service runs), its batch field and limit, its
answer (one `Out` per attribute of the engine's result class), and its column form (`QueryColumns`:
request columns, the top-level options a column request shares, reply columns and flag bits). The
readers (service/protocol/readers.py), the writers (writers.py), the service's runner
(service/queries.py), the client library (clients/spatial.py, clients/paths.py) and the test that
reads docs/protocol.md's tables all work from `QUERIES`. A new query kind is one declaration here, its
engine call in service/queries.py, its client method and its section of protocol.md.

No I/O, no zenoh: values in, values out.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Final

from engine.limits import MAX_PATH_DISTANCE, MAX_RAY_RADIUS, MAX_WANDER_RADIUS, MIN_SPHERE_RADIUS
from engine import REASONS, Ground, PathResult, PlacementResult, RayHit, SightResult

from service.protocol.columns import Column, reply_columns
from service.protocol.errors import ProtocolError
from service.protocol.validate import as_uint, field_path
from service.protocol.wire import MAX_BATCH, ErrorKind
from service.protocol import answers as a
from service.protocol.fields import BOOL, ID, MOVER, POSITION, Choice, Count, Field, Kind, Real

__all__ = [
    "QueryKind",
    "QueryColumns",
    "QUERIES",
    "QUERY_OPS",
    "BATCH_FIELDS",
    "QUERY_COLUMNS",
    "QUERY_FORMS",
    "BLOCKER_CODES",
    "PLACEMENT_CODES",
    "REASON_CODES",
    "NO_CODE",
    "PLACEMENT_MODES",
    "MAX_PATH_BATCH",
    "MAX_PATH_BUDGET",
]

#: Health's `query_forms`: the request forms every query op understands.
QUERY_FORMS: Final = ("single", "batch", "columns")
#: a reply's `blocker` code: the index in this tuple (engine.queries.results.BLOCKER_KINDS), 255 for none
BLOCKER_CODES: Final = ("terrain", "cell", "building", "object")
#: a place reply's `placement_result` code: the index in this tuple, 255 for a failed item
PLACEMENT_CODES: Final = ("OK", "NoValidPosition", "NoCell(lost)")
#: a path reply's `reason` code: the index in this tuple, 255 for a path found (or a failed item)
REASON_CODES: Final = REASONS
#: what a code column holds for "none" (and a failed item)
NO_CODE: Final = 255
PLACEMENT_MODES: Final = ("enter_world", "teleport")
#: Most paths in one request: a path is thousands of moves' work, run on the engine thread in turn with
#: everyone's moves, so a request may not hold the thousands a move batch may.
MAX_PATH_BATCH: Final = 64
#: Most graph nodes one path may expand over the bus (the library allows more; its default is 10,000).
MAX_PATH_BUDGET: Final = 100_000


@dataclass(frozen=True, slots=True)
class QueryColumns:
    """One op's column form: its request columns (`count` the one whose length gives N), the top-level
    `options` every item shares, its reply columns (one row per item) and `flags` bits (bit k is
    `flags[k]`; bit 0 is always `resolved`), and `ragged` reply columns whose rows are the items' lists
    one after the other (a path's waypoints), found by the reply's `<list>_start` / `<list>_count`."""

    op: str
    request: tuple[Column, ...]
    reply: tuple[Column, ...]
    flags: tuple[str, ...]
    count: str
    options: tuple[Field, ...] = ()
    ragged: tuple[Column, ...] = ()

    def bit(self, name: str) -> int:
        return 1 << self.flags.index(name)

    def request_column(self, name: str) -> Column:
        return next(c for c in self.request if c.name == name)


#: Cross-field rules of a query, run on its raw map before its fields are read: (map, path) -> None,
#: ProtocolError when the fields given do not go together.
Check = Callable[[dict[str, Any], str], None]


@dataclass(frozen=True, slots=True)
class QueryKind:
    """One query op, every form of it (module docstring)."""

    op: str
    batch: str
    fields: tuple[Field, ...]
    answer: tuple[a.Out, ...]
    result: type
    columns: QueryColumns
    #: the answer may be null (ground: no surface within reach)
    nullable: bool = False
    max_batch: int = MAX_BATCH
    #: a small request may run on the callback thread (the cheap queries); a path always queues
    inline_ok: bool = True
    check: Check | None = None


# -- column builders ---------------------------------------------------------------------------------
def _req(op: str, name: str, dtype: str, width: int, required: bool) -> Column:
    return Column(name, dtype, width, required=(op,) if required else (), optional=() if required else (op,))


def _at(op: str, optional: tuple[Column, ...]) -> tuple[Column, ...]:
    """A point query's columns: its cell and origin, then `optional`."""
    return (_req(op, "cell", "u32", 1, True), _req(op, "origin", "f64", 3, True)) + optional


def _segment(op: str) -> tuple[Column, ...]:
    return (_req(op, "from_cell", "u32", 1, True), _req(op, "from_origin", "f64", 3, True),
            _req(op, "to_cell", "u32", 1, True), _req(op, "to_origin", "f64", 3, True))


def _out(*columns: tuple[str, str, int]) -> tuple[Column, ...]:
    """Reply columns (name, dtype, per item), after the `flags` column every reply starts with; each holds
    its dtype's missing value where there is none (service/columns.MISSING_BY_DTYPE)."""
    return reply_columns(("flags", "u32", 1), *columns)


_BLOCKER = (("blocker", "u8", 1), ("blocker_id", "u64", 1))


# -- the field kinds the queries share ------------------------------------------------------------------
def _radius_why(v: float) -> str:
    return f"must be from {MIN_SPHERE_RADIUS:g} to {MAX_RAY_RADIUS:g} m, got {v}"


_RADIUS = Real(MIN_SPHERE_RADIUS, MAX_RAY_RADIUS, _radius_why)
_NOT_NEGATIVE = Real(0.0, float("inf"), lambda v: "must not be negative")
_PATH_DISTANCE = Real(0.0, MAX_PATH_DISTANCE, lambda v: f"must be above 0 and at most {MAX_PATH_DISTANCE:,.0f} m, got {v}",
                      low_open=True)
_BUDGET = Count(1, MAX_PATH_BUDGET, "graph nodes")


def _segment_fields(radius_required: bool) -> tuple[Field, ...]:
    return (Field("from", POSITION, required=True, start=True), Field("to", POSITION, required=True),
            Field("radius", _RADIUS, required=radius_required), Field("target", ID))


def _walker_rule(start: str) -> Check:
    """A path's (or random point's) walker is exactly one of `mover` and `id`; a `mover` walks from
    `start`, an `id` from where it stands."""
    def check(m: dict[str, Any], path: str) -> None:
        has_mover, has_id, has_start = (m.get(k) is not None for k in ("mover", "id", start))
        if has_mover == has_id:
            kind = ErrorKind.BAD_VALUE if has_mover else ErrorKind.MISSING_FIELD
            raise ProtocolError(kind, f"{path}: give exactly one of mover (a MoverSpec, with {start}) and id (a "
                                "registered mover, which starts where it stands)",
                                field_path(path, "id" if has_mover else "mover"))
        if has_mover and not has_start:
            p = field_path(path, start)
            raise ProtocolError(ErrorKind.MISSING_FIELD, f"{p}: required field is missing (a mover walker's start)", p)
        if has_id and has_start:
            p = field_path(path, start)
            raise ProtocolError(ErrorKind.BAD_VALUE, f"{p}: a registered mover (id) starts where it stands; leave {start} out", p)
    return check


_PATH_OPTIONS = (Field("max_distance", _PATH_DISTANCE), Field("budget", _BUDGET), Field("avoid_movers", BOOL, default=False))
_WANDER_RADIUS = Real(0.0, MAX_WANDER_RADIUS, lambda v: f"must be above 0 and at most {MAX_WANDER_RADIUS:,.0f} m, got {v}",
                      low_open=True)
_SEED = Kind("uint64", as_uint)
#: a path's answer, and a random point's (a path to the point)
_PATH_ANSWER = a.out(("found", a.FLAG), ("waypoints", a.POSITIONS), ("length", a.REAL), ("expanded", a.COUNT),
                     ("reason", a.TEXT), ("detail", a.TEXT))
#: ... in columns: one row per item, the waypoints ragged
_PATH_REPLY = _out(("length", "f64", 1), ("expanded", "u32", 1), ("reason", "u8", 1), ("waypoint_start", "u32", 1),
                   ("waypoint_count", "u32", 1))
_WAYPOINTS = (Column("waypoint_cell", "u32", 1), Column("waypoint_origin", "f64", 3))

# -- the declarations ------------------------------------------------------------------------------------
SIGHT = QueryKind(
    "sight", "sights",
    _segment_fields(False) + (Field("viewer", ID),),
    a.out(("clear", a.FLAG), ("stop", a.POSITION), ("normal", a.VECTOR), ("cell", a.CELL), ("blocker", a.BLOCKER)),
    SightResult,
    QueryColumns(
        "sight",
        _segment("sight") + (_req("sight", "radius", "f64", 1, False), _req("sight", "target", "u64", 1, False),
                             _req("sight", "viewer", "u64", 1, False)),
        _out(("cell", "u32", 1), ("stop", "f64", 3), ("normal", "f64", 3), *_BLOCKER),
        ("resolved", "clear", "stop given", "normal given", "blocker_id given"),
        "from_cell",
    ),
)

RAY = QueryKind(
    "ray", "rays",
    _segment_fields(True),
    a.out(("hit", a.FLAG), ("position", a.POSITION), ("cell", a.COUNT), ("normal", a.VECTOR), ("distance", a.REAL),
          ("blocker", a.BLOCKER)),
    RayHit,
    QueryColumns(
        "ray",
        _segment("ray") + (_req("ray", "radius", "f64", 1, True), _req("ray", "target", "u64", 1, False)),
        _out(("cell", "u32", 1), ("position", "f64", 3), ("normal", "f64", 3), ("distance", "f64", 1), *_BLOCKER),
        ("resolved", "hit", "normal given", "blocker_id given"),
        "from_cell",
    ),
)

GROUND = QueryKind(
    "ground", "grounds",
    (Field("position", POSITION, required=True, start=True), Field("max_drop", _NOT_NEGATIVE)),
    a.out(("z", a.REAL), ("plane", a.PLANE), ("cell", a.COUNT), ("walkable", a.FLAG), ("water_depth", a.REAL)),
    Ground,
    QueryColumns(
        "ground",
        _at("ground", (_req("ground", "max_drop", "f64", 1, False),)),
        _out(("z", "f64", 1), ("plane", "f64", 4), ("cell", "u32", 1), ("water_depth", "f64", 1)),
        ("resolved", "found", "walkable"),
        "cell",
    ),
    nullable=True,
)

_PLACE_SHAPE = (Field("mover", MOVER, required=True),)
_PLACE_MODE = (Field("mode", Choice(PLACEMENT_MODES), default="enter_world"), Field("slide", BOOL, default=True))

PLACE = QueryKind(
    "place", "places",
    _PLACE_SHAPE + (Field("position", POSITION, required=True, start=True),) + _PLACE_MODE,
    a.out(("ok", a.FLAG), ("placement_result", a.TEXT), ("position", a.POSITION), ("contact", a.FLAG),
          ("on_walkable", a.FLAG), ("contact_plane", a.PLANE), ("contact_plane_cell", a.CELL), ("water_contact", a.FLAG)),
    PlacementResult,
    QueryColumns(
        "place",
        _at("place", (_req("place", "orientation", "f64", 4, False),)),
        _out(("placement_result", "u8", 1), ("cell", "u32", 1), ("origin", "f64", 3), ("orientation", "f64", 4),
             ("contact_plane", "f64", 4), ("contact_plane_cell", "u32", 1)),
        ("resolved", "ok", "contact", "on_walkable", "water_contact", "contact_plane given",
         "contact_plane_cell given"),
        "cell",
        options=_PLACE_SHAPE + _PLACE_MODE,
    ),
)

PATH = QueryKind(
    "path", "paths",
    (Field("mover", MOVER), Field("id", ID), Field("from", POSITION, start=True), Field("to", POSITION, required=True))
    + _PATH_OPTIONS,
    _PATH_ANSWER,
    PathResult,
    QueryColumns(
        "path", _segment("path"), _PATH_REPLY, ("resolved", "found"), "from_cell",
        options=(Field("mover", MOVER, required=True),) + _PATH_OPTIONS, ragged=_WAYPOINTS,
    ),
    max_batch=MAX_PATH_BATCH,
    inline_ok=False,
    check=_walker_rule("from"),
)

RANDOM_POINT = QueryKind(
    "random_point", "random_points",
    (Field("mover", MOVER), Field("id", ID), Field("near", POSITION, start=True),
     Field("radius", _WANDER_RADIUS, required=True), Field("seed", _SEED), Field("budget", _BUDGET),
     Field("avoid_movers", BOOL, default=False)),
    _PATH_ANSWER,
    PathResult,
    QueryColumns(
        "random_point",
        (_req("random_point", "near_cell", "u32", 1, True), _req("random_point", "near_origin", "f64", 3, True),
         _req("random_point", "radius", "f64", 1, True), _req("random_point", "seed", "u64", 1, False)),
        _PATH_REPLY, ("resolved", "found"), "near_cell",
        options=(Field("mover", MOVER, required=True), Field("budget", _BUDGET), Field("avoid_movers", BOOL, default=False)),
        ragged=_WAYPOINTS,
    ),
    max_batch=MAX_PATH_BATCH,
    inline_ok=False,
    check=_walker_rule("near"),
)

QUERIES: Final[dict[str, QueryKind]] = {k.op: k for k in (SIGHT, RAY, GROUND, PLACE, PATH, RANDOM_POINT)}
QUERY_OPS: Final = tuple(QUERIES)
#: the query ops and the field of their batch form
BATCH_FIELDS: Final = {k.op: k.batch for k in QUERIES.values()}
QUERY_COLUMNS: Final = {k.op: k.columns for k in QUERIES.values()}
