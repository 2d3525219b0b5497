"""Outdoor scenarios whose answers are obvious from the geometry."""

from __future__ import annotations

import math

import pytest

import engine
from engine import MoverSpec, Plane, Position, SphereSpec, Vec3
from engine.constants import FLOOR_Z
from benchmarks.scenes import PLAYER, world_from_heights

LB = 0xA9B40000
R = 0.48


def cell_at(x: float, y: float, lb: int = LB) -> int:
    return lb | (int(x // 24) * 8 + int(y // 24) + 1)


def standing(world: engine.World, x: float, y: float, spec: MoverSpec = PLAYER, lb: int = LB) -> int:
    z = world.terrain_height(lb | 1, x, y)
    tri_normal = world.landblocks[lb >> 16].terrain.normal_at(x, y)
    plane = Plane(tri_normal, -tri_normal.dot(Vec3(x, y, z)))
    return world.add_mover(spec, Position.at(cell_at(x, y, lb), Vec3(x, y, z)), plane, cell_at(x, y, lb))


def walk(world: engine.World, mid: int, dx: float, dy: float, steps: int, dz: float = 0.0) -> list[engine.MoveResult]:
    out = []
    for _ in range(steps):
        m = world.mover(mid)
        p = m.position
        out.append(world.move(mid, Position(p.cell_id, p.frame.with_origin(p.frame.origin + Vec3(dx, dy, dz)))))
    return out


def test_standing_still_stays_put() -> None:
    w = world_from_heights(lambda bx, by, x, y: 100)
    mid = standing(w, 50.0, 50.0)
    before = w.mover(mid).position.origin
    r = w.move(mid, w.mover(mid).position)
    assert r.ok and r.position.origin == before and r.contact and r.on_walkable


def test_walking_on_flat_ground_rests_on_it() -> None:
    w = world_from_heights(lambda bx, by, x, y: 100)  # 50 m everywhere
    mid = standing(w, 20.0, 20.0)
    for r in walk(w, mid, 0.3, 0.1, 100):
        assert r.ok and r.contact and r.on_walkable
        assert abs(r.position.origin.z - 50.0) < 1e-4  # sphere bottom = origin z on the ground
    assert math.isclose(w.mover(mid).position.origin.x, 50.0, abs_tol=1e-3)


def test_walking_up_a_walkable_slope_follows_the_surface() -> None:
    # 1 byte (0.5 m) per 24 m column: gradient 1/48, far below the walkable limit
    w = world_from_heights(lambda bx, by, x, y: 60 + x)
    mid = standing(w, 10.0, 100.0)
    for r in walk(w, mid, 0.4, 0.0, 200):
        o = r.position.origin
        assert r.ok and r.contact and r.on_walkable
        assert abs(o.z - w.terrain_height(LB | 1, o.x, o.y)) < 1e-3
    assert w.mover(mid).position.origin.x > 80.0


def test_a_slope_steeper_than_floor_z_cannot_be_walked_up() -> None:
    # columns x >= 4 rise 20 bytes (10 m) per 24 m... make a wall-like ramp: 60 bytes = 30 m per 24 m
    w = world_from_heights(lambda bx, by, x, y: 40 if x <= 3 else min(255, 40 + 60 * (x - 3)))
    n = w.landblocks[0xA9B4].terrain.normal_at(80.0, 100.0)
    assert n.z < FLOOR_Z  # the ramp really is unwalkable
    mid = standing(w, 60.0, 100.0)
    for _ in walk(w, mid, 0.4, 0.0, 200):
        pass
    final = w.mover(mid).position.origin
    # it may creep onto the foot of the slope by less than a sphere, never climb it
    assert final.x < 72.0 + R
    assert final.z < 20.0 + 0.5


def test_walking_downhill_keeps_contact() -> None:
    w = world_from_heights(lambda bx, by, x, y: 120 - 4 * x)  # down 2 m per 24 m east
    mid = standing(w, 10.0, 100.0)
    for r in walk(w, mid, 0.4, 0.0, 300):
        assert r.contact and r.on_walkable
    o = w.mover(mid).position.origin
    assert abs(o.z - w.terrain_height(LB | 1, o.x, o.y)) < 1e-3


def test_walking_off_a_cliff_loses_contact() -> None:
    # plateau at 60 m for x <= 96, then a drop of 40 m within one cell
    w = world_from_heights(lambda bx, by, x, y: 120 if x <= 4 else 40)
    spec = MoverSpec(spheres=PLAYER.spheres, step_up_height=0.4, step_down_height=0.4, state=["Contact", "OnWalkable", "IsPlayer"])
    mid = standing(w, 90.0, 100.0, spec)
    results = walk(w, mid, 0.4, 0.0, 40)
    assert any(not r.contact for r in results)


def test_edge_slide_keeps_a_creature_on_the_plateau() -> None:
    w = world_from_heights(lambda bx, by, x, y: 120 if x <= 4 else 40)
    mid = standing(w, 90.0, 100.0)  # PLAYER has EdgeSlide
    for r in walk(w, mid, 0.4, 0.0, 40):
        assert r.contact
    assert w.mover(mid).position.origin.z > 59.0


@pytest.mark.parametrize(("step_down_height", "steps_down"), [(0.4, False), (0.5, True)])
def test_a_scaled_mover_steps_down_by_its_given_height_not_a_scaled_one(step_down_height: float, steps_down: bool) -> None:
    # Flat at 100 m up to x = 72, then a walkable slope down 21.5 m over 24 m
    # (gradient 0.896, normal z 0.745). Scale 1.25 makes the spheres 0.6 m, so
    # a 0.55 m move is one sub-step, ending 0.5 m past the edge where the
    # ground is 0.448 m lower. A 0.4 m step-down cannot reach it (had the
    # scale multiplied it, 0.5 m would): the edge slide puts the creature back.
    w = world_from_heights(lambda bx, by, x, y: 200 if x <= 3 else 157)
    spec = MoverSpec(
        spheres=PLAYER.spheres,
        step_up_height=0.4,
        step_down_height=step_down_height,
        state=PLAYER.state,
        scale=1.25,
    )
    mid = standing(w, 71.95, 60.0, spec)
    start = w.mover(mid).position
    r = w.move(mid, start.with_origin(Vec3(72.5, 60.0, 100.0)))
    assert r.ok and r.contact and r.on_walkable
    if steps_down:
        assert math.isclose(r.position.origin.x, 72.5, abs_tol=1e-4)
        assert math.isclose(r.position.origin.z, 100.0 - 0.5 * 21.5 / 24.0, abs_tol=1e-4)
        assert r.contact_plane is not None and r.contact_plane.normal.z < 0.75
    else:
        assert (r.position.origin - start.origin).length() < 1e-5
        assert r.contact_plane is not None and r.contact_plane.normal == Vec3(0.0, 0.0, 1.0)


def test_crossing_cells_and_landblocks_keeps_z_continuous() -> None:
    blocks = [(0xA9, 0xB4), (0xAA, 0xB4)]
    w = world_from_heights(lambda bx, by, x, y: 100 + (bx - 0xA9) * 8 * 2 + 2 * x, blocks)  # one smooth ramp
    mid = standing(w, 180.0, 50.0)
    last_z = w.mover(mid).position.origin.z
    for r in walk(w, mid, 0.4, 0.0, 60):
        assert r.ok and r.contact
        z = r.position.origin.z
        assert abs(z - last_z) < 0.05  # 0.4 m at gradient 1/24 rises 1.7 cm
        last_z = z
    final = w.mover(mid).position
    assert final.cell_id >> 16 == 0xAAB4
    assert final.origin.x < 192.0


def test_frames_stationary_fall_builds_a_synthetic_floor_after_three_stuck_frames() -> None:
    # The client's objects work on their own: validate three steps that went nowhere.
    from engine.geometry import Sphere
    from engine.transition.object_info import ObjectInfo
    from engine.transition.state import TransitionState
    from engine.transition.transition import Transition

    w = world_from_heights(lambda bx, by, x, y: 100)
    t = Transition(w)
    t.init_object(ObjectInfo(0))  # gravity on
    t.init_sphere([Sphere(Vec3(0, 0, R), R)], 1.0)
    here = Position.at(cell_at(50, 50), Vec3(50.0, 50.0, 60.0))
    t.init_path(w.get_landcell(here.cell_id), here, here)
    t.sphere_path.set_check_pos(here, t.sphere_path.curr_cell)
    counts = []
    for _ in range(3):
        assert t.validate_transition(TransitionState.OK) == TransitionState.OK
        counts.append(t.collision_info.frames_stationary_fall)
    assert counts == [1, 2, 3]
    ci = t.collision_info
    # a horizontal floor through the sphere's lowest point: z = 60 (centre 60.48 - r)
    assert ci.contact_plane_valid and ci.contact_plane.normal == Vec3(0, 0, 1)
    assert math.isclose(-ci.contact_plane.d, 60.0, abs_tol=1e-5)  # sphere centres are kept in single precision
    assert ci.collision_normal_valid and ci.collided_with_environment  # it was not in contact


def test_a_move_needing_more_than_30_steps_fails_under_the_retail_cap() -> None:
    w = world_from_heights(lambda bx, by, x, y: 100)
    mid = standing(w, 20.0, 20.0)
    start = w.mover(mid).position
    # 0.48 m radius: 15 m needs ceil(31.25) = 32 steps
    r = w.move(mid, start.with_origin(start.origin + Vec3(15.0, 0.0, 0.0)))
    assert not r.ok and r.position.origin == start.origin
    # the reference port's cap lets it through
    w2 = world_from_heights(lambda bx, by, x, y: 100, settings=engine.ACE_COMPAT)
    mid2 = standing(w2, 20.0, 20.0)
    r2 = w2.move(mid2, start.with_origin(start.origin + Vec3(15.0, 0.0, 0.0)))
    assert r2.ok and math.isclose(r2.position.origin.x, 35.0, abs_tol=1e-3)


def test_an_outdoor_camera_follows_its_path_and_stops_against_a_hill() -> None:
    # flat at 50 m up to x = 96, then a hill rising 30 m per 24 m
    w = world_from_heights(lambda bx, by, x, y: 100 if x <= 4 else min(255, 100 + 60 * (x - 4)))
    cam = MoverSpec(spheres=[SphereSpec((0, 0, 0), 0.3)], state=["IsViewer"], gravity=False)
    mid = w.add_mover(cam, Position.at(cell_at(40, 100), Vec3(40.0, 100.0, 52.0)))
    for target_x in (45.0, 50.0, 55.0, 60.0):  # 5 m moves: 17 camera steps, under the cap
        r = w.move(mid, Position.at(cell_at(40, 100), Vec3(target_x, 100.0, 52.0)))
        assert r.ok and math.isclose(r.position.origin.x, target_x, abs_tol=1e-4)  # followed its path
    for target_x in (65.0, 70.0, 75.0, 80.0, 85.0, 90.0, 95.0):
        r = w.move(mid, Position.at(cell_at(40, 100), Vec3(target_x, 100.0, 52.0)))
        assert r.ok and math.isclose(r.position.origin.x, target_x, abs_tol=1e-4)
    # into the hill: its surface is at z = 50 + 30 (x - 96) / 24, so a 0.3 m camera at
    # z = 52 touches it where 50 + 1.25 (x - 96) = 52 - 0.3 / cos: x = 96 + (2 - 0.384) / 1.25 = 97.29
    r = w.move(mid, Position.at(cell_at(95, 100), Vec3(100.0, 100.0, 52.0)))
    x = r.position.origin.x
    assert r.ok and r.collision_normal is not None
    assert 96.5 < x < 97.3


def test_bad_input_is_refused_clearly() -> None:
    w = world_from_heights(lambda bx, by, x, y: 100)
    mid = standing(w, 20.0, 20.0)
    p = w.mover(mid).position
    with pytest.raises(engine.NonFiniteError):
        w.move(mid, p.with_origin(Vec3(float("nan"), 0.0, 0.0)))
    with pytest.raises(engine.LandblockNotLoadedError):
        w.move(mid, Position.at(0x12340001, Vec3(1.0, 1.0, 1.0)))
    with pytest.raises(engine.UnknownCellError):
        w.move(mid, Position.at(LB | 0x0150, Vec3(1.0, 1.0, 1.0)))
    with pytest.raises(engine.UnknownMoverError):
        w.move(999, p)
    assert w.mover(mid).position.origin == p.origin  # nothing lost


def test_an_entry_restriction_keeps_a_mover_out_of_a_cell() -> None:
    from engine.transition.state import TransitionState

    w = world_from_heights(lambda bx, by, x, y: 100)
    refused = []

    def barrier(cell, transition):  # a housing barrier: nobody gets in
        refused.append(cell.id)
        return TransitionState.COLLIDED

    barred = w.get_landcell(cell_at(30.0, 10.0))
    barred.restriction = barrier
    mid = standing(w, 20.0, 10.0)
    for _ in walk(w, mid, 0.4, 0.0, 20):
        pass
    x = w.mover(mid).position.origin.x
    assert refused and x < 24.0  # stopped at the cell boundary (x = 24), never inside
    barred.restriction = None
    for _ in walk(w, mid, 0.4, 0.0, 20):
        pass
    assert w.mover(mid).position.origin.x > 24.0
