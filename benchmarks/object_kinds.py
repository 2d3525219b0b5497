"""Every kind of object in odd places: the object-kinds fuzz, shared by a test and the stress run.

A case is one mover, of any combination of the ObjectInfo flags IsViewer,
PathClipped, PerfectClip, EdgeSlide, FreeRotate and IsPlayer, with one or
two spheres of 2 mm to 15 m (scale 0.5 to 2: at least the 1 mm the limits allow), starting on, under or high
above the ground, exactly on a cell corner or a landblock edge (synthetic
hills, flat open water at sea level, four landblocks meeting) or at a
reference start indoors (the cellar, the house), moved by zero, tiny
(1 nm to 1 mm), vertical, ordinary (1 m) and very long (250 m) moves and
physics steps, under RETAIL or ACE_COMPAT.

`random_case` draws a case from a random.Random (benchmarks/stress.py);
tests/test_fuzz_object_kinds.py draws the same fields with hypothesis.
`run_kind_case` runs one and reports what every move did; what must hold is
that nothing but the engine's documented input errors is raised, that
every number of every result is finite, that a refused move leaves its
mover as it was, and that the same case gives the same answers twice.
"""

from __future__ import annotations

import functools
import math
import random
from dataclasses import dataclass, field
from typing import Any

import engine
from engine import MoverSpec, Plane, Position, SphereSpec, Vec3
from engine.errors import EngineError
from engine.limits import MIN_SPHERE_RADIUS

from . import common
from . import scenes as S

FLAG_NAMES = ("IsViewer", "PathClipped", "PerfectClip", "EdgeSlide", "FreeRotate", "IsPlayer")
#: outdoor scenes start at a drawn point of landblock A9B4; indoor ones at a reference case's start
OUTDOOR_SCENES = ("hills", "sea", "seams")
INDOOR_SCENES = ("cellar", "house")
SCENES = OUTDOOR_SCENES + INDOOR_SCENES
PRESETS = ("retail", "ace")
STARTS = ("on", "under", "high", "cell-corner", "landblock-edge")
MOVE_KINDS = ("zero", "tiny", "vertical", "step", "long", "physics")
SCALES = (0.5, 1.0, 2.0)
#: unscaled: the smallest scaled radius the limits allow (engine.limits.MIN_SPHERE_RADIUS) at the smallest scale
MIN_RADIUS = MIN_SPHERE_RADIUS / min(SCALES)
MAX_RADIUS = 15.0
MAX_MOVES = 8
DT = 1.0 / 30.0
HOME = 0xA9B40000


@dataclass(frozen=True)
class Move:
    kind: str  # one of MOVE_KINDS
    size: float  # 0..1: where in its kind's range the move's length lies
    angle: float  # radians: its horizontal direction


@dataclass(frozen=True)
class KindCase:
    scene: str
    preset: str
    flags: tuple[str, ...]  # a subset of FLAG_NAMES
    contact: bool  # starts with Contact and OnWalkable
    radius: float
    two_spheres: bool
    scale: float
    start: str  # one of STARTS (outdoor scenes only)
    where: float  # 0..1: which point (outdoors) or which reference start (indoors)
    moves: tuple[Move, ...]

    def spec(self) -> MoverSpec:
        r = self.radius
        spheres = [SphereSpec((0.0, 0.0, r), r)]
        if self.two_spheres:
            spheres.append(SphereSpec((0.0, 0.0, 2.5 * r), r))
        step = min(0.4, r)
        state = list(self.flags) + (["Contact", "OnWalkable"] if self.contact else [])
        return MoverSpec(spheres=spheres, step_up_height=step, step_down_height=step, state=state,
                         step_down="PathClipped" not in self.flags, scale=self.scale, gravity=True)


@dataclass
class Outcome:
    """What one case did: each move's answer (a tuple of every number, or the error's class name)."""

    answers: list[Any] = field(default_factory=list)
    moves: int = 0
    refused: int = 0  # moves the engine refused at the door (EngineError)
    nonfinite: int = 0  # results with a NaN or infinity anywhere
    refusal_changed: int = 0  # refused moves that changed their mover anyway
    start_refused: bool = False


def random_case(rng: random.Random) -> KindCase:
    """A case drawn with `rng` (the stress run's generator)."""
    scene = rng.choice(SCENES)
    return KindCase(
        scene=scene,
        preset=rng.choice(PRESETS),
        flags=tuple(f for f in FLAG_NAMES if rng.random() < 0.5),
        contact=rng.random() < 0.5,
        radius=MIN_RADIUS * (MAX_RADIUS / MIN_RADIUS) ** rng.random(),  # log-uniform: as many tiny as huge
        two_spheres=rng.random() < 0.4,
        scale=rng.choice(SCALES),
        start=rng.choice(STARTS),
        where=rng.random(),
        moves=tuple(Move(rng.choice(MOVE_KINDS), rng.random(), rng.uniform(0.0, 2.0 * math.pi))
                    for _ in range(rng.randint(1, MAX_MOVES))),
    )


# -- worlds, built once per process and scene (a case removes its mover when done) -------------------
def _sea_scene() -> dict[str, Any]:
    """Flat terrain at height 0, every vertex water (terrain type 0x10): open sea."""
    scene = S.terrain_scene("kinds-sea", lambda gx, gy: 0, S.around())
    for lb in scene["landblocks"]:
        lb["terrain"] = [0x10 << 2] * 81
    return scene


@functools.cache
def world(scene: str) -> engine.World:
    if scene == "hills":
        return engine.world_from_scene_dict(S.terrain_scene("kinds-hills", S.hill_heights, S.around()))
    if scene == "sea":
        return engine.world_from_scene_dict(_sea_scene())
    if scene == "seams":
        blocks = [(0xA9, 0xB4), (0xAA, 0xB4), (0xA9, 0xB5), (0xAA, 0xB5)]
        return engine.world_from_scene_dict(S.terrain_scene("kinds-seams", S.seam_heights, blocks))
    return engine.load_scene(common.ORACLE / "scenes" / f"{scene}.json")


@functools.cache
def reference_starts(scene: str) -> list[dict[str, Any]]:
    return [c for c in common.load_trace(scene)["cases"] if "movers" not in c and "object" in c]


# -- one case -------------------------------------------------------------------------------------
def _outdoor_start(w: engine.World, case: KindCase) -> tuple[Position, Plane]:
    u = case.where
    if case.start == "cell-corner":
        x, y = 24.0 * (1 + int(u * 7) % 7), 24.0 * (1 + int(u * 49) % 7)
    elif case.start == "landblock-edge":
        x, y = [(0.0, 20.0 + 150.0 * u), (192.0, 20.0 + 150.0 * u), (20.0 + 150.0 * u, 0.0),
                (20.0 + 150.0 * u, 192.0), (0.0, 0.0)][int(u * 5) % 5]
    else:
        x, y = 20.0 + 150.0 * u, 20.0 + 150.0 * ((u * 7.0) % 1.0)
    # the terrain under a point on the landblock's north or east edge is that of its last row of cells
    tx, ty = min(x, 191.999), min(y, 191.999)
    h = w.terrain_height(HOME | 1, tx, ty)
    n = w.landblocks[HOME >> 16].terrain.normal_at(tx, ty)
    z = h + {"under": -0.5, "high": 100.0}.get(case.start, 0.0)
    plane = Plane(n, -n.dot(Vec3(tx, ty, h)))
    return Position.at(S.cell_at(HOME, tx, ty), Vec3(x, y, z)), plane


def _add(w: engine.World, case: KindCase) -> int:
    spec = case.spec()
    if case.scene in INDOOR_SCENES:
        starts = reference_starts(case.scene)
        ref = starts[int(case.where * len(starts)) % len(starts)]
        mid = S.add_case_mover(w, ref)
        w.update_mover(mid, spec)
        return mid
    position, plane = _outdoor_start(w, case)
    return w.add_mover(spec, position, plane if case.contact else None, position.cell_id)


def _offset(move: Move) -> Vec3:
    a, u = move.angle, move.size
    if move.kind == "zero":
        return Vec3(0.0, 0.0, 0.0)
    if move.kind == "tiny":
        d = 10.0 ** (-9.0 + 6.0 * u)
        return Vec3(d * math.cos(a), d * math.sin(a), 0.0)
    if move.kind == "vertical":
        dz = 10.0 ** (-2.0 + 3.7 * ((2.0 * u) % 1.0))  # 1 cm .. 50 m
        return Vec3(0.0, 0.0, dz if u < 0.5 else -dz)
    d = 250.0 if move.kind == "long" else 1.0
    return Vec3(d * math.cos(a), d * math.sin(a), 0.0)


def _numbers(r: engine.MoveResult) -> tuple[Any, ...]:
    """Every number of a result, and its flags: what two runs must agree on exactly."""
    f = r.position.frame
    o, q = f.origin, f.orientation
    cp = r.contact_plane
    vecs = [v for v in (r.collision_normal, r.sliding_normal) if v is not None]
    return (r.ok, r.transition_state, r.position.cell_id, o.x, o.y, o.z, q.w, q.x, q.y, q.z,
            None if cp is None else (cp.normal.x, cp.normal.y, cp.normal.z, cp.d), r.contact_plane_cell,
            tuple((v.x, v.y, v.z) for v in vecs), r.contact, r.on_walkable, r.water_contact,
            r.frames_stationary_fall, tuple(r.transient_state), tuple(r.collide_objects))


def finite_result(r: engine.MoveResult) -> bool:
    numbers: list[float] = []
    f = r.position.frame
    numbers += [f.origin.x, f.origin.y, f.origin.z, f.orientation.w, f.orientation.x, f.orientation.y, f.orientation.z]
    if r.contact_plane is not None:
        n = r.contact_plane.normal
        numbers += [n.x, n.y, n.z, r.contact_plane.d]
    for v in (r.collision_normal, r.sliding_normal):
        if v is not None:
            numbers += [v.x, v.y, v.z]
    return all(math.isfinite(x) for x in numbers)


def _mover_state(w: engine.World, mid: int) -> tuple[Any, ...]:
    m = w.mover(mid)
    v = m.velocity
    return _numbers(w.mover_state(mid)) + ((v.x, v.y, v.z),)


def run_kind_case(case: KindCase) -> Outcome:
    """Run one case on its scene's (shared) world; exceptions other than EngineError propagate."""
    w = world(case.scene)
    w.settings = engine.RETAIL if case.preset == "retail" else engine.ACE_COMPAT
    out = Outcome()
    try:
        mid = _add(w, case)
    except EngineError as e:
        out.start_refused = True
        out.answers.append(type(e).__name__)
        return out
    try:
        for move in case.moves:
            out.moves += 1
            before = _mover_state(w, mid)
            try:
                if move.kind == "physics":
                    motion = Vec3(math.cos(move.angle), math.sin(move.angle), 0.0) * (0.5 * move.size)
                    r = w.step(mid, motion, DT)
                else:
                    r = w.move(mid, w.mover(mid).position.moved(_offset(move)))
            except EngineError as e:
                out.refused += 1
                out.answers.append(type(e).__name__)
                if _mover_state(w, mid) != before:
                    out.refusal_changed += 1
                continue
            if not finite_result(r):
                out.nonfinite += 1
            out.answers.append(_numbers(r))
    finally:
        w.remove_mover(mid)
    return out
