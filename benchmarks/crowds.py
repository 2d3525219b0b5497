"""Crowds of live movers on flat ground: the engine benchmark's crowd
rows and the broad-phase test's workloads.

A crowd is a set of creatures (the player's two spheres, not players: players
walk through each other) standing on flat
terrain in landblock A9B4, either spread over the middle of the landblock
(a square grid over 120 m) or packed into a 20 m square round the corner of
four cells. They take turns: each move is one creature stepping 0.2 m along
its own heading, then back on its next turn, so the crowd stays where it was
put; packed creatures stand 1.05 m apart (0.09 m between their spheres) and
bump into each other. Everything is deterministic.

`mixed_crowd` adds what the broad phase must get right beyond walkers:
players, ethereal, cylsphere, single-sphere, big-footed and non-creature
movers, an ignore-creatures walker, missiles, falling movers landing on the
others (collide mode) and new movers placed into the crowd.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

import engine
from engine import CylSphereSpec, MoverSpec, Position, SphereSpec, Vec3

from .scenes import DT, LB, PLAYER, around, flat_heights, place_on_ground, terrain_scene, walk_call

#: a monster: the player's shape, a creature, collides with the others
CREATURE = MoverSpec(spheres=PLAYER.spheres, step_up_height=0.4, step_down_height=0.4,
                     state=["Contact", "OnWalkable", "EdgeSlide"], gravity=True, creature=True)
#: how far one move carries a creature
STEP = 0.2
#: the golden angle: headings that do not line up however many creatures there are
_TURN = math.pi * (3.0 - math.sqrt(5.0))


@dataclass(frozen=True)
class Crowd:
    """A crowd layout: `count` creatures on a square grid of side `side`
    metres, `spacing` apart, centred at landblock-local (`cx`, `cy`)."""

    name: str
    description: str
    count: int
    spacing: float
    cx: float = 96.0
    cy: float = 96.0

    def positions(self) -> list[tuple[float, float]]:
        per_row = math.ceil(math.sqrt(self.count))
        half = (per_row - 1) * self.spacing * 0.5
        return [(self.cx - half + (i % per_row) * self.spacing, self.cy - half + (i // per_row) * self.spacing)
                for i in range(self.count)]


def _spread(count: int) -> Crowd:
    per_row = math.ceil(math.sqrt(count))
    return Crowd(f"crowd-{count}", f"{count} creatures spread over the middle 120 m of a landblock, each "
                 f"walking {STEP} m and back in turn", count, 120.0 / max(1, per_row - 1))


CROWDS = [
    _spread(10),
    _spread(100),
    _spread(1000),
    Crowd("crowd-400-packed", f"400 creatures packed 1.05 m apart in a 20 m square, each walking {STEP} m and back "
          "in turn (they bump)", 400, 1.05),
]


def crowd_world(crowd: Crowd, settings: engine.EngineSettings) -> tuple[engine.World, list[int]]:
    """Flat ground (A9B4 and its neighbours) with the crowd standing on it."""
    world = engine.world_from_scene_dict(terrain_scene(f"bench-{crowd.name}", flat_heights, around()), settings=settings)
    ids = [place_on_ground(world, CREATURE, LB, x, y) for x, y in crowd.positions()]
    return world, ids


def turns(world: engine.World, ids: list[int]) -> Iterator[Callable[[], Any]]:
    """The crowd's moves, forever: creature after creature, out along its heading and back."""
    out = [True] * len(ids)
    while True:
        for i, mid in enumerate(ids):
            sign = 1.0 if out[i] else -1.0
            out[i] = not out[i]
            heading = i * _TURN
            yield walk_call(world, mid, sign * STEP * math.cos(heading), sign * STEP * math.sin(heading))


def wl_crowd(crowd: Crowd) -> Callable[[engine.EngineSettings], Iterator[Callable[[], Any]]]:
    def make(settings: engine.EngineSettings) -> Iterator[Callable[[], Any]]:
        world, ids = crowd_world(crowd, settings)
        return turns(world, ids)

    return make


# -- the mixed crowd of the broad-phase test ---------------------------------------------------------
_SMALL = [SphereSpec((0.0, 0.0, 0.3), 0.3)]
MIXED_SPECS: list[MoverSpec] = [
    CREATURE,
    PLAYER,
    MoverSpec(spheres=PLAYER.spheres, state=["Contact", "OnWalkable"], creature=False),  # a non-creature object
    MoverSpec(spheres=PLAYER.spheres, state=["Contact", "OnWalkable", "IsPlayer"], ethereal=True),
    MoverSpec(spheres=_SMALL, cyl_spheres=[CylSphereSpec((0.0, 0.0, 0.0), 0.4, 1.6)], state=["Contact", "OnWalkable"]),
    MoverSpec(spheres=_SMALL, state=["Contact", "OnWalkable"], scale=1.5),  # one sphere, scaled
    MoverSpec(spheres=PLAYER.spheres, state=["Contact", "OnWalkable", "IsPlayer", "IgnoreCreatures"]),
    # a big foot under a smaller, offset head: the tests measure the head with the foot's radius
    MoverSpec(spheres=[SphereSpec((-0.75, 0.0, 0.75), 0.75), SphereSpec((0.75, 0.25, 0.625), 0.625)],
              state=["Contact", "OnWalkable"], step_up_height=0.3, step_down_height=0.3),
]
#: a falling single sphere: collide mode against whatever it lands on
FALLER = MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.4), 0.4)], state=[], creature=False)
MISSILE = MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.0), 0.15)], state=["PathClipped", "PerfectClip"],
                    step_down=False, gravity=False)


@dataclass
class MixedCrowd:
    """A packed crowd of every kind in MIXED_SPECS, with the moves to make."""

    world: engine.World
    walkers: list[int]
    record: list[Any] = field(default_factory=list)


def mixed_crowd(settings: engine.EngineSettings, side: int = 8, spacing: float = 1.05) -> MixedCrowd:
    world = engine.world_from_scene_dict(terrain_scene("bench-mixed-crowd", flat_heights, around()), settings=settings)
    crowd = Crowd("mixed", "", side * side, spacing, 93.0, 94.0)
    walkers = [place_on_ground(world, MIXED_SPECS[i % len(MIXED_SPECS)], LB, x, y)
               for i, (x, y) in enumerate(crowd.positions())]
    return MixedCrowd(world, walkers)


def run_mixed(settings: engine.EngineSettings, rounds: int = 6) -> list[Any]:
    """Every answer of a mixed crowd's moves, in order: MoveResults of walks,
    falls, missiles and placements (a refused placement as its error's text),
    and at the end every mover's state."""
    crowd = mixed_crowd(settings)
    world = crowd.world
    out: list[Any] = []
    walk = turns(world, crowd.walkers)
    z_ground = world.terrain_height(LB | 1, 90.0, 90.0)
    for r in range(rounds):
        for _ in range(len(crowd.walkers)):
            out.append(next(walk)())
        # something falls into the crowd and lands on whatever is under it
        x, y = 89.5 + 0.9 * r, 90.2 + 1.1 * r
        faller = world.add_mover(FALLER, Position.at(_cell(x, y), Vec3(x, y, z_ground + 2.5)))
        for _ in range(40):
            out.append(world.step(faller, Vec3(0.0, 0.0, 0.0), DT))
        # a missile flies through at head height
        start = Vec3(86.0, 91.0 + 0.7 * r, z_ground + 1.3)
        missile = world.add_mover(MISSILE, Position.at(_cell(start.x, start.y), start))
        for k in range(1, 30):
            p = world.mover(missile).position
            out.append(world.move(missile, Position(p.cell_id, p.frame.with_origin(p.frame.origin + Vec3(0.5, 0.05 * k, 0.0)))))
        world.remove_mover(missile)
        # a newcomer is placed into the crowd (slid to a free spot, or refused)
        at = Vec3(92.0 + 0.5 * r, 93.0, z_ground)
        try:
            mid = world.add_mover(PLAYER, Position.at(_cell(at.x, at.y), at), placement="enter_world")
            out.append(world.mover_state(mid))
        except engine.EngineError as e:
            out.append(f"{type(e).__name__}: {e}")
    out.extend(world.mover_state(mid) for mid in sorted(world.movers))
    return [answer(r) for r in out]


def run_crowd(crowd: Crowd, settings: engine.EngineSettings, moves: int) -> list[Any]:
    """The answers of a crowd's first `moves` moves, then every mover's state."""
    world, ids = crowd_world(crowd, settings)
    calls = turns(world, ids)
    out: list[Any] = [next(calls)() for _ in range(moves)]
    out.extend(world.mover_state(mid) for mid in ids)
    return [answer(r) for r in out]


def answer(result: Any) -> Any:
    """Every field of a MoveResult as plain, comparable values (Positions and
    Frames compare by identity); anything else as it is."""
    if not isinstance(result, engine.MoveResult):
        return result
    return tuple((f.name, _plain(getattr(result, f.name))) for f in dataclasses.fields(result))


def _plain(value: Any) -> Any:
    if isinstance(value, Position):
        q = value.frame.orientation
        return (value.cell_id, value.frame.origin.as_tuple(), (q.w, q.x, q.y, q.z))
    if isinstance(value, engine.Plane):
        return (value.normal.as_tuple(), value.d)
    if isinstance(value, Vec3):
        return value.as_tuple()
    if isinstance(value, list):
        return tuple(value)
    return value


def _cell(x: float, y: float) -> int:
    return LB | (int(x // 24) * 8 + int(y // 24) + 1)
