"""What RETAIL's corrections of ACE cost and how far they move results.

The reference traces step physics at a fixed 1/30 s and have no sleds, so
on them the quantum ladder and the sledding rules change nothing (the error
benchmark's rows show it). This workload exercises them: on the `steep`
and `rolling` reference scenes,

- `frames`: a player runs (motion 4 m/s) through frames of uneven real
  length, 1/60 s to 0.5 s, jumping (5 m/s up) every 20th frame;
- `sled`: a sled starts downhill at 5 m/s on a walkable slope and is
  stepped at 1/30 s.

Each is run under ACE_COMPAT and under ACE_COMPAT with one correction (and
under RETAIL); per setting: engine time per call, and the distance of the
mover from where it is under ACE_COMPAT after each call (global metres).
"""

from __future__ import annotations

import dataclasses
import math
import time
from typing import Any
from collections.abc import Callable

import engine
from engine import MoverSpec, Plane, Position, SphereSpec, Vec3

from . import common
from .common import pct

#: (name, what it is, settings); the first is the baseline the distances are measured from
SETTINGS: list[tuple[str, str, engine.EngineSettings]] = [
    ("ace-compat", "ACE_COMPAT", engine.ACE_COMPAT),
    ("+quantum_ladder", "ACE_COMPAT with the step ladder at ACE's 0.1 s quantum",
     dataclasses.replace(engine.ACE_COMPAT, quantum_ladder=True)),
    ("+quantum_ladder, max_quantum=0.2", "ACE_COMPAT with the client's step ladder (0.2 s quantum)",
     dataclasses.replace(engine.ACE_COMPAT, quantum_ladder=True, max_quantum=0.2)),
    ("+sled_slope_friction", "ACE_COMPAT with the client's sledding friction test",
     dataclasses.replace(engine.ACE_COMPAT, sled_slope_friction=True)),
    ("+sled_gravity", "ACE_COMPAT with gravity kept on a grounded sled",
     dataclasses.replace(engine.ACE_COMPAT, sled_gravity=True)),
    ("retail", "RETAIL (all corrections, step cap 30)", engine.RETAIL),
]

PLAYER = MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.48), 0.48), SphereSpec((0.0, 0.0, 1.35), 0.48)],
                   state=["Contact", "OnWalkable", "IsPlayer", "EdgeSlide"])
SLED = MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.5), 0.5)], state=["Contact", "OnWalkable", "EdgeSlide"], sledding=True)
#: frame lengths cycled through by the `frames` workload (seconds)
FRAMES = (1 / 60, 1 / 45, 1 / 30, 0.05, 0.1, 0.016, 0.25, 0.5, 0.02, 0.2)


def _grounded(world: engine.World, spec: MoverSpec, lb: int, x: float, y: float) -> int:
    cell = lb | (int(x // 24) * 8 + int(y // 24) + 1)
    z = world.terrain_height(cell, x, y)
    n = world.landblocks[lb >> 16].terrain.normal_at(x, y)
    return world.add_mover(spec, Position.at(cell, Vec3(x, y, z)), Plane(n, -n.dot(Vec3(x, y, z))), cell)


def _global(p: Position) -> tuple[float, float, float]:
    o = p.frame.origin
    return (o.x + 192.0 * ((p.cell_id >> 24) & 0xFF), o.y + 192.0 * ((p.cell_id >> 16) & 0xFF), o.z)


#: the scenes' middle landblock, and a walkable slope in it for the sled (normal z 0.86 and 0.91)
LB = 0xA9B40000
SLED_START = {"steep": (30.0, 114.0), "rolling": (42.0, 18.0)}


def _frames(world: engine.World, scene: str) -> Callable[[int], Position]:
    mid = _grounded(world, PLAYER, LB, 96.0, 96.0)

    def call(i: int) -> Position:
        dt = FRAMES[i % len(FRAMES)]
        if i % 20 == 19:
            world.mover(mid).set_velocity(Vec3(0.0, 0.0, 5.0))
        heading = Vec3(math.cos(i * 0.05), math.sin(i * 0.05), 0.0)
        return world.step(mid, heading * (4.0 * dt), dt).position

    return call


def _sled(world: engine.World, scene: str) -> Callable[[int], Position]:
    mid = _grounded(world, SLED, LB, *SLED_START[scene])
    n = world.mover(mid).contact_plane.normal
    downhill = Vec3(0.0, 0.0, -1.0) - n * (-n.z)  # gravity's part along the ground
    length = downhill.length()
    start = downhill * (5.0 / length) if length > 1e-6 else Vec3(5.0, 0.0, 0.0)
    world.move(mid, world.mover(mid).position, velocity=start)
    return lambda i: world.step(mid, Vec3(0.0, 0.0, 0.0), 1.0 / 30.0).position


WORKLOADS: dict[str, Callable[[engine.World, str], Callable[[int], Position]]] = {"frames": _frames, "sled": _sled}
SCENES = ("steep", "rolling")


def run(quick: bool) -> dict[str, Any]:
    calls = 30 if quick else 150
    rows: list[dict[str, Any]] = []
    for workload, make in WORKLOADS.items():
        for scene in SCENES:
            tracks: dict[str, list[tuple[float, float, float]]] = {}
            for name, desc, settings in SETTINGS:
                world = engine.load_scene(common.ORACLE / "scenes" / f"{scene}.json", settings=settings)
                call = make(world, scene)
                times: list[float] = []
                track: list[tuple[float, float, float]] = []
                for i in range(calls):
                    t0 = time.perf_counter_ns()
                    pos = call(i)
                    times.append((time.perf_counter_ns() - t0) * 1e-9)
                    track.append(_global(pos))
                tracks[name] = track
                base = tracks[SETTINGS[0][0]]
                dist = [math.dist(a, b) for a, b in zip(base, track)]
                rows.append({
                    "workload": workload, "scene": scene, "name": name, "description": desc, "calls": calls,
                    "us_mean": sum(times) / len(times) * 1e6, "us_median": pct(times, 50) * 1e6,
                    "moved_final_m": dist[-1], "moved_max_m": max(dist),
                })
    return {"calls": calls, "rows": rows}
