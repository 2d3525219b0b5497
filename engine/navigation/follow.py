"""follow: a registered mover walks a path's waypoints with World.move, as the contract says.

The same walk the search proves each path with (engine.navigation.walk), on
the public World.move and a mover in the world: what a bot or a server's AI
does with an answer. From where the mover stands, moves of at most
NavSettings.stride metres straight toward the next waypoint (the one within
a stride of it aimed at the waypoint itself), until within the arrival
tolerance, at most ceil(length / stride) + EXTRA_STRIDES moves a leg.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

from ..geometry import Position
from .walk import EXTRA_STRIDES

if TYPE_CHECKING:
    from ..world.world import World

__all__ = ["follow"]


def follow(world: World, mover_id: int, waypoints: Sequence[Position]) -> int:
    """Walk the mover over `waypoints[1:]` (it stands at the first); how many of them it reached, in order,
    standing on walkable ground in each one's cell (outdoors, for an outdoor one): len(waypoints) - 1 when
    it reached them all. The mover is left where the walk ended."""
    nav = world.navigation.settings
    reached = 0
    for goal in waypoints[1:]:
        here = world.mover_state(mover_id).position
        for _ in range(math.ceil(here.get_offset(goal).length() / nav.stride) + EXTRA_STRIDES):
            here = world.mover_state(mover_id).position
            offset = here.get_offset(goal)
            distance = offset.length()
            if distance <= nav.arrival_tolerance:
                break
            step = offset if distance <= nav.stride else offset * (nav.stride / distance)
            world.move(mover_id, Position(here.cell_id, here.frame.with_origin(here.frame.origin + step)))
        state = world.mover_state(mover_id)
        where = state.position
        indoor = (where.cell_id & 0xFFFF) >= 0x100 or (goal.cell_id & 0xFFFF) >= 0x100
        if (where.get_offset(goal).length() > nav.arrival_tolerance or (indoor and where.cell_id != goal.cell_id)
                or not (state.contact and state.on_walkable)):
            return reached
        reached += 1
    return reached
