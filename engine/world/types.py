"""The World's public value types: what a mover is and what a move returns.

These are plain dataclasses so that callers (the service, tests, tools) can
build, compare and serialise them without touching engine internals.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Final

from ..geometry import Plane, Position, Vec3
from ..transition.state import OI
from .._compat import mypyc_attr

__all__ = ["SphereSpec", "CylSphereSpec", "MoverSpec", "MoveResult", "ObjectState"]


class ObjectState:
    """ObjectInfoState flag names accepted in `MoverSpec.state`, with the
    client's bit values (engine.transition.state.OI)."""

    BY_NAME: Final = {
        "Contact": OI.CONTACT,
        "OnWalkable": OI.ON_WALKABLE,
        "IsViewer": OI.IS_VIEWER,
        "PathClipped": OI.PATH_CLIPPED,
        "FreeRotate": OI.FREE_ROTATE,
        "PerfectClip": OI.PERFECT_CLIP,
        "IsImpenetrable": OI.IS_IMPENETRABLE,
        "IsPlayer": OI.IS_PLAYER,
        "EdgeSlide": OI.EDGE_SLIDE,
        "IgnoreCreatures": OI.IGNORE_CREATURES,
        "IsPK": OI.IS_PK,
        "IsPKLite": OI.IS_PK_LITE,
    }

    @classmethod
    def from_names(cls, names: list[str] | tuple[str, ...]) -> int:
        bits = 0
        for n in names:
            try:
                bits |= cls.BY_NAME[n]
            except KeyError:
                raise ValueError(f"unknown ObjectInfoState flag {n!r}") from None
        return bits

    @classmethod
    def to_names(cls, bits: int) -> list[str]:
        return [n for n, b in cls.BY_NAME.items() if bits & b]


@dataclass(frozen=True, slots=True)
class SphereSpec:
    """A mover sphere in the mover's own frame (unscaled)."""

    center: tuple[float, float, float]
    radius: float


@dataclass(frozen=True, slots=True)
class CylSphereSpec:
    """A cylsphere: low point in the object's frame, radius, height."""

    origin: tuple[float, float, float]
    radius: float
    height: float


@dataclass(slots=True)
class MoverSpec:
    """What an object is, for the physics: its shape and ObjectInfo inputs.

    `state` holds ObjectInfoState flag names ("Contact", "OnWalkable",
    "IsPlayer", "EdgeSlide", "PathClipped", "IsViewer", ...). Contact and
    OnWalkable are the starting transient state; the World updates them.
    """

    spheres: list[SphereSpec]
    step_up_height: float = 0.4
    step_down_height: float = 0.4
    state: list[str] = field(default_factory=list)
    step_down: bool = True  # False for missiles
    ethereal: bool = False
    scale: float = 1.0
    gravity: bool = True
    creature: bool | None = None  # default: True for IsPlayer, else False
    cyl_spheres: list[CylSphereSpec] = field(default_factory=list)
    #: PhysicsState.Sledding: calc_friction's sledding rule; on the ground the
    #: client keeps gravity on a sled and lets it bounce (docs/divergences.md)
    sledding: bool = False


@mypyc_attr(acyclic=True)
@dataclass(slots=True, init=False)
class MoveResult:
    """The resolved outcome of one move (one transition + SetPositionInternal)."""

    ok: bool
    position: Position
    transition_state: str  # "OK", "Collided", "Adjusted", "Slid", "Invalid" or "NoTransition"
    contact: bool
    on_walkable: bool
    contact_plane: Plane | None
    contact_plane_cell: int | None
    collision_normal: Vec3 | None
    sliding_normal: Vec3 | None
    water_contact: bool
    frames_stationary_fall: int | None  # None when no transition ran
    transient_state: list[str]
    collide_objects: list[int]
    #: for placements: "OK", "NoValidPosition" or "NoCell(lost)"; None for moves
    placement_result: str | None
    #: the mover's move count (Mover.seq) after this move; a result that is no move (a placement,
    #: World.mover_state) carries the count as it stands. Lets a caller order a mover's results and
    #: resume its count after a restart without keeping one of its own.
    seq: int

    # Written out rather than generated: a dataclass's generated __init__ is interpreted even in the
    # compiled engine, and one is built per move (about a third of a microsecond each).
    def __init__(self, ok: bool, position: Position, transition_state: str, contact: bool, on_walkable: bool,
                 contact_plane: Plane | None, contact_plane_cell: int | None, collision_normal: Vec3 | None,
                 sliding_normal: Vec3 | None, water_contact: bool, frames_stationary_fall: int | None,
                 transient_state: list[str], collide_objects: list[int] | None = None,
                 placement_result: str | None = None, seq: int = 0) -> None:
        self.ok = ok
        self.position = position
        self.transition_state = transition_state
        self.contact = contact
        self.on_walkable = on_walkable
        self.contact_plane = contact_plane
        self.contact_plane_cell = contact_plane_cell
        self.collision_normal = collision_normal
        self.sliding_normal = sliding_normal
        self.water_contact = water_contact
        self.frames_stationary_fall = frames_stationary_fall
        self.transient_state = transient_state
        self.collide_objects = [] if collide_objects is None else collide_objects
        self.placement_result = placement_result
        self.seq = seq
