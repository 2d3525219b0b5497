"""The part of `clients.Client` the demo walk uses, served by a World in this process (no service)."""

from __future__ import annotations

from typing import Any

from clients.types import MoverState
from engine import PathResult, World
from engine.geometry import Position, Vec3

__all__ = ["EngineClient"]


class EngineClient:
    """register, step, move, path and remove, answered by `world` directly."""

    def __init__(self, world: World) -> None:
        self.world = world
        self.seq = 0

    def register(self, spec: Any, position: Position) -> MoverState:
        mid = self.world.add_mover(spec, position)
        return MoverState(mid, 0, None, self.world.mover_state(mid))

    def step(self, mover_id: int, motion: tuple[float, float, float], dt: float) -> MoverState:
        self.seq += 1
        return MoverState(mover_id, self.seq, None, self.world.step(mover_id, Vec3(*motion), dt))

    def move(self, mover_id: int, to: Position) -> MoverState:
        self.seq += 1
        return MoverState(mover_id, self.seq, None, self.world.move(mover_id, to))

    def path(self, walker: Any, start: Position | None, goal: Position, *, timeout: float | None = None,
             **options: Any) -> PathResult:
        return self.world.path(walker, start, goal, **options)  # (no bus here: no timeout either)

    def remove(self, mover_id: int) -> None:
        self.world.remove_mover(mover_id)
