"""The typed answers of the spatial queries (engine.queries)."""

from __future__ import annotations

from dataclasses import dataclass

from ..geometry import Plane, Position, Vec3

__all__ = ["Blocker", "RayHit", "SightResult", "Ground", "PlacementResult", "BLOCKER_KINDS"]

#: what can stop a sweep: the terrain of an outdoor cell, a polygon of an
#: indoor (Env) cell, a building's outer shell, or an object (a mover, or a
#: static landblock object, whose id is 0)
BLOCKER_KINDS = ("terrain", "cell", "building", "object")


@dataclass(frozen=True, slots=True)
class Blocker:
    """What stopped a sweep: `kind` one of BLOCKER_KINDS; `object_id` the
    mover's id for a mover, 0 for a static landblock object, None otherwise."""

    kind: str
    object_id: int | None = None


@dataclass(frozen=True, slots=True)
class RayHit:
    """The first contact of a sphere swept along a segment.

    `position` is where the sphere's centre stopped: touching what it hit
    (to engine.queries.sweep.CONTACT_TOLERANCE along the segment), or the
    segment's end when nothing was hit; `cell` the cell id it stopped in,
    `normal` the hit surface's normal (None when nothing was hit), `distance`
    how far the centre travelled from the start."""

    hit: bool
    position: Position
    cell: int
    normal: Vec3 | None
    distance: float
    blocker: Blocker | None


@dataclass(frozen=True, slots=True)
class SightResult:
    """Whether a sight object swept from one eye to the other arrives.

    When blocked, `stop` is where the sight object stopped (its centre),
    `normal` the surface normal there, `cell` the cell id it stopped in and
    `blocker` what stopped it; all None when clear."""

    clear: bool
    stop: Position | None = None
    normal: Vec3 | None = None
    cell: int | None = None
    blocker: Blocker | None = None


@dataclass(frozen=True, slots=True)
class Ground:
    """The surface under a point: its height `z` straight below the point,
    its `plane` (in the coordinates of `cell`'s landblock), the `cell` id it
    belongs to, whether a grounded object may stand on it (`walkable`,
    normal z at least FloorZ) and the water depth there (0 on dry ground)."""

    z: float
    plane: Plane
    cell: int
    walkable: bool
    water_depth: float


@dataclass(frozen=True, slots=True)
class PlacementResult:
    """Where a placement puts an object, and the contact state it leaves.

    `placement_result` is the client's outcome: "OK", "NoValidPosition" (no
    free spot: `ok` False, `position` None) or "NoCell(lost)" (no cell at
    the target). On "OK", `position` is where the object stands and the
    rest its contact state there (as a move's result reports it)."""

    ok: bool
    placement_result: str
    position: Position | None
    contact: bool = False
    on_walkable: bool = False
    contact_plane: Plane | None = None
    contact_plane_cell: int | None = None
    water_contact: bool = False
