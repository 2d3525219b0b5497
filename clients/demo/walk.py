"""The demo walk: a player-sized mover driven over the demo world by physics steps.

It is dropped onto the hills, walks east and north across them, walks into
the mesa's west face (too steep: it stops there), backs off, climbs the ramp
onto the mesa and walks off its north ledge. Then it crosses the north
hills, asks the service for a path into the house (`Client.path`: round its
walls to the doorway that faces south, into the room's EnvCell) and walks
it, walks back out, runs into the pillar and the boulder (stopped short of
them) and steps up onto the low platform and off again. Each leg but the
path's heads for a waypoint with `Client.step` (own motion on the ground,
gravity in the air) and ends when the waypoint is reached or the mover stops
making progress. The path's leg (PATH_LEG) is walked as the path's
guarantee says (docs/protocol.md, "Paths"): `Client.move`s of at most 3 m
straight toward each waypoint in turn, until within 0.25 m of it.

The landing lasts until the mover has stood on walkable ground for a few
steps in a row (a hard landing bounces first), so that every leg starts
standing. Each step is counted once: in the walk's total, in its leg (or
the landing), on the path and by the progress callback. Events
(`WalkEvent`) carry where they happened: the position after their step,
except "left the ground", which is where the mover last stood.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

from engine.geometry import Position, Vec3

from clients.cli.player import player_mover
from clients.client import Client
from clients.demo.map import FLOOR_Z, PathPoint
from clients.demo.world import (
    BOULDER,
    DOOR,
    HOUSE,
    HOUSE_CELL,
    ORIGIN_LANDBLOCK,
    PAD_HEIGHT,
    PILLAR,
    PLATFORM,
    global_to_cell,
    is_indoor,
)
from clients.types import MoverState

__all__ = ["ARRIVE_WITHIN", "FIRST_LEG", "LANDING", "LEGS", "PATH_LEG", "LegReport", "WalkEvent", "WalkResult",
           "global_xy", "numbered_legs", "walk_demo"]

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
    ("by a path into the house", HOUSE),
    ("back out of the house", (DOOR[0], DOOR[1] - 9.0)),
    ("into the pillar", PILLAR),
    ("west into the boulder", BOULDER),
    ("north over the platform", (PLATFORM[0], PLATFORM[1] + 10.0)),
)

#: the leg walked along a path the service finds (Client.path) rather than by physics steps: from the
#: north hills to the middle of the house's room (its EnvCell, on the floor), the doorway facing away
PATH_LEG = "by a path into the house"
PATH_GOAL = (HOUSE_CELL, float(PAD_HEIGHT))  # the goal's cell and height; its x, y are the leg's waypoint
#: the path's guarantee (docs/protocol.md, "Paths"): moves of at most this many metres straight toward
#: the next waypoint, until within PATH_ARRIVAL_M of it, at most ceil(leg / stride) + PATH_EXTRA_MOVES a leg
PATH_STRIDE_M = 3.0
PATH_ARRIVAL_M = 0.25
PATH_EXTRA_MOVES = 3
#: seconds the path may take: the first path to reach a landblock builds its graph (about a second of the
#: service's time per landblock, several on a slow machine or the interpreted engine)
PATH_TIMEOUT_S = 60.0

#: legs that must end closer to their waypoint than ARRIVE_M: heading for an object's centre (so the
#: mover runs into it rather than "arriving" next to it)
ARRIVE_WITHIN: dict[str, float] = {
    "into the pillar": 0.5,
    "west into the boulder": 0.5,
}

#: the number of the first leg, the same on the map, the profile, the story and the printed table
#: (the landing before it is not a leg and has no number)
FIRST_LEG = 1

START = (20.0, 20.0)
START_Z = 60.0
LANDING = "fall onto the hills"  # the walk's first part: a drop from START_Z until it stands still on the ground
SETTLED_STEPS = 2  # steps on walkable ground in a row that end the landing (a hard landing bounces first)
STEP_UP_M = 0.3  # a rise this much above the contact plane's slope in one step is a step up (down: a step down)
SLIDE_FRACTION = 0.3  # a collision that still leaves this share of the step's own motion ...
SLIDE_COS = 0.94  # ... and turns it by more than 20 degrees is a slide
HELD_FRACTION = 0.2  # on walkable ground, a walkable collision normal and less than this share: held back
SPEED = 4.0  # metres per second of own motion
DT = 0.2
ARRIVE_M = 1.5
STALL_STEPS = 12  # steps without STALL_M of progress mean "blocked"
STALL_M = 0.5



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
    #: the path's waypoints (global x, y and z) when the leg was walked along a path; else empty
    waypoints: list[tuple[float, float, float]] = field(default_factory=list)
    #: the path's length as the service answered it (metres; 0 for a leg of physics steps)
    path_length: float = 0.0


@dataclass(frozen=True, slots=True)
class WalkEvent:
    """Something that happened on the walk, where it happened (global metres) and after which step.

    `kind` is one of "dropped", "landed", "bounced", "left_ground", "touched_down", "steep",
    "collision", "slide", "held_back", "step_up", "step_down", "blocked", "went_in", "came_out"."""

    kind: str
    leg: str
    step: int
    x: float
    y: float
    z: float
    text: str

    def __str__(self) -> str:
        return f"{self.leg}: {self.text}" if self.leg and self.leg != LANDING else self.text


@dataclass(slots=True)
class WalkResult:
    """The walk: its landing and legs, every resolved position, and its events.

    `steps` counts every physics step and every move sent; it equals
    `landing.steps` plus every leg's `steps`, and `len(path) - 1` (path[0] is
    the registered start). `moves` counts those that were moves along the
    path (PATH_LEG's steps)."""

    mover_id: int
    landing: LegReport = field(default_factory=lambda: LegReport(LANDING))
    legs: list[LegReport] = field(default_factory=list)
    path: list[PathPoint] = field(default_factory=list)
    events: list[WalkEvent] = field(default_factory=list)
    steps: int = 0
    moves: int = 0

    def event(self, kind: str, leg: str, z: float, text: str, at: tuple[float, float] | None = None) -> None:
        """Record an event at `at` (default: the last point of the path)."""
        x, y = at if at is not None else (self.path[-1].x, self.path[-1].y)
        self.events.append(WalkEvent(kind, leg, self.steps, x, y, z, text))


def numbered_legs(legs: list[LegReport]) -> list[tuple[int, LegReport]]:
    """Each leg with its number (from FIRST_LEG), as every view of the walk numbers it."""
    return list(enumerate(legs, start=FIRST_LEG))


def _point(st: MoverState) -> PathPoint:
    x, y = global_xy(st.position)
    return PathPoint(x, y, st.contact, st.on_walkable, st.collision_normal is not None, st.position.origin.z)


def walk_demo(client: Client, on_step: Callable[[int], None] | None = None) -> WalkResult:
    """Register the demo mover, let it land, walk every leg, remove it; what happened.

    `on_step` is called with the running count after every physics step (landing included)."""
    cell, lx, ly = global_to_cell(*START)
    st = client.register(player_mover(), Position.at(cell, Vec3(lx, ly, START_Z)))
    res = WalkResult(st.id)
    res.path.append(_point(st))
    res.event("dropped", LANDING, START_Z, f"dropped at ({START[0]:.0f}, {START[1]:.0f}) from z {START_Z:.1f}")
    try:
        st = _land(client, st, res, on_step)
        for name, wp in LEGS:
            if name == PATH_LEG:
                st = _walk_path_leg(client, st, name, wp, res, on_step)
            else:
                st = _walk_leg(client, st, name, wp, res, on_step)
    finally:
        client.remove(res.mover_id)
    return res


def _record(st: MoverState, leg: LegReport, res: WalkResult, on_step: Callable[[int], None] | None) -> PathPoint:
    """Count one physics step in the walk and in its leg, and add its point to the path."""
    res.steps += 1
    leg.steps += 1
    if on_step is not None:
        on_step(res.steps)
    p = _point(st)
    res.path.append(p)
    leg.lowest_z, leg.highest_z = min(leg.lowest_z, p.z), max(leg.highest_z, p.z)
    leg.collisions += p.collided
    leg.airborne_steps += not st.contact
    leg.unwalkable_steps += st.contact and not st.on_walkable
    return p


def _land(client: Client, st: MoverState, res: WalkResult, on_step: Callable[[int], None] | None) -> MoverState:
    """Fall until the mover has stood on walkable ground SETTLED_STEPS steps in a row (a hard landing bounces)."""
    leg = res.landing
    x, y = global_xy(st.position)
    leg.start = (x, y, st.position.origin.z)
    first: tuple[float, float] | None = None
    settled = 0
    for _ in range(100):
        st = client.step(st.id, (0.0, 0.0, 0.0), DT)
        p = _record(st, leg, res, on_step)
        if st.on_walkable and first is None:
            first = (p.x, p.y)
            res.event("landed", LANDING, p.z, f"landed at ({p.x:.1f}, {p.y:.1f}), z {p.z:.2f} after {res.steps} steps")
        settled = settled + 1 if st.on_walkable else 0
        if settled >= SETTLED_STEPS:
            break
    leg.end = (res.path[-1].x, res.path[-1].y, st.position.origin.z)
    leg.end_cell = st.position.cell_id
    if first is not None:
        moved = math.hypot(leg.end[0] - first[0], leg.end[1] - first[1])
        if leg.airborne_steps > 0 and moved > 0.05 and any(not q.contact for q in res.path[-leg.steps:][1:]):
            res.event("bounced", LANDING, leg.end[2], f"bounced {moved:.1f} m and came to rest at "
                      f"({leg.end[0]:.1f}, {leg.end[1]:.1f}), z {leg.end[2]:.2f} after {res.steps} steps")
    leg.outcome = "standing" if settled >= SETTLED_STEPS else "still falling after 100 steps"
    return st


def _walk_leg(client: Client, st: MoverState, name: str, wp: tuple[float, float], res: WalkResult,
              on_step: Callable[[int], None] | None) -> MoverState:
    x, y = global_xy(st.position)
    leg = LegReport(name, start=(x, y, st.position.origin.z))
    dist0 = math.hypot(wp[0] - x, wp[1] - y)
    budget = int(2.5 * dist0 / (SPEED * DT)) + 40
    recent: list[float] = []
    was_walkable, was_contact = st.on_walkable, st.contact
    was_cell = st.position.cell_id
    was_plane = st.result.contact_plane
    hit = slid = held = False
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
                res.event("blocked", name, st.position.origin.z,
                          f"blocked at ({x:.1f}, {y:.1f}), z {st.position.origin.z:.2f}")
                break
        f = SPEED * DT / d
        was_xy, was_z = (x, y), st.position.origin.z
        st = client.step(st.id, (dx * f, dy * f, 0.0), DT)
        p = _record(st, leg, res, on_step)
        x, y, z = p.x, p.y, p.z
        moved = math.hypot(x - was_xy[0], y - was_xy[1])
        if was_contact and not st.contact:  # where it last stood, so that the air stretch starts there
            res.event("left_ground", name, was_z, f"left the ground at ({was_xy[0]:.1f}, {was_xy[1]:.1f}), z {was_z:.2f}",
                      at=was_xy)
        elif not was_contact and st.contact:
            res.event("touched_down", name, z, f"touched down at ({x:.1f}, {y:.1f}), z {z:.2f}"
                      + ("" if st.on_walkable else " on unwalkable ground"))
        elif was_walkable and st.contact and not st.on_walkable:
            res.event("steep", name, z, f"on unwalkable slope at ({x:.1f}, {y:.1f}), z {z:.2f}")
        elif was_contact and st.contact and was_plane is not None and moved < 1.5 * SPEED * DT:
            pn = was_plane.normal  # how far the old contact plane rises under this step
            along = -(pn.x * (x - was_xy[0]) + pn.y * (y - was_xy[1])) / pn.z if abs(pn.z) > 1e-6 else 0.0
            rise = (z - was_z) - along
            if rise > STEP_UP_M:
                res.event("step_up", name, z, f"stepped up {rise:.2f} m at ({x:.1f}, {y:.1f}), z {z:.2f}")
            elif rise < -STEP_UP_M and st.on_walkable:
                res.event("step_down", name, z, f"stepped down {-rise:.2f} m at ({x:.1f}, {y:.1f}), z {z:.2f}")
        n = st.collision_normal
        if n is not None and abs(n.z) < FLOOR_Z:  # a wall, an object or a steep face
            if not hit:
                res.event("collision", name, z, f"collided at ({x:.1f}, {y:.1f}), z {z:.2f}, "
                          f"normal ({n.x:.2f}, {n.y:.2f}, {n.z:.2f})")
                hit = True
            turned = moved > 1e-6 and ((x - was_xy[0]) * dx + (y - was_xy[1]) * dy) / (moved * d) < SLIDE_COS
            if moved > SLIDE_FRACTION * SPEED * DT and turned and not slid:
                res.event("slide", name, z, f"slid along the obstacle at ({x:.1f}, {y:.1f})")
                slid = True
        elif n is not None and st.on_walkable and moved < HELD_FRACTION * SPEED * DT and not held:
            # the walkable check refused the step onto ground too steep to stand on
            res.event("held_back", name, z, f"held back at the foot of an unwalkable slope at ({x:.1f}, {y:.1f}), "
                      f"z {z:.2f}")
            held = True
        cell = st.position.cell_id
        if is_indoor(cell) != is_indoor(was_cell):
            kind, where = ("went_in", "went into the house") if is_indoor(cell) else ("came_out", "came out of the house")
            res.event(kind, name, z, f"{where} at ({x:.1f}, {y:.1f}): cell {was_cell:08X} -> {cell:08X}")
        was_walkable, was_contact, was_cell = st.on_walkable, st.contact, cell
        was_plane = st.result.contact_plane
    leg.end = (x, y, st.position.origin.z)
    leg.end_cell = st.position.cell_id
    if is_indoor(leg.end_cell):
        leg.outcome += f", indoors (cell {leg.end_cell:08X})"
    res.legs.append(leg)
    return st


def _went_in_or_out(res: WalkResult, name: str, was_cell: int, st: MoverState) -> None:
    """A went_in / came_out event when the step just recorded crossed into or out of the house."""
    cell = st.position.cell_id
    if is_indoor(cell) != is_indoor(was_cell):
        p = res.path[-1]
        kind, where = ("went_in", "went into the house") if is_indoor(cell) else ("came_out", "came out of the house")
        res.event(kind, name, p.z, f"{where} at ({p.x:.1f}, {p.y:.1f}): cell {was_cell:08X} -> {cell:08X}")


def _walk_path_leg(client: Client, st: MoverState, name: str, goal_xy: tuple[float, float], res: WalkResult,
                   on_step: Callable[[int], None] | None) -> MoverState:
    """Ask the service for a path from where the mover stands to the leg's goal and walk it with moves, as
    the path's guarantee says; each move is one step of the walk (counted in `res.moves` too)."""
    x, y = global_xy(st.position)
    leg = LegReport(name, start=(x, y, st.position.origin.z))
    res.legs.append(leg)
    goal_cell, goal_z = PATH_GOAL
    gx, gy = goal_xy
    # the goal in its own landblock's frame (the room's EnvCell is in A9B5, as the walk's global metres say)
    _, lx, ly = global_to_cell(gx, gy)
    found = client.path(st.id, None, Position.at(goal_cell, Vec3(lx, ly, goal_z)), timeout=PATH_TIMEOUT_S)
    if not found.found:
        leg.end, leg.end_cell = leg.start, st.position.cell_id
        leg.outcome = f"no path ({found.reason}: {found.detail})"
        return st
    leg.waypoints = [(*global_xy(p), p.origin.z) for p in found.waypoints]
    leg.path_length = found.length
    reached = 0
    for wp in found.waypoints[1:]:
        here = st.position
        for _ in range(math.ceil(here.get_offset(wp).length() / PATH_STRIDE_M) + PATH_EXTRA_MOVES):
            to_go = here.get_offset(wp)
            distance = to_go.length()
            if distance <= PATH_ARRIVAL_M:
                break
            step = to_go if distance <= PATH_STRIDE_M else to_go * (PATH_STRIDE_M / distance)
            was_cell = here.cell_id
            st = client.move(st.id, here.with_origin(here.origin + step))
            res.moves += 1
            _record(st, leg, res, on_step)
            _went_in_or_out(res, name, was_cell, st)
            here = st.position
        if here.get_offset(wp).length() > PATH_ARRIVAL_M:
            break
        reached += 1
    n = len(found.waypoints) - 1
    leg.outcome = (f"arrived along a path of {n} legs, {found.length:.1f} m" if reached == n else
                   f"stopped after {reached} of the path's {n} waypoints")
    leg.end = (res.path[-1].x, res.path[-1].y, st.position.origin.z)
    leg.end_cell = st.position.cell_id
    if is_indoor(leg.end_cell):
        leg.outcome += f", indoors (cell {leg.end_cell:08X})"
    return st
