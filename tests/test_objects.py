"""Object collisions: movers against spheres, cylspheres, BSP props and each other.

Every world here is flat ground at z = 50 (height byte 100) with obstacles put
straight into the cells' shadow lists; the expected answers come from the
geometry (radii, heights, step-up heights), not from running the engine.
"""

from __future__ import annotations

import json
import math

import pytest

import engine
from engine import MoverSpec, Plane, Position, SphereSpec, Vec3
from engine.constants import EPSILON
from engine.geometry import Frame, Quat, Sphere
from engine.objects.cylsphere_collision import CylSphere
from engine.objects.obstacle import MoverObstacle, Obstacle
from engine.objects.gfx_obj import GfxObj
from engine.objects.setup import ModelLibrary
from engine.objects.sphere_collision import collides_with_sphere, find_time_of_collision
from engine.transition.state import OI
from benchmarks.scenes import PLAYER, world_from_heights
from support.shared_data import needs_shared, scene_path, shared_root

LB = 0xA9B40000
GROUND = 50.0
R = 0.48  # the walkers' sphere radius
HEAD_Z = 1.35  # PLAYER's head sphere centre above its origin
OBJECTS_SCENE = scene_path("objects")

#: a walker that is not a player (players walk through players)
WALKER = MoverSpec(
    spheres=[SphereSpec((0.0, 0.0, R), R), SphereSpec((0.0, 0.0, HEAD_Z), R)],
    step_up_height=0.4,
    step_down_height=0.4,
    state=["Contact", "OnWalkable"],
)
#: a one-sphere walker
BALL = MoverSpec(spheres=[SphereSpec((0.0, 0.0, R), R)], step_up_height=0.4, step_down_height=0.4, state=["Contact", "OnWalkable"])


def cell_at(x: float, y: float) -> int:
    return LB | (int(x // 24) * 8 + int(y // 24) + 1)


def flat_world() -> engine.World:
    return world_from_heights(lambda bx, by, x, y: 100)


def place(world: engine.World, spec: MoverSpec, x: float, y: float) -> int:
    """A mover standing on the ground at (x, y)."""
    return world.add_mover(spec, Position.at(cell_at(x, y), Vec3(x, y, GROUND)), Plane(Vec3(0.0, 0.0, 1.0), -GROUND), cell_at(x, y))


def add(world: engine.World, obstacle: object, x: float, y: float) -> None:
    """Shadow an obstacle into the cell at (x, y) (all tests keep to one cell)."""
    world.get_landcell(cell_at(x, y)).shadow_objects.append(obstacle)


def walk(world: engine.World, mid: int, d: Vec3, n: int) -> list[engine.MoveResult]:
    out = []
    for _ in range(n):
        p = world.mover(mid).position
        out.append(world.move(mid, Position(p.cell_id, p.frame.with_origin(p.frame.origin + d))))
    return out


def sphere_obstacle(x: float, y: float, z: float, r: float, **kw: object) -> Obstacle:
    """A one-sphere obstacle whose sphere is centred at (x, y, z)."""
    return Obstacle(kw.pop("obj_id", 0), Position.at(cell_at(x, y), Vec3(x, y, GROUND)), spheres=[Sphere(Vec3(0.0, 0.0, z - GROUND), r)], **kw)  # type: ignore[arg-type]


def centre_distances(origin: Vec3, centre: Vec3, heights: tuple[float, ...] = (R, HEAD_Z)) -> list[float]:
    return [(Vec3(origin.x, origin.y, origin.z + h) - centre).length() for h in heights]


# -- sphere obstacles ------------------------------------------------------------------


def test_a_tall_sphere_is_slid_around_keeping_the_tangential_motion() -> None:
    w = flat_world()
    centre = Vec3(60.0, 60.0, GROUND + 1.0)  # top at 2 m: far above the 0.4 m step-up
    add(w, sphere_obstacle(centre.x, centre.y, centre.z, 1.0), 60.0, 60.0)
    mid = place(w, WALKER, 56.0, 60.2)  # 0.2 m off the obstacle's centre line
    results = walk(w, mid, Vec3(0.2, 0.0, 0.0), 45)

    first_hit = None
    prev = Vec3(56.0, 60.2, GROUND)
    for i, r in enumerate(results):
        o = r.position.origin
        assert r.ok and r.contact and r.on_walkable
        assert abs(o.z - GROUND) < 1e-4  # it never climbs the sphere
        for dist in centre_distances(o, centre):
            assert dist >= R + 1.0 - 2 * EPSILON - 1e-4  # never inside the obstacle
        if r.collision_normal is not None and first_hit is None:
            first_hit = i
            n = r.collision_normal
            assert n.x < 0.0  # the obstacle pushed back against the walk
            moved = o - prev
            # the slide keeps the motion along the obstacle: the walker moves
            # sideways (to the side it was already off-centre), not into it
            assert moved.y > 0.0
            assert Vec3(n.x, n.y, 0.0).dot(moved) >= -1e-4
        prev = o
    assert first_hit is not None
    final = results[-1].position.origin
    assert final.x > centre.x + 1.0  # it got round
    assert final.y > centre.y + 1.0  # on its own side


def test_a_small_sphere_below_the_step_up_height_is_stepped_onto() -> None:
    w = flat_world()
    centre = Vec3(60.0, 60.0, GROUND + 0.1)  # r = 0.25: top 0.35 m up, within 0.4 m
    top = centre.z + 0.25
    add(w, sphere_obstacle(centre.x, centre.y, centre.z, 0.25), 60.0, 60.0)
    mid = place(w, BALL, 58.0, 60.0)
    # A step-up needs a walkable resting point: the foot sphere must first
    # touch where the line of centres is steeper than FloorZ from horizontal,
    # i.e. less than 0.73 * sqrt(1 - 0.664^2) = 0.55 m from the axis. Strides
    # of 0.3 m first touch at 0.5 m; then small steps walk up to the top.
    results = walk(w, mid, Vec3(0.3, 0.0, 0.0), 5) + walk(w, mid, Vec3(0.05, 0.0, 0.0), 16)
    assert all(r.ok for r in results)
    assert results[3].position.origin.z == GROUND  # 0.8 m from the axis: not touching yet
    on_top = [r for r in results if r.position.origin.z > GROUND + 1e-3]
    assert len(on_top) == 17  # from the fifth stride on
    for r in on_top:
        o = r.position.origin
        assert r.contact and r.on_walkable
        # the foot sphere rests on the obstacle: centres one radius-sum apart
        assert abs(centre_distances(o, centre, (R,))[0] - (R + 0.25)) < 1e-3
        # the contact plane is tangent there (its normal along the line of centres)
        n = r.contact_plane.normal  # type: ignore[union-attr]
        line = (Vec3(o.x, o.y, o.z + R) - centre).normalized_or_none()
        assert line is not None and (n - line).length() < 1e-3
        # the reference records an obstacle's rest plane as a water plane
        assert r.water_contact
    # it reaches the top (its bottom at the obstacle's top), never above it
    peak = max(r.position.origin.z for r in results)
    assert top - 0.002 < peak <= top + 1e-3
    # and walks on over it, going down the far side
    assert results[-1].position.origin.x > centre.x and results[-1].position.origin.z < peak


def test_the_same_sphere_is_not_climbed_with_a_lower_step_up_height() -> None:
    w = flat_world()
    centre = Vec3(60.0, 60.0, GROUND + 0.1)
    add(w, sphere_obstacle(centre.x, centre.y, centre.z, 0.25), 60.0, 60.0)
    low = MoverSpec(spheres=BALL.spheres, step_up_height=0.2, step_down_height=0.4, state=["Contact", "OnWalkable"])
    mid = place(w, low, 58.0, 60.1)
    for r in walk(w, mid, Vec3(0.1, 0.0, 0.0), 40):
        o = r.position.origin
        assert r.ok and abs(o.z - GROUND) < 1e-4
        assert centre_distances(o, centre, (R,))[0] >= R + 0.25 - 2 * EPSILON - 1e-4
    assert w.mover(mid).position.origin.x > 60.5  # slid round it


def test_a_creature_sphere_is_never_stood_on() -> None:
    w = flat_world()
    centre = Vec3(60.0, 60.0, GROUND + 0.1)
    creature = sphere_obstacle(centre.x, centre.y, centre.z, 0.25, obj_id=0x80000001, static=False, is_creature=True)
    add(w, creature, 60.0, 60.0)
    mid = place(w, BALL, 58.0, 60.0)
    # the same strides that step onto a non-creature sphere (test above)
    results = walk(w, mid, Vec3(0.3, 0.0, 0.0), 5) + walk(w, mid, Vec3(0.05, 0.0, 0.0), 16)
    for r in results:
        # head-on against it the walker is stopped (and its later moves fail
        # for want of any motion left after the slide), but never lifted
        assert abs(r.position.origin.z - GROUND) < 1e-4
        assert centre_distances(r.position.origin, centre, (R,))[0] >= R + 0.25 - 2 * EPSILON - 1e-4
    assert any(r.collide_objects == [0x80000001] for r in results)


# -- cylspheres -----------------------------------------------------------------------


def test_a_cylsphere_pillar_is_walked_around() -> None:
    w = flat_world()
    pillar = Obstacle(0, Position.at(cell_at(60.0, 60.0), Vec3(60.0, 60.0, GROUND)), cyl_spheres=[CylSphere(Vec3(0.0, 0.0, 0.0), 0.6, 4.0)])
    add(w, pillar, 60.0, 60.0)
    mid = place(w, WALKER, 56.0, 60.2)
    results = walk(w, mid, Vec3(0.2, 0.0, 0.0), 45)
    hits = 0
    for r in results:
        o = r.position.origin
        assert r.ok and r.contact and abs(o.z - GROUND) < 1e-4
        assert math.hypot(o.x - 60.0, o.y - 60.0) >= 0.6 + R - 2 * EPSILON - 1e-4
        if r.collision_normal is not None:
            hits += 1
            assert r.collision_normal.z == 0.0  # the side of a cylinder is vertical
            assert r.collision_normal.x < 0.0
    assert hits > 0
    final = results[-1].position.origin
    assert final.x > 61.0 and final.y > 60.2


def test_a_low_cylsphere_is_stepped_onto_and_stood_on_its_flat_top() -> None:
    w = flat_world()
    drum = Obstacle(0, Position.at(cell_at(60.0, 60.0), Vec3(60.0, 60.0, GROUND)), cyl_spheres=[CylSphere(Vec3(0.0, 0.0, 0.0), 1.0, 0.3)])
    add(w, drum, 60.0, 60.0)
    mid = place(w, BALL, 57.0, 60.0)
    results = walk(w, mid, Vec3(0.1, 0.0, 0.0), 25)
    assert all(r.ok for r in results)
    up = [r for r in results if r.position.origin.z > GROUND + 1e-3]
    assert up
    for r in up:
        assert abs(r.position.origin.z - (GROUND + 0.3)) < 1e-3  # on the top, 0.3 m up
        assert r.contact and r.on_walkable
        assert r.contact_plane is not None and r.contact_plane.normal.z == 1.0
    assert results[-1].position.origin.z == pytest.approx(GROUND + 0.3, abs=1e-3)


# -- movers against movers ---------------------------------------------------------------


def test_two_sphere_movers_collide_and_slide() -> None:
    w = flat_world()
    a = place(w, BALL, 56.0, 60.3)
    b = place(w, BALL, 60.0, 60.0)
    ma, mb = w.mover(a), w.mover(b)
    # the World shadows each mover into its cells as a MoverObstacle
    shadows = w.get_landcell(cell_at(60.0, 60.0)).shadow_objects
    assert [type(o) for o in shadows] == [MoverObstacle, MoverObstacle]

    results = walk(w, a, Vec3(0.2, 0.0, 0.0), 40)
    touched = [r for r in results if r.collide_objects]
    assert touched and all(r.collide_objects == [b] for r in touched)
    for r in results:
        o = r.position.origin
        assert r.ok and abs(o.z - GROUND) < 1e-4
        assert (o - mb.position.origin).length() >= 2 * R - 2 * EPSILON - 1e-4
    final = results[-1].position.origin
    assert final.x > 61.0 and final.y > 60.3  # slid round b on its own side
    assert mb.position.origin == Vec3(60.0, 60.0, GROUND)  # b was not pushed

    # now b walks into a (standing at its final place) and slides off it too
    back = walk(w, b, Vec3(0.2, 0.0, 0.0), 5)
    assert all(r.ok for r in back)
    for r in back:
        assert (r.position.origin - ma.position.origin).length() >= 2 * R - 2 * EPSILON - 1e-4


def test_a_mover_never_collides_with_its_own_shadow() -> None:
    w = flat_world()
    a = place(w, BALL, 60.0, 60.0)
    add(w, MoverObstacle(w.mover(a)), 60.0, 60.0)  # a second view of it, newest
    results = walk(w, a, Vec3(0.2, 0.0, 0.0), 5)
    assert [round(r.position.origin.x, 4) for r in results] == [60.2, 60.4, 60.6, 60.8, 61.0]
    assert all(not r.collide_objects for r in results)


# -- ethereal, missiles, players ------------------------------------------------------------


def test_an_ethereal_obstacle_is_passed_through_but_recorded() -> None:
    w = flat_world()
    ghost = sphere_obstacle(60.0, 60.0, GROUND + 1.0, 1.0, obj_id=0x80000007, static=False, ethereal=True)
    add(w, ghost, 60.0, 60.0)
    mid = place(w, WALKER, 57.0, 60.0)
    results = walk(w, mid, Vec3(0.2, 0.0, 0.0), 30)
    for i, r in enumerate(results):
        o = r.position.origin
        assert r.ok and r.collision_normal is None
        assert o.x == pytest.approx(57.0 + 0.2 * (i + 1), abs=1e-4) and o.y == pytest.approx(60.0, abs=1e-4)
        overlapping = min(centre_distances(o, Vec3(60.0, 60.0, GROUND + 1.0))) <= R + 1.0 - EPSILON
        if overlapping:
            assert r.collide_objects == [0x80000007]
    assert any(r.collide_objects for r in results)
    assert not results[0].collide_objects  # far away: not touched


def test_an_ethereal_mover_passes_a_live_obstacle_but_not_a_static_one() -> None:
    w = flat_world()
    live = sphere_obstacle(60.0, 60.0, GROUND + 1.0, 1.0, obj_id=0x80000002, static=False)
    add(w, live, 60.0, 60.0)
    rock = sphere_obstacle(64.0, 60.0, GROUND + 1.0, 1.0)
    add(w, rock, 64.0, 60.0)
    ghost = MoverSpec(spheres=WALKER.spheres, state=["Contact", "OnWalkable"], ethereal=True)
    mid = place(w, ghost, 57.0, 60.0)
    results = walk(w, mid, Vec3(0.2, 0.0, 0.0), 30)
    xs = [r.position.origin.x for r in results]
    assert xs[16] == pytest.approx(60.4, abs=1e-4)  # straight through the live one
    assert any(r.collide_objects == [0x80000002] for r in results)
    # the static rock stops (and slides) it like any mover
    for r in results:
        assert min(centre_distances(r.position.origin, Vec3(64.0, 60.0, GROUND + 1.0))) >= R + 1.0 - 2 * EPSILON - 1e-4
    assert max(xs) < 64.0 - 1.0


def test_a_missile_stops_at_the_first_obstacle() -> None:
    w = flat_world()
    z = GROUND + 1.0
    add(w, sphere_obstacle(60.0, 60.0, z, 0.5), 60.0, 60.0)
    add(w, sphere_obstacle(62.0, 60.0, z, 0.5), 60.0, 60.0)
    # a 0.5 m ball: the 8 m flight is 16 sub-steps of 0.5 m (under the 30-step cap)
    arrow = MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.0), 0.5)], state=["PathClipped"], step_down=False, gravity=False)
    mid = w.add_mover(arrow, Position.at(cell_at(56.0, 60.0), Vec3(56.0, 60.0, z)))
    r = w.move(mid, Position.at(cell_at(56.0, 60.0), Vec3(64.0, 60.0, z)))  # one long move through both
    o = r.position.origin
    assert r.ok
    assert o.x <= 60.0 - 1.0 + 1e-4  # short of the first obstacle (radius sum 1 m)
    assert o.x > 60.0 - 1.0 - 0.5 - 1e-3  # within one sub-step of it
    assert o.y == pytest.approx(60.0, abs=1e-6) and o.z == pytest.approx(z, abs=1e-6)
    assert r.collision_normal is not None and r.collision_normal.x == pytest.approx(-1.0, abs=1e-6)


def test_a_missile_hitting_a_live_object_ends_its_flight() -> None:
    # PhysicsObj.track_object_collision: hitting a non-static object clears Missile
    w = flat_world()
    z = GROUND + 1.0
    add(w, sphere_obstacle(60.0, 60.0, z, 0.5, obj_id=0x80000002, static=False), 60.0, 60.0)
    arrow = MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.0), 0.5)], state=["PathClipped"], step_down=False, gravity=False)
    mid = w.add_mover(arrow, Position.at(cell_at(56.0, 60.0), Vec3(56.0, 60.0, z)))
    assert w.mover(mid).missile
    r = w.move(mid, Position.at(cell_at(56.0, 60.0), Vec3(64.0, 60.0, z)))
    assert r.collide_objects == [0x80000002]
    assert not w.mover(mid).missile
    # against a static object the flight ends too, as an environment collision
    w2 = flat_world()
    add(w2, sphere_obstacle(60.0, 60.0, z, 0.5), 60.0, 60.0)
    mid2 = w2.add_mover(arrow, Position.at(cell_at(56.0, 60.0), Vec3(56.0, 60.0, z)))
    r2 = w2.move(mid2, Position.at(cell_at(56.0, 60.0), Vec3(64.0, 60.0, z)))
    assert r2.collision_normal is not None and not w2.mover(mid2).missile


def test_a_player_walks_through_a_player_but_not_an_impenetrable_one() -> None:
    centre = Vec3(60.0, 60.0, GROUND + 0.9)

    def run(**flags: bool) -> list[engine.MoveResult]:
        w = flat_world()
        other = sphere_obstacle(centre.x, centre.y, centre.z, 0.9, obj_id=0x50000002, static=False, is_player=True, is_creature=True, **flags)
        add(w, other, 60.0, 60.0)
        mid = place(w, PLAYER, 57.0, 60.0)
        return walk(w, mid, Vec3(0.2, 0.0, 0.0), 30)

    through = run()
    for i, r in enumerate(through):
        assert r.ok and r.collision_normal is None and not r.collide_objects
        assert r.position.origin.x == pytest.approx(57.0 + 0.2 * (i + 1), abs=1e-4)

    for flags in ({"is_impenetrable": True}, {"is_pk": True}):
        blocked = run(**flags)
        if "is_pk" in flags:
            # only both-PK players collide: this walker is not PK, so it passes
            assert blocked[-1].position.origin.x == pytest.approx(63.0, abs=1e-4)
            continue
        assert any(r.collide_objects == [0x50000002] for r in blocked)
        for r in blocked:
            assert min(centre_distances(r.position.origin, centre)) >= R + 0.9 - 2 * EPSILON - 1e-4


def test_two_pk_players_collide() -> None:
    w = flat_world()
    centre = Vec3(60.0, 60.0, GROUND + 0.9)
    other = sphere_obstacle(centre.x, centre.y, centre.z, 0.9, obj_id=0x50000002, static=False, is_player=True, is_creature=True, is_pk=True)
    add(w, other, 60.0, 60.0)
    pk = MoverSpec(spheres=PLAYER.spheres, step_up_height=0.4, step_down_height=0.4, state=PLAYER.state + ["IsPK"])
    mid = place(w, pk, 57.0, 60.0)
    results = walk(w, mid, Vec3(0.2, 0.0, 0.0), 30)
    assert any(r.collide_objects == [0x50000002] for r in results)
    for r in results:
        assert min(centre_distances(r.position.origin, centre)) >= R + 0.9 - 2 * EPSILON - 1e-4


def test_ignore_creatures_walks_through_a_creature_but_records_it() -> None:
    w = flat_world()
    centre = Vec3(60.0, 60.0, GROUND + 1.0)
    add(w, sphere_obstacle(centre.x, centre.y, centre.z, 1.0, obj_id=0x80000003, static=False, is_creature=True), 60.0, 60.0)
    spec = MoverSpec(spheres=WALKER.spheres, state=["Contact", "OnWalkable", "IgnoreCreatures"])
    mid = place(w, spec, 56.0, 60.0)
    results = walk(w, mid, Vec3(0.2, 0.0, 0.0), 40)
    assert any(r.collide_objects == [0x80000003] for r in results)
    assert all(r.ok and r.collision_normal is None for r in results)
    # the creature's response still moved it, but never stopped it
    assert results[-1].position.origin.x > 61.0


def test_a_viewer_ignores_creatures() -> None:
    w = flat_world()
    add(w, sphere_obstacle(60.0, 60.0, GROUND + 1.0, 1.0, obj_id=0x80000004, static=False, is_creature=True), 60.0, 60.0)
    cam = MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.0), 0.3)], state=["IsViewer"], gravity=False)
    mid = w.add_mover(cam, Position.at(cell_at(57.0, 60.0), Vec3(57.0, 60.0, GROUND + 1.0)))
    r = w.move(mid, Position.at(cell_at(57.0, 60.0), Vec3(63.0, 60.0, GROUND + 1.0)))
    assert r.ok and r.position.origin.x == pytest.approx(63.0, abs=1e-4) and not r.collide_objects


# -- BSP props and scene setups -----------------------------------------------------------------


@pytest.fixture(scope="module")
def library() -> ModelLibrary:
    shared_root()  # skips without the shared material
    return ModelLibrary(json.loads(OBJECTS_SCENE.read_text()))


def test_setup_shapes_follow_the_scene(library: ModelLibrary) -> None:
    pillar = library.setup("02000001")
    assert pillar is not None and not pillar.has_physics_bsp and not pillar.spheres
    (cyl,) = pillar.cyl_spheres
    assert (cyl.low_point, cyl.radius, cyl.height) == (Vec3(0.0, 0.0, 0.0), 0.59375, 4.0)
    cluster = library.setup("02000005")
    assert cluster is not None and len(cluster.spheres) == 3 and cluster.spheres[2].radius == 0.5
    box = library.setup("01000003")  # a bare GfxObj: one part at the object's frame
    assert box is not None and box.has_physics_bsp and box.placement_frames == [None]
    (gfx,) = box.part_gfx
    assert isinstance(gfx, GfxObj) and gfx.physics_sphere is not None and gfx.physics_sphere.radius == pytest.approx(3.6243)
    assert library.setup("01000003") is box  # built once


def test_setup_placement_frame_resting_then_default_and_default_scale() -> None:
    frame = {"origin": [1.0, 0.0, 0.0], "orientation": [1.0, 0.0, 0.0, 0.0]}
    resting = {"origin": [0.0, 2.0, 0.0], "orientation": [1.0, 0.0, 0.0, 0.0]}
    scene = {
        "gfx_objs": {"01000009": {"vertices": {}}},
        "setups": {
            "02000009": {"parts": ["01000009"], "placement_frames": {"0": {"frames": [frame]}, "101": {"frames": [resting]}}, "default_scale": [[2.0, 2.0, 3.0]]},
            "0200000A": {"parts": ["01000009"], "placement_frames": {"0": {"frames": [frame]}}},
            "0200000B": {"parts": []},
        },
    }
    lib = ModelLibrary(scene)
    s9 = lib.setup("02000009")
    assert s9 is not None and s9.placement_frames[0].origin == Vec3(0.0, 2.0, 0.0) and s9.default_scales[0] == Vec3(2.0, 2.0, 3.0)
    sa = lib.setup("0200000A")
    assert sa is not None and sa.placement_frames[0].origin == Vec3(1.0, 0.0, 0.0) and sa.default_scales[0] == Vec3(1.0, 1.0, 1.0)
    assert lib.setup("0200000B") is None
    assert lib.obstacle("0200000B", Position.at(cell_at(1.0, 1.0), Vec3(1.0, 1.0, 0.0))) is None
    # a part's place follows the object: frame combined, offset scaled by the object's scale
    ob = sa.make_obstacle(0, Position.at(cell_at(20.0, 20.0), Vec3(20.0, 20.0, 5.0)), scale=2.0)
    (part,) = ob.parts
    assert part.pos.frame.origin == Vec3(22.0, 20.0, 5.0)
    assert part.gfx_scale == Vec3(2.0, 2.0, 2.0)
    ob.position = Position.at(cell_at(10.0, 10.0), Vec3(10.0, 10.0, 5.0), Quat.from_heading(90.0))  # the part follows a move
    ob.place_parts()
    pp = part.pos
    expected = Frame(Vec3(10.0, 10.0, 5.0), Quat.from_heading(90.0)).local_to_global(Vec3(2.0, 0.0, 0.0))
    assert (pp.frame.origin - expected).length() < 1e-9


def test_a_bsp_box_stops_a_walker_at_its_wall(library: ModelLibrary) -> None:
    w = flat_world()
    box = library.obstacle("01000003", Position.at(cell_at(60.0, 60.0), Vec3(60.0, 60.0, GROUND)))  # 5 x 5 x 1.5 m
    add(w, box, 60.0, 60.0)
    mid = place(w, WALKER, 55.0, 60.0)
    results = walk(w, mid, Vec3(0.2, 0.0, 0.0), 20)
    wall = 60.0 - 2.5 - R  # where the walker's sphere touches the box's west face
    for r in results:
        assert r.position.origin.x <= wall + 1e-3
    assert results[-1].position.origin.x == pytest.approx(wall, abs=0.05)
    normals = [r.collision_normal for r in results if r.collision_normal is not None]
    assert normals and all(n.x == pytest.approx(-1.0, abs=1e-6) for n in normals)


def test_a_low_bsp_platform_is_stepped_onto(library: ModelLibrary) -> None:
    w = flat_world()
    platform = library.obstacle("01000002", Position.at(cell_at(60.0, 60.0), Vec3(60.0, 60.0, GROUND)))  # 4 x 3 x 0.3125 m
    add(w, platform, 60.0, 60.0)
    mid = place(w, WALKER, 56.0, 60.0)
    results = walk(w, mid, Vec3(0.2, 0.0, 0.0), 15)
    assert all(r.ok for r in results)
    assert results[-1].position.origin.z == pytest.approx(GROUND + 0.3125, abs=1e-3)
    assert results[-1].on_walkable


# -- the sphere helpers on their own ---------------------------------------------------------------


def test_touching_counts_as_colliding() -> None:
    assert collides_with_sphere(Vec3(1.0, 0.0, 0.0), 1.0)
    assert not collides_with_sphere(Vec3(1.0, 0.0, 0.001), 1.0)


def test_time_of_collision_keeps_the_reference_sign() -> None:
    # moving 2 m straight at a sphere 3 m away with radius sum 2: contact after
    # half the move; the reference reports it as a negative fraction
    assert find_time_of_collision(Vec3(2.0, 0.0, 0.0), Vec3(-3.0, 0.0, 0.0), 2.0) == pytest.approx(-0.5)
    assert find_time_of_collision(Vec3(0.0, 0.0, 0.0), Vec3(-3.0, 0.0, 0.0), 2.0) == -1.0  # no motion
    assert find_time_of_collision(Vec3(2.0, 0.0, 0.0), Vec3(-1.0, 0.0, 0.0), 2.0) == -1.0  # already overlapping
    assert find_time_of_collision(Vec3(0.0, 2.0, 0.0), Vec3(-3.0, 0.0, 0.0), 2.0) == -1.0  # passes by


def test_obstacle_flags_for_static_dat_objects_and_ignore_collisions() -> None:
    ob = Obstacle(0, Position.at(cell_at(1.0, 1.0), Vec3(1.0, 1.0, 0.0)))
    assert ob.static and ob.dat_object and not ob.has_physics_bsp
    live = Obstacle(5, Position.at(cell_at(1.0, 1.0), Vec3(1.0, 1.0, 0.0)), static=False)
    assert not live.dat_object

    w = flat_world()
    gone = sphere_obstacle(60.0, 60.0, GROUND + 1.0, 1.0, obj_id=0x80000009, static=False, ethereal=True, ignore_collisions=True)
    add(w, gone, 60.0, 60.0)
    mid = place(w, WALKER, 57.0, 60.0)
    assert all(not r.collide_objects for r in walk(w, mid, Vec3(0.2, 0.0, 0.0), 30))
    assert OI.IS_PLAYER == 0x100


@needs_shared
def test_scene_objects_become_obstacles_in_their_cells() -> None:
    w = engine.load_scene(OBJECTS_SCENE)
    # the cylsphere pillar (Setup 02000001) stands at (84, 84) of A9B4, unscaled
    pillar_cell = w.get_landcell(0xA9B40000 | (3 * 8 + 3 + 1))
    pillars = [o for o in pillar_cell.shadow_objects if isinstance(o, Obstacle) and o.cyl_spheres]
    assert len(pillars) == 1
    p = pillars[0]
    assert p.static and p.dat_object and p.id == 0 and p.scale == 1.0
    assert p.position.frame.origin == Vec3(84.0, 84.0, 112.5)
    assert [(c.radius, c.height) for c in p.cyl_spheres] == [(0.59375, 4.0)]


def test_missile_ignore_rules() -> None:
    from engine.objects.obstacle import missile_ignore
    from engine.transition.object_info import ObjectInfo

    class Mover:  # the mover behind the transition
        def __init__(self, missile: bool) -> None:
            self.id = 0x50000001
            self.missile = missile

    here = Position.at(cell_at(1.0, 1.0), Vec3(1.0, 1.0, 0.0))
    flying = Obstacle(0x80000001, here, static=False, missile=True)
    walker = ObjectInfo(OI.CONTACT, obj=Mover(False))
    player = ObjectInfo(OI.CONTACT | OI.IS_PLAYER, obj=Mover(False))
    assert missile_ignore(walker, flying)  # non-players ignore missiles
    assert not missile_ignore(player, flying)  # an untargeted missile hits a player
    aimed_elsewhere = Obstacle(0x80000001, here, static=False, missile=True, projectile_target_id=0x50000009)
    aimed_here = Obstacle(0x80000001, here, static=False, missile=True, projectile_target_id=0x50000001)
    assert missile_ignore(player, aimed_elsewhere) and not missile_ignore(player, aimed_here)

    arrow = ObjectInfo(OI.PATH_CLIPPED, obj=Mover(True))
    creature = Obstacle(0x80000002, here, static=False, is_creature=True)
    ghost = Obstacle(0x80000003, here, static=False, ethereal=True)
    rock = Obstacle(0, here)  # a dat object: no weenie, never ignored
    assert not missile_ignore(arrow, creature)  # no target: creatures are hit
    assert missile_ignore(arrow, ghost)
    assert not missile_ignore(arrow, Obstacle(0, here, ethereal=True))
    arrow.target_id = 0x80000009
    assert missile_ignore(arrow, creature)  # aimed at someone else: creatures are passed
    arrow.target_id = 0x80000002
    assert not missile_ignore(arrow, creature)  # ...but not the target
    assert not missile_ignore(arrow, rock)


def test_a_cylsphere_object_on_a_cell_corner_is_in_all_four_cells() -> None:
    # ACE registers a cylsphere object in every cell a sphere of its radius at
    # its low point touches; a pillar on the corner of four cells touches four
    from benchmarks.scenes import HEIGHT_TABLE

    scene = {
        "format": "acphys-scene/1",
        "height_table": HEIGHT_TABLE,
        "gfx_objs": {"01000001": {"vertices": {}}},
        "setups": {
            "02000001": {
                "parts": ["01000001"],
                "cyl_spheres": [{"origin": [0.0, 0.0, 0.0], "radius": 0.6, "height": 4.0}],
                "spheres": [],
            }
        },
        "landblocks": [
            {
                "id": "A9B4",
                "heights": [100] * 81,
                "objects": [{"id": "02000001", "frame": {"origin": [48.0, 48.0, 50.0], "orientation": [1, 0, 0, 0]}}],
            }
        ],
    }
    w = engine.world_from_scene_dict(scene)
    holding = sorted(c.id & 0xFFFF for c in w.landblocks[0xA9B4].cells if c.shadow_objects)
    # cells (1,1), (1,2), (2,1), (2,2) around the corner (48, 48): indexes cx*8+cy+1
    assert holding == sorted([1 * 8 + 1 + 1, 1 * 8 + 2 + 1, 2 * 8 + 1 + 1, 2 * 8 + 2 + 1])
