"""Numerical-stability stress: many random moves, every result checked.

Scenarios (each on a deterministic scene): synthetic terrain (flat, hills,
unwalkable ramps, spiky heights, four-landblock seams, the far corner of the
world 0xFE..0xFF and its origin corner 0x00), the reference terrain scenes
(with water), the indoor reference scenes (house, interior, cellar,
dungeon), the crowd of sphere objects, the reference object scene, and a
scene whose static object has degenerate polygons (zero-area, duplicate
vertices).

Movers: the player, tiny spheres (mm to cm) and huge ones (3 to 15 m; not
indoors, where no start is free of the walls), each starting exactly on the
ground (or at a reference start, exactly touching a wall of its room, or
exactly touching a sphere object) and then moved by a seeded mix of ordinary
steps, zero-length and sub-millimetre moves, very long moves, axis-aligned
moves along cell and landblock edges, grazing moves along walls, vertical
drops and jumps, and physics steps with gravity.

Counted after every move:
- non-finite numbers in the result (position, orientation, planes, normals);
- fall-throughs: a sphere's lowest point more than 1 cm below the terrain
  under it (terrain and object scenes, outdoor cells);
- wall penetrations: a sphere crossing the plane of a physics polygon by more
  than 1 cm with its centre's projection inside the polygon, for the EnvCell
  it is in and the cells behind that cell's portals, or reaching more than
  1 cm into a static sphere object - and deeper than before the move;
- exceptions other than the engine's documented input errors.
Each failure is kept with a reproducer (scene, mover, start, moves so far).

A wall overlap of at most 5 cm after a long move that reported a collision
is the client's doorway-corner behaviour (docs/divergences.md), counted as
`corner_overlap` and not as a penetration.

The object-kinds scenario (benchmarks/object_kinds.py, its own move budget)
runs every ObjectInfo kind in odd places under both presets, and counts
also refused moves that changed their mover and cases that answered
differently when run again.
"""

from __future__ import annotations

import copy
import json
import math
import random
import time
import traceback
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from typing import Any

import engine
from engine import MoverSpec, Position, SphereSpec, Vec3
from engine.errors import EngineError
from engine.geometry import Frame

from . import common
from . import scenes as S
from .common import log
from .stress_checks import (CellPolys, crowd_spheres, in_block, inside_polygon, nonfinite, object_depth, sphere_centres,
                           terrain_below, wall_depth)

TOL = 0.01  # 1 cm

#: What earlier stress runs found (other seeds, or before a check or start was added), each now a
#: regression test in tests/test_stress_regressions.py. A run that misses them is not a fix.
FINDINGS = [
    (("one long diagonal move past the corner where a wall meets an opening (house doorway, dungeon branch) "
     "ends with the sphere 1.5-4 cm inside that wall; seeds 6 and 21 of the 1,000,000-move run found it in the "
     "dungeon, a 200,000-move indoor run in the house. The reference (ACE's physics) ends the same moves at the "
     "same positions: the client's behaviour (docs/divergences.md), counted as corner_overlap"),
     "test_a_long_move_past_the_corner_of_an_opening_ends_inside_the_wall_as_the_reference_does"),
    (("World.add_mover accepted a zero, negative, NaN or infinite scale and NaN step heights (moves then raised "
     "ZeroDivisionError or a plain ValueError); fixed in commit 438516b"),
     "test_a_mover_spec_the_service_would_reject_is_an_engine_error"),
    (("the object-kinds fuzz: cameras whose terrain pull-back divided by a zero step raised "
     "OverflowError/ValueError from the outdoor cell search (14 in 32,650 moves); the compiled build raised "
     "TypeError for a two-sphere missile indoors (a narrowed `hit.poly` read in BSPTree.find_collisions)"),
     "tests/test_fuzz_object_kinds.py"),
]
#: a wall overlap that is the client's doorway-corner behaviour, not a penetration: after a move longer
#: than the sphere's radius that reported a collision, at most this deep (docs/divergences.md)
CORNER_OVERLAP_MAX = 0.05
MOVES_PER_MOVER = 60
MAX_FAILURE_RECORDS = 20


# -- scenes --------------------------------------------------------------------------------------
def spiky_heights(gx: int, gy: int) -> int:
    """Deterministic pseudo-random heights over the whole byte range: near-vertical faces."""
    h = (gx * 73856093) ^ (gy * 19349663)
    return (h >> 3) % 256


def debris_scene() -> dict[str, Any]:
    """Flat ground and a few copies of a box whose physics BSP leaf also holds a
    zero-area triangle, a polygon with a repeated vertex and a sliver."""
    ref = json.loads((common.ORACLE / "scenes" / "objects.json").read_text())
    box = copy.deepcopy(ref["gfx_objs"]["01000001"])
    verts = box["vertices"]
    verts.update({"8": [-0.5, 0.0, 1.625], "9": [0.0, 0.0, 1.625], "10": [0.5, 0.0, 1.625],  # collinear
                  "11": [-1.5, -1.25, -0.25], "12": [0.5, 0.75, 1.625000001]})  # duplicates / near-duplicates
    polys = box["physics_polygons"]
    extra = {"6": [8, 9, 10], "7": [4, 5, 5, 6], "8": [0, 11, 3], "9": [6, 12, 7], "10": [2, 2, 2]}
    for k, ids in extra.items():
        polys[k] = {"vertex_ids": ids, "sides_type": 0, "stippling": 0, "pos_surface": 0, "neg_surface": -1}

    def add_to_solid_leaf(node: dict[str, Any]) -> bool:
        if node["type"] == "LEAF":
            if node.get("solid"):
                node["in_polys"] = list(node.get("in_polys", [])) + [int(k) for k in extra]
                return True
            return False
        return any(add_to_solid_leaf(node[c]) for c in ("pos_node", "neg_node") if node.get(c))

    if not add_to_solid_leaf(box["physics_bsp"]):
        raise RuntimeError("the reference box has no solid leaf to add degenerate polygons to")
    scene = S.terrain_scene("stress-debris", S.flat_heights, S.around())
    scene["gfx_objs"] = {"01000099": box}
    objects = []
    for i in range(12):
        x, y = 70.0 + 7.0 * (i % 4), 70.0 + 7.0 * (i // 4)
        a = i * 0.37
        objects.append({"id": "01000099", "frame": {"origin": [x, y, 50.25],
                                                    "orientation": [math.cos(a / 2), 0.0, 0.0, math.sin(a / 2)]}})
    scene["landblocks"][[lb["id"] for lb in scene["landblocks"]].index("A9B4")]["objects"] = objects
    return scene


@dataclass
class Scenario:
    name: str
    build: Callable[[], engine.World]
    home: int  # landblock id (XXYY) whose middle the movers start in, or 0 for trace starts
    terrain_check: bool
    trace: str | None = None
    sphere_objects: bool = False
    #: (x0, y0, x1, y1) in the home landblock where most starts go (where the objects are)
    focus: tuple[float, float, float, float] | None = None


def _terrain(name: str, heights: S.Heights, blocks: list[tuple[int, int]]) -> Callable[[], engine.World]:
    return lambda: engine.world_from_scene_dict(S.terrain_scene(name, heights, blocks))


def _ref(scene: str) -> Callable[[], engine.World]:
    return lambda: engine.load_scene(common.ORACLE / "scenes" / scene)


FAR = [(0xFE, 0xFE), (0xFF, 0xFE), (0xFE, 0xFF), (0xFF, 0xFF)]
ORIGIN = [(0, 0), (1, 0), (0, 1), (1, 1)]
SEAMS = [(0xA9, 0xB4), (0xAA, 0xB4), (0xA9, 0xB5), (0xAA, 0xB5)]

SCENARIOS = [
    Scenario("flat", _terrain("s-flat", S.flat_heights, S.around()), 0xA9B4, True),
    Scenario("hills", _terrain("s-hills", S.hill_heights, S.around()), 0xA9B4, True),
    Scenario("ramps", _terrain("s-ramps", S.steep_heights, S.around()), 0xA9B4, True),
    Scenario("spiky", _terrain("s-spiky", spiky_heights, S.around()), 0xA9B4, True),
    Scenario("seams", _terrain("s-seams", S.seam_heights, SEAMS), 0xA9B4, True),
    Scenario("far-edge-FEFE", _terrain("s-far", S.hill_heights, FAR), 0xFEFE, True),
    Scenario("far-edge-FFFF", _terrain("s-far2", spiky_heights, FAR), 0xFFFF, True),
    Scenario("origin-0000", _terrain("s-origin", S.hill_heights, ORIGIN), 0x0000, True),
    Scenario("ref-rolling", _ref("rolling.json"), 0xA9B4, True),
    Scenario("ref-cliff", _ref("cliff.json"), 0xA9B4, True),
    Scenario("ref-water", _ref("water.json"), 0xA9B4, True),
    Scenario("house", _ref("house.json"), 0, False, trace="house"),
    Scenario("interior", _ref("interior.json"), 0, False, trace="interior"),
    Scenario("cellar", _ref("cellar.json"), 0, False, trace="cellar"),
    Scenario("dungeon", _ref("dungeon.json"), 0, False, trace="dungeon"),
    Scenario("objects", _ref("objects.json"), 0, False, trace="objects"),
    Scenario("crowd", lambda: S.crowd_world(), 0xA9B4, True, sphere_objects=True, focus=(78.0, 86.0, 112.0, 104.0)),
    Scenario("debris", lambda: engine.world_from_scene_dict(debris_scene()), 0xA9B4, True, focus=(64.0, 64.0, 98.0, 90.0)),
    # every ObjectInfo kind in odd places (benchmarks/object_kinds.py): its own worlds and checks
    Scenario("object-kinds", lambda: engine.World(), 0, False),
]


# -- movers and moves --------------------------------------------------------------------------------
def spec_for(label: str) -> MoverSpec:
    """The mover a label names: "player", "tiny r=0.005", "huge r=8.0"."""
    if label == "player":
        return S.PLAYER
    kind, r_text = label.split(" r=")
    r = float(r_text)
    step = r if kind == "tiny" else 0.4
    return MoverSpec(spheres=[SphereSpec((0.0, 0.0, r), r)], step_up_height=step, step_down_height=step,
                     state=["Contact", "OnWalkable", "IsPlayer", "EdgeSlide"], gravity=True)


def mover_spec(rng: random.Random, indoors: bool = False) -> tuple[str, MoverSpec]:
    """A random mover; no huge spheres indoors (they cannot start anywhere in a room without overlapping it)."""
    u = rng.random() * (0.8 if indoors else 1.0)
    if u < 0.6:
        label = "player"
    elif u < 0.8:
        label = f"tiny r={rng.choice([0.001, 0.005, 0.02, 0.05])}"
    else:
        label = f"huge r={rng.choice([3.0, 8.0, 15.0])}"
    return label, spec_for(label)


def _offset(rng: random.Random) -> tuple[str, Vec3]:
    u = rng.random()
    a = rng.uniform(0.0, 2.0 * math.pi)
    if u < 0.45:
        d = rng.uniform(0.05, 0.6)
        return "step", Vec3(d * math.cos(a), d * math.sin(a), 0.0)
    if u < 0.52:
        return "zero", Vec3(0.0, 0.0, 0.0)
    if u < 0.58:
        d = 10.0 ** rng.uniform(-7, -3)
        return "tiny", Vec3(d * math.cos(a), d * math.sin(a), 0.0)
    if u < 0.64:
        d = rng.uniform(5.0, 60.0)
        return "long", Vec3(d * math.cos(a), d * math.sin(a), rng.uniform(-2.0, 2.0))
    if u < 0.67:
        d = rng.uniform(100.0, 400.0)
        return "very-long", Vec3(d * math.cos(a), d * math.sin(a), 0.0)
    if u < 0.80:  # along an axis (cell edges, seams, axis-aligned walls: grazing)
        d = rng.choice([0.1, 0.3, 1.0, 2.4]) * rng.choice([1, -1])
        return "axis", Vec3(d, 0.0, 0.0) if rng.random() < 0.5 else Vec3(0.0, d, 0.0)
    if u < 0.86:  # nearly along an axis: a very shallow angle against walls and edges
        d = rng.uniform(0.1, 1.0)
        e = rng.choice([1e-6, 1e-4, 1e-2]) * rng.choice([1, -1])
        return "grazing", Vec3(d, d * e, 0.0) if rng.random() < 0.5 else Vec3(d * e, -d, 0.0)
    if u < 0.92:
        return "vertical", Vec3(0.0, 0.0, rng.choice([-5.0, -0.5, -0.01, 0.01, 0.5, 3.0]))
    return "diagonal", Vec3(0.3, 0.3, 0.0) * rng.choice([1, -1])


def replay(failure: dict[str, Any]) -> list[engine.MoveResult]:
    """Rebuild a recorded failure (an entry of benchmarks/out/stress_failures.json) and
    replay its moves; the results, the last one being the failing move."""
    if failure["mover"] == "object-kinds":  # the case's repr rebuilds it; no per-move results to give back
        from . import object_kinds as K

        case = eval(failure["case"], {"KindCase": K.KindCase, "Move": K.Move})  # noqa: S307 - our own repr
        K.run_kind_case(case)
        return []
    sc = next(s for s in SCENARIOS if s.name == failure["scenario"])
    world = sc.build()
    spec = spec_for(failure["mover"])
    if "case" in failure:
        assert sc.trace is not None, f"scenario {sc.name} replays no trace"
        case = next(c for c in common.load_trace(sc.trace)["cases"] if c["id"] == failure["case"])
        mid = S.add_case_mover(world, case)
        if spec is not S.PLAYER:
            world.update_mover(mid, spec)
        if "touching" in failure:
            mid = _move_start(world, mid, _case_spec(world, case, spec), Vec3(*failure["touching"]))
    else:
        lb, x, y = failure["start"]
        mid = S.place_on_ground(world, spec, int(lb, 16), x, y)
    out = []
    for kind, off, physics in failure["moves"]:
        v = Vec3(*off)
        if physics:
            out.append(world.step(mid, v * 0.1 if kind != "zero" else Vec3(0.0, 0.0, 0.0), 1.0 / 30.0))
        else:
            out.append(world.move(mid, world.mover(mid).position.moved(v)))
    return out


def _case_spec(world: engine.World, case: dict[str, Any], spec: MoverSpec) -> MoverSpec:
    """The mover a trace start uses: the case's own object for "player", else the drawn spec."""
    if spec is not S.PLAYER:
        return spec
    from engine.formats.trace import mover_spec_from_case

    return mover_spec_from_case(case["object"], getattr(world, "scene", None))


def _move_start(world: engine.World, mid: int, spec: MoverSpec, origin: Vec3) -> int:
    """Re-add a mover at `origin` in its cell, keeping its contact plane (the floor it stood on)."""
    m = world.mover(mid)
    cell, plane, plane_cell = m.position.cell_id, m.contact_plane, m.contact_plane_cell_id
    orientation = m.position.frame.orientation
    world.remove_mover(mid)
    return world.add_mover(spec, Position(cell, Frame(origin, orientation)), plane, plane_cell)


class _Resample(Exception):
    """A start that is not fair (overlapping an object): draw another."""


# -- one scenario, run in a worker ---------------------------------------------------------------
def _touching_wall(world: engine.World, mid: int, polys: CellPolys, rng: random.Random) -> Vec3 | None:
    """An origin in the mover's EnvCell where its lowest sphere exactly touches a wall of that cell, or None."""
    m = world.mover(mid)
    cell_id = m.position.cell_id
    cell = world.get_landcell(cell_id)
    cs = getattr(cell, "cell_struct", None)
    if cs is None or cs.cell_bsp is None or cell is None:
        return None
    low = min(m.spheres, key=lambda s: s.center.z - s.radius)
    r, cz = low.radius * m.scale, low.center.z * m.scale
    walls = [w for w in polys.get(cell_id) if abs(w[0].z) < 0.05]
    rng.shuffle(walls)
    z = m.position.origin.z
    for n, _d, vs, pc, _rad in walls[:6]:
        horiz = Vec3(n.x, n.y, 0.0).normalized_or_none()
        if horiz is None:
            continue
        t = rng.uniform(-0.4, 0.4)
        along = Vec3(-horiz.y, horiz.x, 0.0) * (t * _rad)
        centre = Vec3(pc.x, pc.y, z + cz) + along + horiz * r  # exactly r in front of the wall's plane
        if not inside_polygon(centre, n, vs) or not cs.point_in_cell(cell.pos.frame.global_to_local(centre)):
            continue
        return Vec3(centre.x, centre.y, z)
    return None


def _start(sc: Scenario, world: engine.World, rng: random.Random, spec: MoverSpec, cases: list[dict[str, Any]],
           objects: list[tuple[Vec3, float]], polys: CellPolys | None = None) -> tuple[int, dict[str, Any]]:
    if sc.trace:
        case = rng.choice(cases)
        c = dict(case)
        c["object"] = dict(case["object"])
        mid = S.add_case_mover(world, c)
        if spec is not S.PLAYER:
            world.update_mover(mid, spec)
        where: dict[str, Any] = {"case": case["id"]}
        if polys is not None and rng.random() < 0.35:  # exactly touching a wall of its room instead
            origin = _touching_wall(world, mid, polys, rng)
            if origin is not None:
                mid = _move_start(world, mid, _case_spec(world, case, spec), origin)
                where["touching"] = origin.as_tuple()
        return mid, where
    lb = sc.home << 16
    u = rng.random()
    if u < 0.2:  # exactly on a cell corner / landblock edge
        x, y = rng.choice([24.0, 96.0, 168.0, 191.5, 0.5]), rng.choice([24.0, 72.0, 190.0, 1.0])
    elif sc.focus is not None and u < 0.85:
        x, y = rng.uniform(sc.focus[0], sc.focus[2]), rng.uniform(sc.focus[1], sc.focus[3])
    else:
        x, y = rng.uniform(2.0, 190.0), rng.uniform(2.0, 190.0)
    if objects and rng.random() < 0.5:  # exactly touching a sphere object
        centre, rad = rng.choice(objects)
        a = rng.uniform(0, 2 * math.pi)
        lowest = min(s.center[2] - s.radius for s in spec.spheres)
        rr = spec.spheres[0].radius
        dz = centre.z - (world.terrain_height(lb | 1, centre.x, centre.y) + spec.spheres[0].center[2] - lowest)
        horiz = math.sqrt(max(0.0, (rad + rr) ** 2 - dz * dz))
        x, y = centre.x + horiz * math.cos(a), centre.y + horiz * math.sin(a)
    mid = S.place_on_ground(world, spec, lb, x, y)
    if objects and object_depth(objects, in_block(sphere_centres(world, mid), world.mover(mid).position.cell_id, sc.home)) > 1e-4:
        world.remove_mover(mid)  # overlapping an object from the start: not a fair start
        raise _Resample()
    return mid, {"start": [hex(lb), x, y]}


def run_scenario(args: tuple[str, int, int, float]) -> dict[str, Any]:
    name, seed, n_moves, seconds = args
    sc = next(s for s in SCENARIOS if s.name == name)
    rng = random.Random(seed)
    out = _new_counts(name)
    if name == "object-kinds":
        return run_object_kinds(out, rng, n_moves, seconds)
    try:
        world = sc.build()
    except Exception as e:  # noqa: BLE001
        out["exceptions"] += 1
        out["failures"].append({"kind": "scene-load", "error": f"{type(e).__name__}: {e}",
                                "traceback": traceback.format_exc()[-3000:]})
        return out
    cases = [c for c in common.load_trace(sc.trace)["cases"] if "movers" not in c and "object" in c] if sc.trace else []
    objects: list[tuple[Vec3, float]] = []
    if sc.sphere_objects:
        objects = crowd_spheres()
    polys = CellPolys(world)
    deadline = time.monotonic() + seconds
    zero = Vec3(0.0, 0.0, 0.0)
    while out["moves"] < n_moves and time.monotonic() < deadline:
        label, spec = mover_spec(rng, indoors=sc.trace is not None)
        try:
            mid, start = _start(sc, world, rng, spec, cases, objects, polys)
        except _Resample:
            continue
        except EngineError:
            out["rejected"] += 1
            continue
        except Exception as e:  # noqa: BLE001
            out["exceptions"] += 1
            _record(out, None, "exception-at-start", {"mover": label, "error": f"{type(e).__name__}: {e}", "traceback": traceback.format_exc()[-3000:]})
            continue
        out["movers"] += 1
        history: list[Any] = []
        recorded: set[str] = set()
        obj_before = (object_depth(objects, in_block(sphere_centres(world, mid), world.mover(mid).position.cell_id, sc.home))
                      if objects else 0.0)
        for _ in range(MOVES_PER_MOVER):
            if out["moves"] >= n_moves:
                break
            kind, off = _offset(rng)
            m = world.mover(mid)
            before = m.position
            centres_before = sphere_centres(world, mid)
            physics = rng.random() < 0.15
            history.append([kind, off.as_tuple(), physics])
            out["kinds"][kind] = out["kinds"].get(kind, 0) + 1
            out["moves"] += 1
            try:
                if physics:
                    r = world.step(mid, off * 0.1 if kind not in ("zero",) else zero, 1.0 / 30.0)
                else:
                    r = world.move(mid, before.moved(off))
            except EngineError:
                out["rejected"] += 1
                continue
            except Exception as e:  # noqa: BLE001
                out["exceptions"] += 1
                _record(out, None, "exception", {"mover": label, **start, "before": repr(before), "moves": list(history),
                              "error": f"{type(e).__name__}: {e}", "traceback": traceback.format_exc()[-3000:]})
                break
            out["states"][r.transition_state] = out["states"].get(r.transition_state, 0) + 1
            if r.collision_normal is not None:
                out["collisions"] += 1
            if nonfinite(r):
                out["nonfinite"] += 1
                _record(out, None, "nonfinite", {"mover": label, **start, "before": repr(before), "moves": list(history),
                              "result": repr(r.position)})
                break
            cell_id = r.position.cell_id
            centres = sphere_centres(world, mid)
            if sc.terrain_check and (cell_id & 0xFFFF) < 0x100:
                for c, rad in centres:
                    got = terrain_below(world, cell_id, c)
                    if got is None:
                        continue
                    h, allowance = got
                    below = h - (c.z - rad) - allowance
                    if below > TOL:
                        out["fall_through"] += 1
                        out["max_fall_m"] = max(out["max_fall_m"], below)
                        _record(out, recorded, "fall-through", {"mover": label, **start, "before": repr(before),
                                "moves": list(history), "result": repr(r.position), "below_m": below})
                        break
            if (cell_id & 0xFFFF) >= 0x100 and label == "player":
                cell = world.get_landcell(cell_id)
                cs = getattr(cell, "cell_struct", None)
                if cs is not None and cs.cell_bsp is not None and cell is not None:
                    c0 = centres[0][0]
                    if not cs.point_in_cell(cell.pos.frame.global_to_local(c0)):
                        out["outside_cell"] += 1
                        _record(out, recorded, "outside-cell", {"mover": label, **start, "before": repr(before),
                                "moves": list(history), "result": repr(r.position)})
            # penetrations count when a move takes a sphere more than 1 cm into a wall or an object
            # and deeper than it was before the move (a huge sphere may start overlapping a room)
            depth = wall_depth(polys, cell_id, centres)
            wall_before = wall_depth(polys, cell_id, centres_before) if depth > TOL else 0.0  # same cell's walls
            if depth > TOL and depth > wall_before + 1e-4 and _corner_overlap(r, off, physics, centres, depth):
                out["corner_overlap"] += 1  # the client's own doorway-corner overlap (docs/divergences.md)
            elif depth > TOL and depth > wall_before + 1e-4:
                out["penetration"] += 1
                out["max_penetration_m"] = max(out["max_penetration_m"], depth)
                _record(out, recorded, "wall-penetration", {"mover": label, **start, "before": repr(before),
                        "moves": list(history), "result": repr(r.position), "depth_m": depth, "depth_before_m": wall_before})
            if objects:
                depth = object_depth(objects, in_block(centres, cell_id, sc.home))
                if depth > TOL and depth > obj_before + 1e-4:
                    out["penetration"] += 1
                    out["max_penetration_m"] = max(out["max_penetration_m"], depth)
                    _record(out, recorded, "object-penetration", {"mover": label, **start, "before": repr(before),
                            "moves": list(history), "result": repr(r.position), "depth_m": depth, "depth_before_m": obj_before})
                obj_before = depth
        world.remove_mover(mid)
    return out


#: the counts of one scenario run, summed over workers
COUNTS = ("moves", "movers", "nonfinite", "fall_through", "penetration", "exceptions", "rejected", "collisions",
          "outside_cell", "corner_overlap", "refusal_changed", "nondeterministic")
#: the counts that are failures (any non-zero one fails the run)
FAILURE_COUNTS = ("nonfinite", "fall_through", "penetration", "exceptions", "refusal_changed", "nondeterministic")


def _new_counts(name: str) -> dict[str, Any]:
    out: dict[str, Any] = {"scenario": name, "kinds": {}, "states": {}, "failures": [], "max_fall_m": 0.0,
                           "max_penetration_m": 0.0}
    out.update({k: 0 for k in COUNTS})
    return out


def _corner_overlap(r: engine.MoveResult, off: Vec3, physics: bool, centres: list[tuple[Vec3, float]], depth: float) -> bool:
    """Whether a wall overlap is the client's doorway-corner behaviour: a transition (not a physics step)
    longer than the foot sphere's radius that reported a collision, ending at most CORNER_OVERLAP_MAX deep."""
    radius = min(rad for _c, rad in centres)
    return (not physics and r.collision_normal is not None and off.length() > radius
            and depth <= CORNER_OVERLAP_MAX)


def run_object_kinds(out: dict[str, Any], rng: random.Random, n_moves: int, seconds: float) -> dict[str, Any]:
    """The object-kinds fuzz (benchmarks/object_kinds.py): cases until `n_moves` moves; every fourth case
    run twice to check that it answers the same."""
    from . import object_kinds as K

    deadline = time.monotonic() + seconds
    i = 0
    while out["moves"] < n_moves and time.monotonic() < deadline:
        case = K.random_case(rng)
        i += 1
        out["movers"] += 1
        for m in case.moves:
            out["kinds"][m.kind] = out["kinds"].get(m.kind, 0) + 1
        try:
            got = K.run_kind_case(case)
            again = K.run_kind_case(case) if i % 4 == 0 else None
        except Exception as e:  # noqa: BLE001
            out["moves"] += len(case.moves)
            out["exceptions"] += 1
            _record(out, None, "exception", {"mover": "object-kinds", "case": repr(case), "moves": [],
                                             "error": f"{type(e).__name__}: {e}", "traceback": traceback.format_exc()[-3000:]})
            continue
        out["moves"] += got.moves
        out["rejected"] += got.refused + got.start_refused
        out["nonfinite"] += got.nonfinite
        out["refusal_changed"] += got.refusal_changed
        if again is not None and repr(again.answers) != repr(got.answers):
            out["nondeterministic"] += 1
            _record(out, None, "nondeterministic", {"mover": "object-kinds", "case": repr(case), "moves": []})
        if got.nonfinite or got.refusal_changed:
            _record(out, None, "nonfinite" if got.nonfinite else "refusal-changed",
                    {"mover": "object-kinds", "case": repr(case), "moves": []})
    return out


def _record(out: dict[str, Any], recorded: set[str] | None, kind: str, failure: dict[str, Any]) -> None:
    """Keep a failure (one per mover and kind, MAX_FAILURE_RECORDS per scenario)."""
    if recorded is not None:
        if kind in recorded:
            return
        recorded.add(kind)
    if len(out["failures"]) < MAX_FAILURE_RECORDS:
        out["failures"].append({"kind": kind, **failure})


def run(total_moves: int, seconds: float, jobs: int = 2, seed: int = 6, kinds_moves: int | None = None) -> dict[str, Any]:
    """`total_moves` over the scene scenarios, and `kinds_moves` (default: as many again) of the
    object-kinds fuzz, within `seconds` in all."""
    scenes = [sc for sc in SCENARIOS if sc.name != "object-kinds"]
    kinds_total = total_moves if kinds_moves is None else kinds_moves
    per = max(1, total_moves // len(scenes))
    chunks = max(1, per // 20000)  # split big scenarios so both workers stay busy
    n_scene_tasks = len(scenes) * chunks
    counts = [total_moves // n_scene_tasks + (1 if i < total_moves % n_scene_tasks else 0) for i in range(n_scene_tasks)]
    kinds_chunks = max(1, kinds_total // 20000) if kinds_total > 0 else 0
    kinds_counts = [kinds_total // kinds_chunks + (1 if k < kinds_total % kinds_chunks else 0) for k in range(kinds_chunks)]
    n_tasks = n_scene_tasks + kinds_chunks
    share = seconds / max(1.0, n_tasks / jobs)
    tasks = [(sc.name, seed * 1000003 + i * 7919 + k, counts[i * chunks + k], share)
             for i, sc in enumerate(scenes) for k in range(chunks)]
    tasks += [("object-kinds", seed * 1000003 + len(scenes) * 7919 + k, kinds_counts[k], share) for k in range(kinds_chunks)]
    t0 = time.monotonic()
    results: dict[str, dict[str, Any]] = {}
    with ProcessPoolExecutor(max_workers=jobs) as ex:
        for res in ex.map(run_scenario, tasks):
            agg = results.setdefault(res["scenario"], {k: (0 if isinstance(v, int) else v) for k, v in res.items()
                                                       if k not in ("failures", "kinds", "states")} | {"failures": [], "kinds": {}, "states": {}})
            for k, v in res.items():
                if k in COUNTS:
                    agg[k] += v
                elif k.startswith("max_"):
                    agg[k] = max(agg[k], v)
            for key in ("kinds", "states"):
                for k, v in res[key].items():
                    agg[key][k] = agg[key].get(k, 0) + v
            agg["failures"] += res["failures"][: max(0, MAX_FAILURE_RECORDS - len(agg["failures"]))]
            log(f"stress: {res['scenario']:14s} {res['moves']:8d} moves  nan {res['nonfinite']}  fall {res['fall_through']}"
                f"  pen {res['penetration']}  exc {res['exceptions']}  corner {res['corner_overlap']}"
                f"  refused-changed {res['refusal_changed']}  nondet {res['nondeterministic']}")
    rows = list(results.values())
    totals = {k: sum(r[k] for r in rows) for k in COUNTS}
    return {"requested_moves": total_moves, "seconds_budget": seconds, "jobs": jobs, "seed": seed,
            "elapsed_s": time.monotonic() - t0, "totals": totals, "scenarios": rows}
