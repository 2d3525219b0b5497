"""The demo walk: a player-sized mover driven over the demo world by physics steps.

It is dropped onto the hills, walks east and north across them, walks into
the mesa's west face (too steep: it stops there), backs off, climbs the ramp
onto the mesa and walks off its north ledge. Then it crosses the hills to
the flat pad in the north-west, walks in through the house's doorway (into
the room's EnvCell) and back out, runs into the pillar and the boulder
(stopped short of them) and steps up onto the low platform and off again.
Each leg heads for a waypoint with `Client.step` (own motion on the ground,
gravity in the air) and ends when the waypoint is reached or the mover stops
making progress.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

from engine.geometry import Position, Vec3
from engine.world.types import MoverSpec, SphereSpec

from .client import Client
from .demo_map import FLOOR_Z, PathPoint
from .demo_world import (
    BOULDER,
    DOOR,
    HOUSE,
    ORIGIN_LANDBLOCK,
    PILLAR,
    PLATFORM,
    global_to_cell,
    is_indoor,
)
from .types import MoverState

__all__ = ["ARRIVE_WITHIN", "LEGS", "LegReport", "WalkResult", "demo_mover", "global_xy", "walk_demo"]

#: (what the leg is about, waypoint in global metres)
LEGS: tuple[tuple[str, tuple[float, float]], ...] = (
    ("east over the hills", (180.0, 40.0)),
    ("north across the hills", (190.0, 262.0)),
    ("into the mesa's west face", (300.0, 262.0)),
    ("back off to the south", (200.0, 90.0)),
    ("to the foot of the ramp", (288.0, 90.0)),
    ("up the ramp onto the mesa", (288.0, 320.0)),
    ("off the north ledge", (288.0, 378.0)),
    ("west along the north hills", (150.0, 372.0)),
    ("south past the house", (130.0, 290.0)),
    ("to the house's door", (DOOR[0], DOOR[1] - 7.0)),
    ("in through the door", HOUSE),
    ("back out of the house", (DOOR[0], DOOR[1] - 9.0)),
    ("into the pillar", PILLAR),
    ("west into the boulder", BOULDER),
    ("north over the platform", (PLATFORM[0], PLATFORM[1] + 10.0)),
)

#: legs that must end closer to their waypoint than ARRIVE_M: lined up with the
#: doorway, well inside the room, and heading for an object's centre (so the
#: mover runs into it rather than "arriving" next to it)
ARRIVE_WITHIN: dict[str, float] = {
    "to the house's door": 0.25,
    "in through the door": 0.5,
    "into the pillar": 0.5,
    "west into the boulder": 0.5,
}

START = (20.0, 20.0)
SPEED = 4.0  # metres per second of own motion
DT = 0.2
ARRIVE_M = 1.5
STALL_STEPS = 12  # steps without STALL_M of progress mean "blocked"
STALL_M = 0.5


def demo_mover() -> MoverSpec:
    """A player-sized mover (two spheres, as the client's human setup)."""
    return MoverSpec(
        spheres=[SphereSpec((0.0, 0.0, 0.48), 0.48), SphereSpec((0.0, 0.0, 1.35), 0.48)],
        step_up_height=0.6,
        step_down_height=0.4,
        state=["IsPlayer"],
    )


def global_xy(p: Position) -> tuple[float, float]:
    lb = p.landblock
    bx = (lb >> 8) - (ORIGIN_LANDBLOCK >> 8)
    by = (lb & 0xFF) - (ORIGIN_LANDBLOCK & 0xFF)
    return bx * 192.0 + p.origin.x, by * 192.0 + p.origin.y


@dataclass(slots=True)
class LegReport:
    name: str
    steps: int = 0
    start: tuple[float, float, float] = (0.0, 0.0, 0.0)
    end: tuple[float, float, float] = (0.0, 0.0, 0.0)
    outcome: str = ""
    collisions: int = 0
    airborne_steps: int = 0
    unwalkable_steps: int = 0
    lowest_z: float = math.inf
    highest_z: float = -math.inf
    end_cell: int = 0


@dataclass(slots=True)
class WalkResult:
    mover_id: int
    legs: list[LegReport] = field(default_factory=list)
    path: list[PathPoint] = field(default_factory=list)
    events: list[str] = field(default_factory=list)
    steps: int = 0


def _point(st: MoverState) -> PathPoint:
    x, y = global_xy(st.position)
    return PathPoint(x, y, st.contact, st.on_walkable, st.collision_normal is not None)


def walk_demo(client: Client, on_step: Callable[[int], None] | None = None) -> WalkResult:
    """Register the demo mover, walk every leg, remove it; what happened."""
    cell, lx, ly = global_to_cell(*START)
    st = client.register(demo_mover(), Position.at(cell, Vec3(lx, ly, 60.0)))
    res = WalkResult(st.id)
    res.path.append(_point(st))
    res.events.append(f"dropped at ({START[0]:.0f}, {START[1]:.0f}) from z 60.0")
    try:
        # fall onto the hills first
        for _ in range(100):
            st = client.step(st.id, (0.0, 0.0, 0.0), DT)
            res.steps += 1
            res.path.append(_point(st))
            if st.on_walkable:
                break
        res.events.append(f"landed at z {st.position.origin.z:.2f} after {res.steps} steps")
        for name, wp in LEGS:
            st = _walk_leg(client, st, name, wp, res, on_step)
    finally:
        client.remove(res.mover_id)
    return res


def _walk_leg(client: Client, st: MoverState, name: str, wp: tuple[float, float], res: WalkResult,
              on_step: Callable[[int], None] | None) -> MoverState:
    x, y = global_xy(st.position)
    leg = LegReport(name, start=(x, y, st.position.origin.z))
    dist0 = math.hypot(wp[0] - x, wp[1] - y)
    budget = int(2.5 * dist0 / (SPEED * DT)) + 40
    recent: list[float] = []
    was_walkable, was_contact = st.on_walkable, st.contact
    was_cell = st.position.cell_id
    hit = False
    arrive_m = ARRIVE_WITHIN.get(name, ARRIVE_M)
    leg.outcome = f"gave up after {budget} steps"
    for _ in range(budget):
        dx, dy = wp[0] - x, wp[1] - y
        d = math.hypot(dx, dy)
        if d < arrive_m:
            leg.outcome = "arrived"
            break
        recent.append(d)
        if len(recent) > STALL_STEPS:
            recent.pop(0)
            if recent[0] - recent[-1] < STALL_M and st.contact:
                leg.outcome = f"blocked {d:.1f} m short"
                res.events.append(f"{name}: blocked at ({x:.1f}, {y:.1f}), z {st.position.origin.z:.2f}")
                break
        f = SPEED * DT / d
        st = client.step(st.id, (dx * f, dy * f, 0.0), DT)
        res.steps += 1
        leg.steps += 1
        if on_step is not None:
            on_step(res.steps)
        x, y = global_xy(st.position)
        z = st.position.origin.z
        leg.lowest_z, leg.highest_z = min(leg.lowest_z, z), max(leg.highest_z, z)
        p = _point(st)
        res.path.append(p)
        leg.collisions += p.collided
        leg.airborne_steps += not st.contact
        leg.unwalkable_steps += st.contact and not st.on_walkable
        if was_contact and not st.contact:
            res.events.append(f"{name}: left the ground at ({x:.1f}, {y:.1f}), z {z:.2f}")
        elif not was_contact and st.contact:
            res.events.append(f"{name}: touched down at ({x:.1f}, {y:.1f}), z {z:.2f}"
                              + ("" if st.on_walkable else " on unwalkable ground"))
        elif was_walkable and st.contact and not st.on_walkable:
            res.events.append(f"{name}: on unwalkable slope at ({x:.1f}, {y:.1f}), z {z:.2f}")
        n = st.collision_normal
        if n is not None and abs(n.z) < FLOOR_Z and not hit:  # a wall, an object or a steep face
            res.events.append(f"{name}: collided at ({x:.1f}, {y:.1f}), z {z:.2f}, "
                              f"normal ({n.x:.2f}, {n.y:.2f}, {n.z:.2f})")
            hit = True
        cell = st.position.cell_id
        if is_indoor(cell) != is_indoor(was_cell):
            where = "went into the house" if is_indoor(cell) else "came out of the house"
            res.events.append(f"{name}: {where} at ({x:.1f}, {y:.1f}): cell {was_cell:08X} -> {cell:08X}")
        was_walkable, was_contact, was_cell = st.on_walkable, st.contact, cell
    leg.end = (x, y, st.position.origin.z)
    leg.end_cell = st.position.cell_id
    if is_indoor(leg.end_cell):
        leg.outcome += f", indoors (cell {leg.end_cell:08X})"
    res.legs.append(leg)
    return st
