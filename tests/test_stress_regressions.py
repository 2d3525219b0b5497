"""Regressions from the stability stress run (benchmarks/stress.py).

Each test is one situation the stress run exercises, reduced to a few
moves with the correct behaviour asserted. Behaviour the engine gets wrong
today is a strict expected failure naming what is wrong, so a fix shows up
at once.
"""

from __future__ import annotations

import copy
import json
import math
import sys
from pathlib import Path

import pytest
from benchmarks.scenes import PLAYER

import engine
from engine import MoverSpec, Plane, Position, SphereSpec, Vec3
from support.shared_data import needs_shared, scene_path

ROOT = Path(__file__).resolve().parent.parent
HEIGHTS = [b * 0.5 for b in range(256)]


def terrain_world(heights, blocks) -> engine.World:
    """Blocks of 9x9 vertices; heights(gx, gy) is the height byte of global vertex (gx, gy)."""
    return engine.world_from_scene_dict({
        "format": "acphys-scene/1",
        "name": "stress-regression",
        "height_table": HEIGHTS,
        "landblocks": [{"id": f"{bx:02X}{by:02X}", "heights": [heights(bx * 8 + x, by * 8 + y) for x in range(9) for y in range(9)]}
                       for bx, by in blocks],
    })


def cell_at(lb: int, x: float, y: float) -> int:
    return lb | (int(x // 24) * 8 + int(y // 24) + 1)


def stand(world: engine.World, spec: MoverSpec, lb: int, x: float, y: float) -> int:
    z = world.terrain_height(lb | 1, x, y)
    n = world.landblocks[lb >> 16].terrain.normal_at(x, y)
    return world.add_mover(spec, Position.at(cell_at(lb, x, y), Vec3(x, y, z)), Plane(n, -n.dot(Vec3(x, y, z))), cell_at(lb, x, y))


def finite(r: engine.MoveResult) -> bool:
    o = r.position.origin
    return all(math.isfinite(c) for c in (o.x, o.y, o.z))


def lowest_above_ground(world: engine.World, mid: int) -> float:
    """Smallest gap between a sphere's lowest point and the terrain under it (negative: below)."""
    m = world.mover(mid)
    lb = m.position.cell_id & 0xFFFF0000
    gaps = []
    for s in m.spheres:
        c = m.position.frame.local_to_global(s.center * m.scale)
        x, y = min(max(c.x, 0.0), 191.999), min(max(c.y, 0.0), 191.999)
        gaps.append(c.z - s.radius * m.scale - world.terrain_height(lb | 1, x, y))
    return min(gaps)


def hills(gx: int, gy: int) -> int:
    return 110 + round(12 * math.sin(gx * 0.9) + 10 * math.cos(gy * 0.7))


def spiky(gx: int, gy: int) -> int:
    return (((gx * 73856093) ^ (gy * 19349663)) >> 3) % 256


# -- the engine's contract on bad mover specs -------------------------------------------------
BAD_SPECS = {
    # what each did before the fix: moves raised ZeroDivisionError; accepted (spheres of negative radius);
    # a plain ValueError from deep in find_cell_list (twice); accepted; accepted
    "scale 0": {"scale": 0.0},
    "negative scale": {"scale": -1.0},
    "NaN scale": {"scale": float("nan")},
    "infinite scale": {"scale": float("inf")},
    "NaN step-up height": {"step_up_height": float("nan")},
    "NaN step-down height": {"step_down_height": float("nan")},
}


# found by the stress run: World.add_mover checked sphere radii but not scale or step heights
@pytest.mark.parametrize("fields", list(BAD_SPECS.values()), ids=list(BAD_SPECS))
def test_a_mover_spec_the_service_would_reject_is_an_engine_error(fields: dict) -> None:
    world = terrain_world(lambda gx, gy: 100, [(0xA9, 0xB4)])
    spec = MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.48), 0.48)], state=["Contact", "OnWalkable", "IsPlayer"], **fields)
    with pytest.raises(engine.EngineError):
        mid = world.add_mover(spec, Position.at(0xA9B40013, Vec3(50.0, 50.0, 50.0)))
        world.move(mid, Position.at(0xA9B40013, Vec3(50.3, 50.0, 50.0)))


# -- moves that must change nothing -------------------------------------------------------------
@pytest.mark.parametrize("offset", [(0.0, 0.0, 0.0), (5e-324, 0.0, 0.0), (1e-300, 1e-300, 0.0), (1e-7, 0.0, 0.0)])
def test_zero_and_vanishing_moves_leave_the_mover_in_place(offset: tuple[float, float, float]) -> None:
    world = terrain_world(hills, [(0xA9, 0xB4)])
    mid = stand(world, PLAYER, 0xA9B40000, 50.0, 50.0)
    before = world.mover(mid).position
    r = world.move(mid, before.moved(Vec3(*offset)))
    assert r.ok and r.transition_state == "NoTransition"
    assert r.position.cell_id == before.cell_id
    assert (r.position.origin - before.origin).length() <= 1e-6  # set to the target, within EPSILON of where it was
    assert r.contact and r.on_walkable


@pytest.mark.parametrize("settings", [engine.RETAIL, engine.ACE_COMPAT], ids=["retail", "ace"])
@pytest.mark.parametrize("offset", [(1e4, 0.0, 0.0), (1e12, 0.0, 0.0), (0.0, 0.0, 1e6), (0.0, 0.0, -1e6)])
def test_absurdly_long_moves_fail_cleanly_and_keep_the_mover(settings: engine.EngineSettings, offset: tuple) -> None:
    # targets beyond the limits (engine.limits: one landblock past the addressed one, |z| <= 10 km) are refused
    world = terrain_world(hills, [(0xA9, 0xB4)])
    world.settings = settings
    mid = stand(world, PLAYER, 0xA9B40000, 50.0, 50.0)
    before = world.mover(mid).position
    with pytest.raises(engine.OutOfRangeError):
        world.move(mid, before.moved(Vec3(*offset)))
    r = world.mover_state(mid)
    assert r.position.origin == before.origin and r.position.cell_id == before.cell_id
    after = world.move(mid, before.moved(Vec3(0.3, 0.0, 0.0)))  # and it walks on afterwards
    assert after.ok and after.contact and finite(after)


# -- the far corner of the world -------------------------------------------------------------------
@pytest.mark.parametrize("heights", [hills, spiky], ids=["hills", "spiky"])
def test_walking_off_the_far_corner_of_the_world_stays_on_the_ground(heights) -> None:
    world = terrain_world(heights, [(0xFE, 0xFE), (0xFF, 0xFE), (0xFE, 0xFF), (0xFF, 0xFF)])
    mid = stand(world, PLAYER, 0xFFFF0000, 180.0, 180.0)
    for i in range(120):
        p = world.mover(mid).position
        r = world.move(mid, p.moved(Vec3(0.3, 0.3 if i % 2 else 0.1, 0.0)))
        assert finite(r)
        assert r.position.cell_id >> 16 in (0xFEFE, 0xFFFE, 0xFEFF, 0xFFFF)
        assert lowest_above_ground(world, mid) > -0.01


# -- tiny and huge spheres -------------------------------------------------------------------------------
@pytest.mark.parametrize(("radius", "heights"), [(0.001, spiky), (0.02, spiky), (15.0, hills), (8.0, spiky)])
def test_tiny_and_huge_spheres_never_sink_into_the_terrain(radius: float, heights) -> None:
    world = terrain_world(heights, [(0xA9, 0xB4)])
    spec = MoverSpec(spheres=[SphereSpec((0.0, 0.0, radius), radius)], step_up_height=min(0.4, radius),
                     step_down_height=min(0.4, radius), state=["Contact", "OnWalkable", "IsPlayer", "EdgeSlide"])
    mid = stand(world, spec, 0xA9B40000, 96.0, 96.0)
    for i in range(80):
        a = i * 0.7
        p = world.mover(mid).position
        r = world.move(mid, p.moved(Vec3(0.5 * math.cos(a), 0.5 * math.sin(a), 0.0)))
        assert finite(r)
        assert lowest_above_ground(world, mid) > -0.01, f"move {i}: {r.position!r}"


# -- degenerate polygons --------------------------------------------------------------------------------
def debris_world() -> engine.World:
    """Flat ground with one box whose solid BSP leaf also lists a zero-area triangle,
    a polygon with a repeated vertex and a polygon of one vertex thrice."""
    ref = json.loads(scene_path("objects").read_text())
    box = copy.deepcopy(ref["gfx_objs"]["01000001"])  # x -1.5..1.5, y -1.25..1.25, z -0.25..1.625
    box["vertices"].update({"8": [-0.5, 0.0, 1.625], "9": [0.0, 0.0, 1.625], "10": [0.5, 0.0, 1.625]})
    extra = {"6": [8, 9, 10], "7": [4, 5, 5, 6], "8": [2, 2, 2]}
    for k, ids in extra.items():
        box["physics_polygons"][k] = {"vertex_ids": ids, "sides_type": 0, "stippling": 0, "pos_surface": 0, "neg_surface": -1}

    def solid_leaf(node: dict) -> dict | None:
        if node["type"] == "LEAF":
            return node if node.get("solid") else None
        return next((leaf for c in ("pos_node", "neg_node") if node.get(c) for leaf in [solid_leaf(node[c])] if leaf), None)

    leaf = solid_leaf(box["physics_bsp"])
    assert leaf is not None
    leaf["in_polys"] = list(leaf["in_polys"]) + [int(k) for k in extra]
    scene = {
        "format": "acphys-scene/1", "name": "debris", "height_table": HEIGHTS,
        "gfx_objs": {"01000099": box},
        "landblocks": [{"id": "A9B4", "heights": [100] * 81,
                        "objects": [{"id": "01000099", "frame": {"origin": [80.0, 80.0, 50.25], "orientation": [1, 0, 0, 0]}}]}],
    }
    return engine.world_from_scene_dict(scene)


@needs_shared
@pytest.mark.parametrize("dy", [0.0, 0.02, -0.3])
def test_degenerate_polygons_in_an_object_neither_crash_nor_let_a_mover_through(dy: float) -> None:
    world = debris_world()
    mid = stand(world, PLAYER, 0xA9B40000, 74.0, 80.0 + dy * 10)
    # the box's -x face: through (78.5, y, 50.0) with outward normal (-0.928477, 0, 0.371391)
    n, v0 = Vec3(-0.928477, 0.0, 0.371391), Vec3(78.5, 0.0, 50.0)
    for _ in range(40):
        p = world.mover(mid).position
        r = world.move(mid, p.moved(Vec3(0.3, dy, 0.0)))
        assert finite(r)
        m = world.mover(mid)
        for s in m.spheres:
            c = m.position.frame.local_to_global(s.center)
            if abs(c.y - 80.0) < 1.0:  # in front of the face, not beside the box
                assert n.dot(c - Vec3(v0.x, c.y, v0.z)) > s.radius - 0.01
    if abs(dy) < 0.1:  # straight at the face: it stops in front of it
        assert world.mover(mid).position.origin.x < 78.5


# -- the harness itself, small ---------------------------------------------------------------------------
@pytest.mark.parametrize("scenario", [pytest.param("debris", marks=needs_shared), "far-edge-FFFF", pytest.param("house", marks=needs_shared), "crowd"])
def test_a_small_stress_run_is_clean(scenario: str) -> None:
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    from benchmarks import stress

    out = stress.run_scenario((scenario, 6, 240, 60.0))
    assert out["moves"] == 240
    assert out["failures"] == []
    assert (out["nonfinite"], out["fall_through"], out["penetration"], out["exceptions"]) == (0, 0, 0, 0)


# -- a long diagonal move past the corner of an opening -------------------------------------------------
#: (scene, floor z, start x, y, offset, wall: plane y, its outward normal's y, x range, the reference's gap).
#: The mover is the reference cases' (house-046-wall, dungeon-033-branch): one sphere of 0.6 m, step
#: heights 0.6. The gap is how far the sphere's surface ends from the wall (negative: inside it), as ACE's
#: physics gives it for the same move (run through the reference, which ends all four within
#: 1e-5 m of the engine's positions; its gaps as reported there, to the millimetre).
CORNER_CASES = {
    # the house room's south wall (y = 105.25, facing +y) runs x 108.75..111.75, a doorway west of it
    "house, 6 m": ("house.json", 112.5, 105.7021, 106.4896, (6.0, -1.8, 0.0), 105.25, 1.0, (108.75, 111.75), -0.015),
    "house, 14 m": ("house.json", 112.5, 105.7021, 106.4896, (13.332247, -3.996451, 0.0), 105.25, 1.0, (108.75, 111.75), -0.027),
    # the dungeon cell's north wall (y = 61.5, facing -y) runs x 65.5..68.0, a branch opening west of it
    "dungeon, 17 m": ("dungeon.json", 52.5, 64.427597, 60.527897, (12.157162, 11.537189, 1.539856), 61.5, -1.0, (65.5, 68.0), -0.026),
    "dungeon, 12 m": ("dungeon.json", 52.5, 63.784363, 60.322327, (10.327619, 6.476041, 0.304598), 61.5, -1.0, (65.5, 68.0), -0.039),
}


@needs_shared
@pytest.mark.parametrize("case", list(CORNER_CASES.values()), ids=list(CORNER_CASES))
def test_a_long_move_past_the_corner_of_an_opening_ends_inside_the_wall_as_the_reference_does(case: tuple) -> None:
    """The client's behaviour, not a bug (docs/divergences.md): the sub-step that crosses the wall's plane
    is in the opening, and the slide along the wall's end never pushes the sphere back out."""
    scene, floor, x, y, offset, wall_y, facing, (x0, x1), reference_gap = case
    world = engine.load_scene(scene_path(scene))
    spec = MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.6), 0.6)], step_up_height=0.6, step_down_height=0.6,
                     state=["Contact", "OnWalkable"], gravity=True)
    cell = 0xA9B40100
    mid = world.add_mover(spec, Position.at(cell, Vec3(x, y, floor)), Plane(Vec3(0.0, 0.0, 1.0), -floor), cell)
    r = world.move(mid, world.mover(mid).position.moved(Vec3(*offset)))
    assert finite(r) and r.ok and r.position.cell_id == cell
    o = r.position.origin
    assert x0 <= o.x <= x1 and o.z == floor  # in front of the wall, on the floor
    gap = (o.y - wall_y) * facing - 0.6
    assert gap == pytest.approx(reference_gap, abs=1e-3), f"{r.position!r}: gap {gap:.4f} m"


@pytest.mark.parametrize("case", list(CORNER_CASES.values()), ids=list(CORNER_CASES))
def test_the_stress_run_counts_the_doorway_corner_overlap_as_the_clients_behaviour(case: tuple) -> None:
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    from benchmarks import stress

    scene, floor, x, y, offset, _wall_y, _facing, _xs, reference_gap = case
    world = engine.load_scene(scene_path(scene))
    spec = MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.6), 0.6)], step_up_height=0.6, step_down_height=0.6,
                     state=["Contact", "OnWalkable"], gravity=True)
    cell = 0xA9B40100
    mid = world.add_mover(spec, Position.at(cell, Vec3(x, y, floor)), Plane(Vec3(0.0, 0.0, 1.0), -floor), cell)
    r = world.move(mid, world.mover(mid).position.moved(Vec3(*offset)))
    centres = stress.sphere_centres(world, mid)
    depth = stress.wall_depth(stress.CellPolys(world), r.position.cell_id, centres)
    assert depth == pytest.approx(-reference_gap, abs=1e-3)  # the stress run's own measure sees the overlap
    assert stress._corner_overlap(r, Vec3(*offset), False, centres, depth)
    # a short move, a physics step, or a deeper overlap would still be a penetration
    assert not stress._corner_overlap(r, Vec3(0.3, 0.0, 0.0), False, centres, depth)
    assert not stress._corner_overlap(r, Vec3(*offset), True, centres, depth)
    assert not stress._corner_overlap(r, Vec3(*offset), False, centres, stress.CORNER_OVERLAP_MAX + 0.01)
