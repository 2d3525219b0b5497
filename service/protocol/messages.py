"""Every map-form message of protocol 1, declared once (docs/protocol.md's tables, as code).

Each declaration (service/protocol/schema.py) is what the service reads a request with (the full reader and
the fast reader generated from it; a move, MOVE, with the msgspec Structs of service/protocol/move_structs.py
that follow it), what it writes a reply or a State with, what the client library
writes its requests and reads the States with, and what tests/service/protocol/test_service_schema.py checks the
protocol document's tables against. The column form's declaration is service/protocol/columns.py.

Only the engine's value types and limits are used (no World), so the client library shares this module.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from engine import limits
from engine.constants import HUGE_QUANTUM
from engine.errors import EngineError
from engine.geometry import IDENTITY, Plane, Position, Quat, Vec3
from engine import CylSphereSpec, MoverSpec, MoveResult, ObjectState, SphereSpec

from service.protocol.errors import ProtocolError
from service.protocol.schema import Field, Map, Rule
from service.protocol.schema_kinds import (
    NON_NEGATIVE,
    POSITIVE,
    Bool,
    Enum,
    Int,
    ListOf,
    Number,
    Quaternion,
    Range,
    Str,
    Tag,
    UInt,
    Value,
    Vector,
)
from service.protocol.wire import MAX_BATCH, ErrorKind

__all__ = [
    "MAX_SPHERES", "PUBLISH_MODES", "Target", "MoveItem", "RegisterRequest", "HandoverRequest",
    "POSITION", "TARGET", "PLANE", "SPHERE", "CYL_SPHERE", "MOVER_SPEC", "STATE", "MOVE", "MOVE_REQUEST",
    "REGISTER", "HANDOVER", "UPDATE", "ID_REQUEST", "ERROR", "HEALTH", "STATS", "LANDBLOCK_LIST",
]

MAX_SPHERES = 32
#: a move request's `publish` values (the map form)
PUBLISH_MODES = ("each", "batch")


def engine_check(check: Callable[[Any, str], Any]) -> Callable[[Any, str], None]:
    """An engine.limits check as a field check: its refusal as the field's error."""

    def checked(value: Any, path: str) -> None:
        try:
            check(value, path)
        except EngineError as e:
            kind = ErrorKind.NON_FINITE if type(e).__name__ == "NonFiniteError" else ErrorKind.BAD_VALUE
            raise ProtocolError(kind, str(e), e.field or path) from None

    return checked


# -- common values ------------------------------------------------------------------------------------
VECTOR = Vector(Vec3)
QUAT = Quaternion(Quat)


POSITION = Map("Position", (
    Field("cell", UInt(32), required=True, src="{}.cell_id"),
    Field("origin", VECTOR, required=True, src="{}.frame.origin", doc="[x, y, z]"),
    Field("orientation", QUAT, default=IDENTITY, src="{}.frame.orientation"),
), Position.at)


@dataclass(slots=True)
class Target:
    """A move's `to`: cell and orientation default to the mover's current ones."""

    cell: int | None
    origin: Vec3
    orientation: Quat | None

    def resolve(self, current: Position) -> Position:
        cell = current.cell_id if self.cell is None else self.cell
        q = current.frame.orientation if self.orientation is None else self.orientation
        return Position.at(cell, self.origin, q)


#: a move's `to`: a Position whose cell and orientation may be left out (written from a Position)
TARGET = Map("Target", (
    Field("cell", UInt(32), src="{}.cell_id"),
    Field("origin", VECTOR, required=True, src="{}.frame.origin"),
    Field("orientation", QUAT, src="{}.frame.orientation"),
), Target)


def _unit_normal(p: Plane) -> bool:
    n = p.normal
    return abs(math.sqrt(n.x * n.x + n.y * n.y + n.z * n.z) - 1.0) <= 1e-3


PLANE = Map("Plane", (
    Field("normal", VECTOR, required=True),
    Field("d", Number(), required=True),
), Plane, rules=(
    Rule(_unit_normal, lambda _p, path: ProtocolError(ErrorKind.BAD_VALUE, f"{path}.normal: not a unit vector",
                                                      f"{path}.normal" if path else "normal")),
))

SPHERE = Map("Sphere", (
    Field("center", Vector(), required=True),
    Field("radius", Number(POSITIVE, "number > 0"), required=True),
), SphereSpec)

CYL_SPHERE = Map("CylSphere", (
    Field("origin", Vector(), required=True),
    Field("radius", Number(POSITIVE, "number > 0"), required=True),
    Field("height", Number(NON_NEGATIVE, "number ≥ 0"), required=True),
), CylSphereSpec)


def _mover_spec(spheres: list[SphereSpec], step_up: float, step_down_height: float, state: list[str],
                step_down: bool, ethereal: bool, scale: float, gravity: bool, creature: bool | None, sledding: bool,
                cyls: list[CylSphereSpec]) -> MoverSpec:
    return MoverSpec(spheres=spheres, step_up_height=step_up, step_down_height=step_down_height, state=state,
                     step_down=step_down, ethereal=ethereal, scale=scale, gravity=gravity, creature=creature,
                     cyl_spheres=cyls, sledding=sledding)


def _spec_limits(spec: MoverSpec, path: str) -> None:
    """Sizes within the engine's limits (docs/protocol.md, "Limits on values")."""
    try:
        limits.check_mover_spec(spec, path)
    except EngineError as e:
        raise ProtocolError(ErrorKind.BAD_VALUE, str(e), e.field or path) from None


MOVER_SPEC = Map("MoverSpec", (
    Field("spheres", ListOf(SPHERE, MAX_SPHERES, 1, "at least one sphere is needed"), required=True,
          doc="array of `{\"center\": Vector, \"radius\": number > 0}`"),
    Field("step_up_height", Number(NON_NEGATIVE, "number ≥ 0"), default=0.4),
    Field("step_down_height", Number(NON_NEGATIVE, "number ≥ 0"), default=0.4),
    Field("state", ListOf(Enum(tuple(ObjectState.BY_NAME), "ObjectInfoState flag"), 32, doc="array of strings"),
          default=[]),
    Field("step_down", Bool(), default=True),
    Field("ethereal", Bool(), default=False),
    Field("scale", Number(POSITIVE, "number > 0"), default=1.0),
    Field("gravity", Bool(), default=True),
    Field("creature", Bool(), nullable=True, doc="bool or nil"),
    Field("sledding", Bool(), default=False),
    Field("cyl_spheres", ListOf(CYL_SPHERE, MAX_SPHERES), default=[], src="{}.cyl_spheres",
          doc="array of `{\"origin\": Vector, \"radius\": number > 0, \"height\": number ≥ 0}`"),
), _mover_spec, checks=(_spec_limits,))


# -- State: a move's outcome, replied and published ----------------------------------------------------
def _state(mover_id: int, seq: int, tag: int | str | None, ok: bool, position: Position, ts: str,
           contact: bool, walk: bool, plane: Plane | None, plane_cell: int | None, cn: Vec3 | None, sn: Vec3 | None,
           water: bool, fsf: int | None, transient: list[str],
           collide: list[int]) -> tuple[int, int, int | str | None, MoveResult]:
    return mover_id, seq, tag, MoveResult(ok, position, ts, contact, walk, plane, plane_cell, cn, sn, water, fsf,
                                          transient, collide)


#: read into (id, seq, tag, MoveResult); written by `pack_state(mover_id, seq, r, collide_ids, tag)`
STATE = Map("State", (
    Field("id", UInt(64), required=True, src="mover_id"),
    Field("seq", UInt(64), required=True, src="seq"),
    Field("tag", Tag(), omit=True, src="tag"),
    Field("ok", Bool(), required=True, src="r.ok"),
    Field("position", POSITION, required=True, src="r.position"),
    Field("landblock", UInt(16), src="(r.position.cell_id >> 16) & 0xFFFF", read=False),
    Field("transition_state", Str(), required=True, src="r.transition_state"),
    Field("contact", Bool(), required=True, src="r.contact"),
    Field("on_walkable", Bool(), required=True, src="r.on_walkable"),
    Field("contact_plane", PLANE, nullable=True, src="r.contact_plane", doc="Plane or nil"),
    Field("contact_plane_cell", UInt(32), nullable=True, src="r.contact_plane_cell", doc="uint32 or nil"),
    Field("collision_normal", VECTOR, nullable=True, src="r.collision_normal", doc="Vector or nil"),
    Field("sliding_normal", VECTOR, nullable=True, src="r.sliding_normal", doc="Vector or nil"),
    Field("water_contact", Bool(), default=False, src="r.water_contact"),
    Field("frames_stationary_fall", Int(), nullable=True, src="r.frames_stationary_fall", doc="int 0..3 or nil"),
    Field("transient_state", ListOf(Str(), doc="array of strings"), default=[], src="r.transient_state"),
    Field("collide_objects", ListOf(UInt(64)), default=[], src="collide_ids"),
), _state)


# -- moves --------------------------------------------------------------------------------------------
@dataclass(slots=True)
class MoveItem:
    """One move: exactly one of `to`, `offset` (transition) or `motion` + `dt` (physics step); `path`
    is where it stood in the request (`moves[3]`), for its errors."""

    path: str
    id: int
    tag: int | str | None
    to: Target | None = None
    offset: Vec3 | None = None
    motion: Vec3 | None = None
    dt: float | None = None
    velocity: Vec3 | None = None


#: written from clients.types.Move (whose `to` is a Position); the service reads it with msgspec Structs
#: generated from these fields (service/protocol/structs.py, used by move_structs.py), into a MoveItem
MOVE = Map("Move", (
    Field("id", UInt(64), required=True),
    Field("tag", Tag(), omit=True, doc="int or string (≤ 256 chars)"),
    Field("to", TARGET, omit=True, doc='`{"cell"?, "origin", "orientation"?}`'),
    Field("offset", VECTOR, omit=True),
    Field("motion", Vector(Vec3, engine_check(limits.check_motion)), omit=True),
    # the longest frame the client resolves (engine.constants.HUGE_QUANTUM)
    Field("dt", Number(Range(0.0, True, HUGE_QUANTUM, f"must be in (0, {HUGE_QUANTUM:g}] seconds"),
                       f"number in (0, {HUGE_QUANTUM:g}]"), required=True, with_field="motion", omit=True),
    # its speed limit is the engine's to check (World.move)
    Field("velocity", VECTOR, omit=True, excludes=("motion", "a physics step integrates its own velocity")),
), one_of=("to", "offset", "motion"), label="move")

#: the envelope's fields beside `v` (requests.parse_moves reads it: a batch item's error is its own)
MOVE_REQUEST = Map("MoveRequest", (
    Field("move", MOVE, omit=True),
    Field("moves", ListOf(MOVE, MAX_BATCH), omit=True),
    Field("publish", Enum(PUBLISH_MODES, doc='`"each"` (default) or `"batch"`'), omit=True),
), one_of=("move", "moves"))


# -- movers -------------------------------------------------------------------------------------------
@dataclass(slots=True)
class RegisterRequest:
    id: int | None
    spec: MoverSpec
    position: Position
    contact_plane: Plane | None
    contact_plane_cell: int | None
    sliding_normal: Vec3 | None = None
    water_contact: bool | None = False


def _nonzero_id(mover_id: int, path: str) -> None:
    if mover_id == 0:
        raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}: 0 is reserved (omit id to have one assigned)", path)


def _register(mover_id: int | None, spec: MoverSpec, position: Position, plane: Plane | None,
              plane_cell: int | None, sliding: Vec3 | None, water: bool) -> RegisterRequest:
    cell = None if plane is None else position.cell_id if plane_cell is None else plane_cell
    return RegisterRequest(mover_id, spec, position, plane, cell, sliding, water)


def _start_limits(req: RegisterRequest | HandoverRequest, path: str) -> None:
    try:
        limits.check_start(req.position, "position", limits.start_slack(req.spec))
    except EngineError as e:
        raise ProtocolError(ErrorKind.BAD_VALUE, str(e), e.field or "position") from None


_REGISTER_FIELDS = (
    Field("mover", MOVER_SPEC, required=True, src="{}.spec"),
    Field("position", POSITION, required=True, doc="Position"),
    Field("contact_plane", PLANE, omit=True, check=engine_check(limits.check_plane)),
    Field("contact_plane_cell", UInt(32), omit=True, with_field="contact_plane"),
    Field("sliding_normal", Vector(Vec3, engine_check(limits.check_sliding_normal)), omit=True),
    Field("water_contact", Bool(), default=False, omit=True),
)

#: read into a RegisterRequest; the client writes one
REGISTER = Map("Register", (
    Field("id", UInt(64), omit=True, check=_nonzero_id, doc="uint64 > 0"),
    *_REGISTER_FIELDS,
), _register, checks=(_start_limits,))


@dataclass(slots=True)
class HandoverRequest:
    """A mover's state passed from one instance to the next landblock's owner."""

    id: int
    seq: int
    spec: MoverSpec
    position: Position
    contact_plane: Plane | None
    contact_plane_cell: int | None
    sliding_normal: Vec3 | None
    water_contact: bool
    source: str
    #: the State of the move that crossed, packed, for the new owner to publish (so that the mover's
    #: States keep their order: the next ones come from the new owner too); None: nothing to publish
    state: bytes | None = None


#: at most this many bytes of a hand-over's packed State (a State with 256 collided ids fits in 3 KiB)
MAX_HANDOVER_STATE = 16384


def _state_bytes(value: Any, path: str) -> None:
    if not isinstance(value, bytes):
        raise ProtocolError(ErrorKind.WRONG_TYPE, f"{path}: expected bin (a packed State)", path)
    if len(value) > MAX_HANDOVER_STATE:
        raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}: {len(value)} bytes, more than {MAX_HANDOVER_STATE}", path)


def _handover(mover_id: int, seq: int, spec: MoverSpec, position: Position, plane: Plane | None,
              plane_cell: int | None, sliding: Vec3 | None, water: bool, source: str | None,
              state: bytes | None) -> HandoverRequest:
    cell = None if plane is None else position.cell_id if plane_cell is None else plane_cell
    return HandoverRequest(mover_id, seq, spec, position, plane, cell, sliding, water, source or "?", state)


#: instance to instance: a Register with the mover's id and seq, and the sender
HANDOVER = Map("Handover", (
    Field("id", UInt(64), required=True, check=_nonzero_id),
    Field("seq", UInt(64), required=True),
    *_REGISTER_FIELDS,
    Field("from", Str(), omit=True, src="{}.source"),
    Field("state", Value("bin"), omit=True, check=_state_bytes),
), _handover, checks=(_start_limits,))

UPDATE = Map("Update", (
    Field("id", UInt(64), required=True),
    Field("mover", MOVER_SPEC, required=True),
), lambda mover_id, spec: (mover_id, spec))

#: remove and get
ID_REQUEST = Map("IdRequest", (Field("id", UInt(64), required=True),), lambda mover_id: mover_id)


# -- replies written as maps --------------------------------------------------------------------------
ERROR = Map("Error", (
    Field("kind", Enum(ErrorKind.ALL), required=True),
    Field("message", Str(), required=True),
    Field("path", Str(), omit=True),
))

_COUNT = Int()
HEALTH = Map("Health", (
    Field("instance", Str(), required=True),
    Field("status", Enum(("ok", "draining", "degraded")), required=True),
    Field("protocol", Int(), required=True),
    Field("publish", ListOf(Str(), doc="[string]"), omit=True),
    Field("move_forms", ListOf(Str(), doc="[string]"), omit=True),
    Field("queries", ListOf(Str(), doc="[string]"), omit=True),
    Field("query_forms", ListOf(Str(), doc="[string]"), omit=True),
    Field("uptime_s", Number(doc="float"), required=True),
    Field("queue_depth", _COUNT, required=True),
    Field("queue_capacity", _COUNT, required=True),
    Field("movers", _COUNT, required=True),
    Field("workers", _COUNT, omit=True),
    Field("workers_ok", _COUNT, omit=True),
    Field("worker_processes", Value("array"), omit=True),
))

STATS = Map("Stats", (
    Field("instance", Str(), required=True),
    Field("uptime_s", Number(doc="float"), required=True),
    Field("movers", _COUNT, required=True),
    Field("queue_depth", _COUNT, required=True),
    Field("queue_capacity", _COUNT, required=True),
    Field("requests", Value("map string → int"), required=True),
    Field("moves", _COUNT, required=True),
    Field("errors", Value("map kind → int"), required=True),
    Field("latency_ms", Value("map"), required=True),
    Field("engine_ms", Value("map"), required=True),
    Field("loaded_landblocks", ListOf(UInt(16), doc="[uint16]"), required=True),
    Field("cache", Value("map string → number"), required=True),
    Field("handovers", Value("map"), required=True),
    Field("workers", _COUNT, omit=True),
    Field("workers_ok", _COUNT, omit=True),
    Field("worker_processes", Value("array"), omit=True),
))

LANDBLOCK_LIST = Map("Landblocks", (
    Field("instance", Str(), required=True),
    Field("owned", Value("Owned"), required=True),
    Field("loaded", ListOf(UInt(16), doc="[uint16, ...]"), required=True),
    Field("workers", _COUNT, omit=True),
    Field("worker_processes", Value("array"), omit=True),
))
