"""Walking a found path with the public World.move, as World.path's docstring tells a caller to.

Written from the contract, not from engine.navigation: from the first
waypoint, moves of at most STRIDE metres straight (3-D) toward the next
waypoint, each from where the mover stands (its cell id kept), until it is
within TOLERANCE of it; at most ceil(length / STRIDE) + 3 moves a leg.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import engine
from engine import Position

#: NavSettings' defaults, as documented
STRIDE = 3.0
TOLERANCE = 0.25


@dataclass
class Walked:
    """Where the walk stood at the end of each leg, and the first leg it failed (None: none)."""

    reached: list[Position]
    failed_leg: int | None
    why: str = ""


def _is_indoor(cell_id: int) -> bool:
    return (cell_id & 0xFFFF) >= 0x100


def walk(world: engine.World, mover_id: int, waypoints: list[Position], stride: float = STRIDE,
         tolerance: float = TOLERANCE) -> Walked:
    """Walk a registered mover over waypoints[1:] (it stands at waypoints[0])."""
    reached: list[Position] = []
    for leg, goal in enumerate(waypoints[1:], start=1):
        here = world.mover_state(mover_id).position
        moves = math.ceil(here.get_offset(goal).length() / stride) + 3
        for _ in range(moves):
            here = world.mover_state(mover_id).position
            offset = here.get_offset(goal)
            d = offset.length()
            if d <= tolerance:
                break
            step = offset if d <= stride else offset * (stride / d)
            world.move(mover_id, Position(here.cell_id, here.frame.with_origin(here.frame.origin + step)))
        state = world.mover_state(mover_id)
        where = state.position
        reached.append(where)
        d = where.get_offset(goal).length()
        same_place = where.cell_id == goal.cell_id or not (_is_indoor(where.cell_id) or _is_indoor(goal.cell_id))
        if d > tolerance or not same_place or not (state.contact and state.on_walkable):
            return Walked(reached, leg, f"leg {leg}: {d:.3f} m from {goal}, at {where}, contact {state.contact}, walkable {state.on_walkable}")
    return Walked(reached, None)


def walk_as_spec(world: engine.World, spec: engine.MoverSpec, waypoints: list[Position]) -> Walked:
    """Register a mover of `spec` where the path says it starts, walk it, and remove it again."""
    mover_id = world.add_mover(spec, waypoints[0], placement="enter_world")
    try:
        start = world.mover_state(mover_id).position
        assert start.get_offset(waypoints[0]).length() <= TOLERANCE, (start, waypoints[0])
        return walk(world, mover_id, waypoints)
    finally:
        world.remove_mover(mover_id)
