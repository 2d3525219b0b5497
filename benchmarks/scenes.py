"""Deterministic scenes and move streams for the engine benchmark, and the tests' synthetic terrain.

HEIGHT_TABLE, PLAYER and `world_from_heights` are also the scenario tests' (`from benchmarks.scenes
import ...`): one player and one height table for the tests and the benchmark.

Every workload is built from code (synthetic terrain, a grid of sphere
objects) or from the shared reference scenes (the house and the interior
with stairs), with no randomness. A workload is a generator of zero-argument
callables: the benchmark times each call (one `World.move` or `World.step`,
i.e. one transition plus SetPositionInternal); whatever the generator does
between two yields (building the target, putting a mover back at its start)
is not timed.
"""

from __future__ import annotations

import functools

import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

import engine
from engine import MoverSpec, Plane, Position, SphereSpec, Vec3
from engine.geometry import Frame, Quat, to_single

from . import common

#: height byte b -> b * 0.5 m
HEIGHT_TABLE = [b * 0.5 for b in range(256)]
HOME = (0xA9, 0xB4)
LB = 0xA9B40000
DT = 1.0 / 30.0

PLAYER = MoverSpec(
    spheres=[SphereSpec((0.0, 0.0, 0.48), 0.48), SphereSpec((0.0, 0.0, 1.35), 0.48)],
    step_up_height=0.4,
    step_down_height=0.4,
    state=["Contact", "OnWalkable", "IsPlayer", "EdgeSlide"],
    gravity=True,
)
AIRBORNE = MoverSpec(spheres=PLAYER.spheres, step_up_height=0.4, step_down_height=0.4,
                     state=["IsPlayer", "EdgeSlide"], gravity=True)

Heights = Callable[[int, int], int]  # global vertex (gx, gy) -> height byte


def terrain_scene(name: str, heights: Heights, blocks: list[tuple[int, int]]) -> dict[str, Any]:
    """An acphys-scene/1 dict: each block's 9x9 vertices from a global height function."""
    return {
        "format": "acphys-scene/1",
        "name": name,
        "height_table": HEIGHT_TABLE,
        "landblocks": [
            {"id": f"{bx:02X}{by:02X}",
             "heights": [max(0, min(255, int(heights(bx * 8 + x, by * 8 + y)))) for x in range(9) for y in range(9)]}
            for bx, by in blocks
        ],
    }


def world_from_heights(
    heights: Callable[[int, int, int, int], int], blocks: Sequence[tuple[int, int]] = (HOME,),
    settings: engine.EngineSettings = engine.RETAIL,
) -> engine.World:
    """A world whose vertex (x, y) of block (bx, by) has height byte heights(bx, by, x, y).

    Unlike `terrain_scene`, each block's 9 x 9 vertices come from a function of the block and the
    vertex within it (neighbouring blocks need not agree on their shared edge), unclamped."""
    scene = {
        "format": "acphys-scene/1",
        "name": "synthetic",
        "height_table": HEIGHT_TABLE,
        "landblocks": [
            {"id": f"{bx:02X}{by:02X}", "heights": [heights(bx, by, x, y) for x in range(9) for y in range(9)]}
            for bx, by in blocks
        ],
    }
    return engine.world_from_scene_dict(scene, settings=settings)


def around(center: tuple[int, int] = HOME, r: int = 1) -> list[tuple[int, int]]:
    cx, cy = center
    return [(cx + dx, cy + dy) for dx in range(-r, r + 1) for dy in range(-r, r + 1)
            if 0 <= cx + dx <= 0xFF and 0 <= cy + dy <= 0xFF]


def cell_at(lb: int, x: float, y: float) -> int:
    return lb | (int(x // 24) * 8 + int(y // 24) + 1)


def place_on_ground(world: engine.World, spec: MoverSpec, lb: int, x: float, y: float) -> int:
    """A mover standing on the terrain at landblock-local (x, y), with its contact plane."""
    z = world.terrain_height(lb | 1, x, y)
    n = world.landblocks[lb >> 16].terrain.normal_at(x, y)
    cell = cell_at(lb, x, y)
    return world.add_mover(spec, Position.at(cell, Vec3(x, y, z)), Plane(n, -n.dot(Vec3(x, y, z))), cell)


def walk_call(world: engine.World, mid: int, dx: float, dy: float) -> Callable[[], Any]:
    p = world.mover(mid).position
    target = Position(p.cell_id, p.frame.with_origin(p.frame.origin + Vec3(dx, dy, 0.0)))
    return lambda: world.move(mid, target)


# -- terrain workloads ------------------------------------------------------------------
def flat_heights(gx: int, gy: int) -> int:
    return 100  # 50 m


def hill_heights(gx: int, gy: int) -> int:
    # neighbouring vertices differ by at most ~11 bytes (5.5 m per 24 m): all walkable
    return 110 + round(12 * math.sin(gx * 0.9) + 10 * math.cos(gy * 0.7))


def steep_heights(gx: int, gy: int) -> int:
    # a ramp rising 30 m per 24 m from vertex column 3 of each block: steeper than FloorZ
    x = gx % 8 if gx % 8 or gx == 0 else 8
    return 40 if x <= 3 else min(255, 40 + 60 * (x - 3))


def seam_heights(gx: int, gy: int) -> int:
    return 100 + round(6 * math.sin(gx * 0.5) * math.cos(gy * 0.4))


def square_walk(world: engine.World, mid: int, step: float, leg: int) -> Iterator[Callable[[], Any]]:
    """Walk a square forever: `leg` moves of `step` metres per side."""
    dirs = [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)]
    i = 0
    while True:
        dx, dy = dirs[(i // leg) % 4]
        yield walk_call(world, mid, dx * step, dy * step)
        i += 1


def wl_flat(settings: engine.EngineSettings) -> Iterator[Callable[[], Any]]:
    world = engine.world_from_scene_dict(terrain_scene("bench-flat", flat_heights, around()), settings=settings)
    mid = place_on_ground(world, PLAYER, LB, 30.0, 30.0)
    yield from square_walk(world, mid, 0.27, 100)


def wl_hills(settings: engine.EngineSettings) -> Iterator[Callable[[], Any]]:
    world = engine.world_from_scene_dict(terrain_scene("bench-hills", hill_heights, around()), settings=settings)
    mid = place_on_ground(world, PLAYER, LB, 40.0, 40.0)
    yield from square_walk(world, mid, 0.4, 250)  # 100 m sides: running over the hills


def wl_steep(settings: engine.EngineSettings) -> Iterator[Callable[[], Any]]:
    """Walk diagonally into an unwalkable ramp and slide along its foot."""
    world = engine.world_from_scene_dict(terrain_scene("bench-steep", steep_heights, around()), settings=settings)
    while True:
        mid = place_on_ground(world, PLAYER, LB, 66.0, 20.0)
        for _ in range(300):
            yield walk_call(world, mid, 0.3, 0.3)
        world.remove_mover(mid)


def wl_seams(settings: engine.EngineSettings) -> Iterator[Callable[[], Any]]:
    """Back and forth across the corner where four landblocks meet."""
    blocks = [(0xA9, 0xB4), (0xAA, 0xB4), (0xA9, 0xB5), (0xAA, 0xB5)]
    world = engine.world_from_scene_dict(terrain_scene("bench-seams", seam_heights, blocks), settings=settings)
    mid = place_on_ground(world, PLAYER, LB, 180.0, 181.0)
    sign = 1.0
    while True:
        for _ in range(96):  # 24 m each way: two seams per leg
            yield walk_call(world, mid, 0.25 * sign, 0.25 * sign)
        sign = -sign


def wl_falling(settings: engine.EngineSettings) -> Iterator[Callable[[], Any]]:
    """Drop from 100 m above flat ground under gravity (World.step), again and again."""
    world = engine.world_from_scene_dict(terrain_scene("bench-fall", flat_heights, around()), settings=settings)
    zero = Vec3(0.0, 0.0, 0.0)
    while True:
        mid = world.add_mover(AIRBORNE, Position.at(cell_at(LB, 50.0, 50.0), Vec3(50.0, 50.0, 150.0)))
        world.mover(mid).velocity = Vec3(0.0, 0.0, -0.5)  # already falling: no zero-length first step
        for _ in range(130):  # lands after ~135 frames: every timed step is a fall
            yield functools.partial(world.step, mid, zero, DT)
        world.remove_mover(mid)


# -- the crowd: 50 static sphere objects on flat ground -------------------------------------------
CROWD_SETUP = "02000050"
CROWD_GFX = "01000050"


def crowd_scene(n: int = 50) -> dict[str, Any]:
    scene = terrain_scene("bench-crowd", flat_heights, around())
    scene["gfx_objs"] = {CROWD_GFX: {
        "vertices": {"0": [-0.5, -0.5, 0.0], "1": [0.5, -0.5, 0.0], "2": [0.5, 0.5, 0.0], "3": [-0.5, 0.5, 1.0]},
        "sort_center": [0.0, 0.0, 0.5]}}
    scene["setups"] = {CROWD_SETUP: {
        "parts": [CROWD_GFX],
        "placement_frames": {"0": {"frames": [{"origin": [0.0, 0.0, 0.0], "orientation": [1.0, 0.0, 0.0, 0.0]}]}},
        "spheres": [{"origin": [0.0, 0.0, 0.5], "radius": 0.5}], "cyl_spheres": [],
        "height": 1.0, "radius": 0.5, "step_up_height": 0.0, "step_down_height": 0.0, "allow_free_heading": False}}
    objects = []
    for i in range(n):  # 10 x 5 grid, 2.5 m apart, alternate rows shifted: a walker always meets some
        row, col = divmod(i, 10)
        x = 84.0 + col * 2.5 + (1.25 if row % 2 else 0.0)
        y = 90.0 + row * 2.5
        objects.append({"id": CROWD_SETUP, "frame": {"origin": [x, y, 50.0], "orientation": [1.0, 0.0, 0.0, 0.0]}})
    scene["landblocks"][[lb["id"] for lb in scene["landblocks"]].index("A9B4")]["objects"] = objects
    return scene


def crowd_world(settings: engine.EngineSettings = engine.RETAIL) -> engine.World:
    return engine.world_from_scene_dict(crowd_scene(), settings=settings)


def crowd_available() -> str | None:
    """None when static sphere objects load and block a mover; else why not."""
    try:
        world = crowd_world()
        mid = place_on_ground(world, PLAYER, LB, 80.0, 90.0)  # the first object is at (84, 90)
        for _ in range(40):
            walk_call(world, mid, 0.25, 0.0)()
        x = world.mover(mid).position.origin.x
        if x > 84.0 - 0.5:
            return f"a mover walked through a sphere object (x = {x:.2f}, object at 84.0)"
        return None
    except Exception as e:  # noqa: BLE001 - whatever stops it is the reason to report
        return f"{type(e).__name__}: {e}"


def wl_crowd(settings: engine.EngineSettings) -> Iterator[Callable[[], Any]]:
    world = crowd_world(settings)
    lane = 0
    while True:
        y = 89.4 + (lane % 9) * 1.3
        mid = place_on_ground(world, PLAYER, LB, 80.0, y)
        for _ in range(130):  # 32 m through the grid, sliding round the spheres
            yield walk_call(world, mid, 0.25, 0.02)
        world.remove_mover(mid)
        lane += 1


# -- indoor: replay reference cases inside the house and up the interior's stairs ---------------
def trace_world(scene_file: str, settings: engine.EngineSettings) -> engine.World:
    return engine.load_scene(common.ORACLE / "scenes" / scene_file, settings=settings)


def _vec(v: Any) -> Vec3:
    return Vec3(to_single(float(v[0])), to_single(float(v[1])), to_single(float(v[2])))


def _quat(q: Any) -> Quat:
    return Quat(*(to_single(float(c)) for c in q))


def add_case_mover(world: engine.World, case: dict[str, Any]) -> int:
    from engine.formats.trace import mover_spec_from_case

    spec = mover_spec_from_case(case["object"], getattr(world, "scene", None))
    s = case["start"]
    pos = Position(int(s["cell"], 16), Frame(_vec(s["origin"]), _quat(s.get("orientation", [1, 0, 0, 0]))))
    plane = case.get("start_contact_plane")
    cell = case.get("start_contact_plane_cell")
    sliding = case.get("start_sliding_normal")
    return world.add_mover(
        spec, pos,
        Plane(_vec(plane["normal"]), to_single(float(plane["d"]))) if plane else None,
        int(cell, 16) if cell else None,
        sliding_normal=_vec(sliding) if sliding else None,
        water_contact=bool(case.get("start_water_contact", False)),
    )


def case_move_call(world: engine.World, mid: int, move: dict[str, Any]) -> Callable[[], Any] | None:
    """The timed call of one trace move (a transition to its target), or None
    for moves that are not transitions (placements, offset-only steps)."""
    if move.get("placement") is not None:
        return None
    mover = world.mover(mid)
    to = move.get("to")
    if to is None:
        if "offset" not in move:
            return None
        offset = _vec(move["offset"])
        dt = move.get("_dt", DT)
        return lambda: world.step(mid, offset, dt)
    v = move.get("velocity")
    mover.velocity = _vec(v) if v is not None else Vec3(0.0, 0.0, 0.0)
    cur = mover.position
    cell_text = to.get("cell", "current")
    cell = cur.cell_id if cell_text == "current" else int(cell_text, 16)
    orientation = _quat(to["orientation"]) if "orientation" in to else cur.frame.orientation
    target = Position(cell, Frame(_vec(to["origin"]), orientation))
    return lambda: world.move(mid, target)


def replay_cases(world: engine.World, cases: list[dict[str, Any]]) -> Iterator[Callable[[], Any]]:
    """Replay the cases' moves one after another, forever."""
    if not cases:
        raise ValueError("no cases to replay")
    while True:
        for case in cases:
            mid = add_case_mover(world, case)
            physics = case.get("physics")
            if physics and physics.get("velocity") is not None:
                world.mover(mid).velocity = _vec(physics["velocity"])
            for move in case["moves"]:
                call = case_move_call(world, mid, move)
                if call is not None:
                    yield call
            world.remove_mover(mid)


def _inside(case: dict[str, Any]) -> bool:
    return int(case["start"]["cell"], 16) & 0xFFFF >= 0x100


def wl_bsp_room(settings: engine.EngineSettings) -> Iterator[Callable[[], Any]]:
    trace = common.load_trace("house")
    cases = [c for c in trace["cases"] if _inside(c) and "wall" in c.get("tags", [])]
    yield from replay_cases(trace_world(trace["scene"], settings), cases)


def wl_stairs(settings: engine.EngineSettings) -> Iterator[Callable[[], Any]]:
    trace = common.load_trace("interior")
    cases = [c for c in trace["cases"] if "stairs" in c.get("tags", [])]
    yield from replay_cases(trace_world(trace["scene"], settings), cases)


@dataclass
class Workload:
    name: str
    description: str
    make: Callable[[engine.EngineSettings], Iterator[Callable[[], Any]]]
    anchor_us: float | None = None  # ACE's figure for the matching reference scene, if any
    target_us: float | None = None
    available: Callable[[], str | None] = field(default=lambda: None)


WORKLOADS = [
    Workload("flat", "walking on flat terrain, 0.27 m per move round a 27 m square", wl_flat, 4.5, 15.0),
    Workload("hills", "running over rolling hills, 0.4 m per move round a 100 m square", wl_hills, 9.6, 15.0),
    Workload("steep-slide", "walking diagonally into an unwalkable ramp, sliding along its foot", wl_steep, 9.5, 15.0),
    Workload("seams", "back and forth across the corner of four landblocks", wl_seams, None, 15.0),
    Workload("falling", "free fall from 100 m (World.step under gravity)", wl_falling, None, 15.0),
    Workload("bsp-room", "inside the house: reference wall approaches replayed (house trace, 'wall' cases)", wl_bsp_room, None, 40.0),
    Workload("stairs", "up and down the interior's stairs (interior trace, 'stairs' cases)", wl_stairs, None, 40.0),
    Workload("crowd-50", "walking through a grid of 50 static sphere objects on flat ground", wl_crowd, None, 40.0,
             crowd_available),
]
