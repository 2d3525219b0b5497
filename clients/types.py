"""Typed values the client library returns and takes."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from engine.geometry import Plane, Position, Vec3
from engine.world.types import MoveResult
from service.codec import decode_state, encode_position, encode_vec
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
        m: dict[str, Any] = {"id": self.id}
        if self.to is not None:
            m["to"] = encode_position(self.to)
            if not self.keep_cell:
                del m["to"]["cell"]
        if self.offset is not None:
            m["offset"] = _vec(self.offset)
        if self.motion is not None:
            m["motion"] = _vec(self.motion)
            m["dt"] = self.dt
        if self.velocity is not None:
            m["velocity"] = _vec(self.velocity)
        if self.tag is not None:
            m["tag"] = self.tag
        return m


def _vec(v: Vec3 | tuple[float, float, float]) -> list[float]:
    if isinstance(v, Vec3):
        return encode_vec(v) or []
    return [float(c) for c in v]


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
