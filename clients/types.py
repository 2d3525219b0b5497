"""Typed values the client library returns and takes."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from engine.geometry import Plane, Position, Vec3
from engine.world.types import MoveResult
from service.codec import decode_state
from service.messages import MOVE
from service.wire import ErrorKind

from .errors import ServiceError

__all__ = ["MoverState", "Move", "InstanceInfo"]


@dataclass(slots=True)
class MoverState:
    """A mover's state as the service reports it: after a move, a register, or on the state key."""

    id: int
    seq: int
    tag: int | str | None
    result: MoveResult

    @classmethod
    def from_wire(cls, m: Any) -> MoverState:
        mover_id, seq, tag, result = decode_state(m)
        return cls(mover_id, seq, tag, result)

    @property
    def ok(self) -> bool:
        return self.result.ok

    @property
    def position(self) -> Position:
        return self.result.position

    @property
    def landblock(self) -> int:
        return self.result.position.landblock

    @property
    def contact(self) -> bool:
        return self.result.contact

    @property
    def on_walkable(self) -> bool:
        return self.result.on_walkable

    @property
    def contact_plane(self) -> Plane | None:
        return self.result.contact_plane

    @property
    def collision_normal(self) -> Vec3 | None:
        return self.result.collision_normal

    @property
    def transition_state(self) -> str:
        return self.result.transition_state


@dataclass(slots=True)
class Move:
    """One move of a batch: exactly one of `to`, `offset`, or `motion` with `dt`."""

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
        """The Move map (service/messages.py, MOVE)."""
        m = _encode_move(self)
        if not self.keep_cell and "to" in m:
            del m["to"]["cell"]
        return m


_encode_move = MOVE.encode_fn()


@dataclass(slots=True)
class InstanceInfo:
    """One service instance's answer on the health, stats or landblocks key."""

    instance: str
    data: dict[str, Any] = field(default_factory=dict)

    def __getitem__(self, key: str) -> Any:
        return self.data[key]

    def get(self, key: str, default: Any = None) -> Any:
        return self.data.get(key, default)


def item_result(m: Any) -> MoverState | ServiceError:
    """A batch `results` entry: a State, or the item's error."""
    if isinstance(m, dict) and "error" in m:
        return ServiceError.from_wire(m["error"])
    try:
        return MoverState.from_wire(m)
    except Exception as e:
        return ServiceError(ErrorKind.MALFORMED, f"unreadable state in reply: {e}")
