"""The walk: how a found path is followed, and how the search proves each leg of it.

The contract (PathResult's guarantee, docs/protocol.md "Paths"): from the
first waypoint, walk to each next one in turn by moves (World.move) of at
most `stride` metres straight toward it in 3-D, each move's target taken
from where the walker stands after the last (in its landblock's frame, its
cell id kept), the move that is within `stride` of the waypoint aimed at the
waypoint itself, until the walker is within `arrival_tolerance` of the
waypoint. The walker then stands there on walkable ground (Contact and
OnWalkable) in the waypoint's cell. A leg gets at most
ceil(length / stride) + EXTRA_STRIDES moves: the moves a slope's bend or a
slide shortens.

The search proves a path by walking it so with a probe of the walker's own
shape and state (move_mover with cast_shadows off: the probe is in no cell's
shadow list), and the engine is deterministic, so the same moves give the
same result bit for bit.

"In the waypoint's cell": the same indoor cell (EnvCell) for an indoor
waypoint; outdoors for an outdoor one (the 24 m outdoor cells are a grid of
lines a point on which belongs to either side).
"""

from __future__ import annotations

import math
from typing import Final

from .. import limits
from ..cells.landscape import Landscape
from ..errors import EngineError
from ..geometry import Position
from ..world.mover import Mover
from ..world.resolve import move_mover
from ..world.rollback import MoverSnapshot
from ..world.transient import TS
from .settings import NavSettings

__all__ = ["EXTRA_STRIDES", "ProbeState", "walk_toward", "stands_at", "leg_strides"]

#: moves a leg may take beyond its length in strides
EXTRA_STRIDES: Final = 3
#: how far a move may carry the walker up while it is off the ground (a step's lift is taken in contact)
_RISE: Final = 1e-3


class ProbeState:
    """A probe's state at one moment (its MoverSnapshot and whether it sees movers), to walk again from."""

    __slots__ = ("snapshot", "ignore_movers")

    def __init__(self, probe: Mover) -> None:
        self.snapshot = MoverSnapshot(probe)
        self.ignore_movers = probe.ignore_movers

    def restore(self) -> None:
        self.snapshot.restore()
        self.snapshot.mover.ignore_movers = self.ignore_movers


def leg_strides(distance: float, stride: float) -> int:
    """The most moves a leg of `distance` metres may take."""
    return math.ceil(distance / stride) + EXTRA_STRIDES


def stands_at(probe: Mover, waypoint: Position, tolerance: float) -> bool:
    """The probe has reached `waypoint`: within `tolerance` (3-D), in its cell (outdoors for an outdoor
    waypoint), on walkable ground."""
    where = probe.position
    if where.cell_id != waypoint.cell_id and (where.cell_id & 0xFFFF >= 0x100 or waypoint.cell_id & 0xFFFF >= 0x100):
        # (two outdoor cells are one place: a point on the line between two 24 m cells belongs to
        # either, as it was found)
        return False
    if where.get_offset(waypoint).length() > tolerance:
        return False
    ts = probe.transient
    return bool(ts & TS.CONTACT) and bool(ts & TS.ON_WALKABLE)


def walk_toward(landscape: Landscape, probe: Mover, waypoint: Position, nav: NavSettings) -> bool:
    """Walk the probe to `waypoint` as the contract says; True when it stands there having kept within
    the arrival tolerance of the straight line (seen from above) all the way.

    The second condition is the search's own, stricter than the contract: a
    leg the walker only completes by sliding along a wall or round a corner
    is not taken, so that a path's waypoints are the track walked (to the
    tolerance), not just points the walk happens to reach. Nor is one that
    carries it up while it is off the ground: a move's target may lie above a
    slope too steep to stand on, and World.move, which has no gravity, would
    fly it there."""
    max_lateral = nav.arrival_tolerance
    stride = nav.stride
    tolerance = nav.arrival_tolerance
    start = probe.position
    offset = start.get_offset(waypoint)
    distance = offset.length()
    # the straight line, seen from above: steps and slopes bend a walk up and down, never sideways
    flat = math.hypot(offset.x, offset.y)
    line = (offset.x / flat, offset.y / flat) if flat > 0.0 else None
    for _ in range(leg_strides(distance, stride)):
        here = probe.position
        to_go = here.get_offset(waypoint)
        remaining = to_go.length()
        if remaining <= tolerance:
            break
        step = to_go if remaining <= stride else to_go * (stride / remaining)
        target = Position(here.cell_id, here.frame.with_origin(here.frame.origin + step))
        before = probe.transient
        if not _move(landscape, probe, target):
            return False
        after = probe.position
        if after.cell_id == here.cell_id and after.frame.origin == here.frame.origin and probe.transient == before:
            return False  # stuck: every further move would be this one again
        if not probe.transient & TS.CONTACT and here.get_offset(after).z > _RISE:
            # off the ground and going up: a move's target carries it through the air where a walker would
            # fall (World.move has no gravity), so a slope too steep to climb could be flown up
            return False
        if line is not None:
            walked = start.get_offset(after)
            if abs(walked.x * line[1] - walked.y * line[0]) > max_lateral:
                return False
    return stands_at(probe, waypoint, tolerance)


def _move(landscape: Landscape, probe: Mover, target: Position) -> bool:
    """One move of the probe, as World.move runs it (the same checks, then PhysicsObj.SetPosition
    through a transition) without casting shadows; False where World.move would refuse or raise."""
    try:
        limits.check_position(target, "target")
        landscape.check_position(target)
    except (EngineError, ValueError):
        return False
    return move_mover(landscape, probe, target, True, False).ok

