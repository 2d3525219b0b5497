"""Typed values the client library returns and takes."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from engine.geometry import Plane, Position, Vec3
from engine import MoveResult
from service.protocol.codec import decode_state
from service.protocol.messages import MOVE
from service.protocol.wire import ErrorKind

from clients.errors import ServiceError

__all__ = ["MoverState", "Move", "InstanceInfo"]


@dataclass(slots=True)
class MoverState:
    """A mover's state as the service reports it: after a move, a register, or on the state key.

    `id` the mover's id; `seq` its sequence number (0 after register, +1 for every move the service
    resolved, so a subscriber seeing a gap missed a State); `tag` the move's tag echoed (None when none was
    given); `result` the engine's `MoveResult`, whose fields the properties below read (it also has
    `contact_plane_cell`, `sliding_normal`, `water_contact`, `frames_stationary_fall`, `transient_state`
    and `collide_objects`, the ids of other movers the move touched). docs/protocol.md, "State".
    """

    id: int
    seq: int
    tag: int | str | None
    result: MoveResult

    @classmethod
    def from_wire(cls, m: Any) -> MoverState:
        """A State map as the service sends it (docs/protocol.md, "State"), decoded; for a State read off
        the bus without the client, e.g. from a `move_many_maps` entry. Raises service.protocol.errors.ProtocolError
        (its `path` names the field) for a map that is not a State."""
        mover_id, seq, tag, result = decode_state(m)
        return cls(mover_id, seq, tag, result)

    @property
    def ok(self) -> bool:
        """Whether the move found a position (False: the mover kept its origin; not an error)."""
        return self.result.ok

    @property
    def position(self) -> Position:
        """Where the mover is now: its cell id (`position.cell_id`, 0xXXYYIIII) and landblock-local origin
        in metres (`position.origin`), orientation w x y z."""
        return self.result.position

    @property
    def landblock(self) -> int:
        """The landblock (0xXXYY) the mover is in now: the high 16 bits of its cell id."""
        return self.result.position.landblock

    @property
    def contact(self) -> bool:
        """Whether it touches a surface."""
        return self.result.contact

    @property
    def on_walkable(self) -> bool:
        """Whether it stands on walkable ground (the surface's normal z at least FloorZ, 0.664)."""
        return self.result.on_walkable

    @property
    def contact_plane(self) -> Plane | None:
        """The plane it stands on when in contact (in the frame of `result.contact_plane_cell`'s
        landblock), else None."""
        return self.result.contact_plane

    @property
    def collision_normal(self) -> Vec3 | None:
        """The transition's collision normal (a unit vector), when one was set; else None."""
        return self.result.collision_normal

    @property
    def transition_state(self) -> str:
        """The transition's outcome: "OK", "Collided", "Adjusted", "Slid", "Invalid", or "NoTransition"
        when no transition ran (register, a zero move, a step whose time was held or dropped)."""
        return self.result.transition_state


@dataclass(slots=True)
class Move:
    """One move, for `Client.send`, `move_many`, `move_many_maps` and `push`: exactly one of `to`,
    `offset`, or `motion` with `dt` (the service refuses the rest: `missing_field`, `bad_value`).

    `id` the mover; `to` a target Position (cell id and landblock-local origin in metres); `offset` metres
    in the landblock frame from the current origin; `motion` metres of own motion in the mover's frame
    over `dt` seconds (a physics step, as `Client.step`); `velocity` metres per second while a `to` or
    `offset` move is resolved; `tag` an int or a string of at most 256 characters, echoed in the State.
    """

    id: int
    to: Position | None = None
    offset: Vec3 | tuple[float, float, float] | None = None
    motion: Vec3 | tuple[float, float, float] | None = None
    dt: float | None = None
    velocity: Vec3 | tuple[float, float, float] | None = None
    tag: int | str | None = None
    #: keep the target's cell as given; False sends only origin/orientation (the current cell is used)
    keep_cell: bool = True

    def to_wire(self) -> dict[str, Any]:
        """The Move map as sent on the wire (docs/protocol.md, "Move request"; service/protocol/messages.py, MOVE)."""
        m = _encode_move(self)
        if not self.keep_cell and "to" in m:
            del m["to"]["cell"]
        return m


_encode_move = MOVE.encode_fn()


@dataclass(slots=True)
class InstanceInfo:
    """One service instance's answer on the health, stats or landblocks key.

    `instance` is the instance's Zenoh id; `data` the whole answer map (docs/protocol.md, "Health",
    "Stats", "List"), read as `info["movers"]` or `info.get("status")`.
    """

    instance: str
    data: dict[str, Any] = field(default_factory=dict)

    def __getitem__(self, key: str) -> Any:
        """The answer's field `key`; KeyError when the instance did not send it."""
        return self.data[key]

    def get(self, key: str, default: Any = None) -> Any:
        """The answer's field `key`, or `default` when the instance did not send it (an older instance)."""
        return self.data.get(key, default)


def item_result(m: Any) -> MoverState | ServiceError:
    """A batch `results` entry: a State, or the item's error."""
    if isinstance(m, dict) and "error" in m:
        return ServiceError.from_wire(m["error"])
    try:
        return MoverState.from_wire(m)
    except Exception as e:
        return ServiceError(ErrorKind.MALFORMED, f"unreadable state in reply: {e}")
