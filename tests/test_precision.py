"""The precision setting (EngineSettings.single_precision) in both values.

Every routine the client computes in float32 is written once and rounds each
operation through `fl(x, single)`. Here each is run in both precisions; the
expected values are worked out by hand, or with numpy's float32 arithmetic
written out in the order of the client's expressions, or from the geometry
(where a sphere must stop against a wall). test_single_precision.py holds the
float32 side's bit-for-bit checks against the reference's numbers.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import engine
from engine import MoverSpec, Plane, Position, SphereSpec, Vec3
from engine.constants import EPSILON
from engine.geometry import Frame, Quat, Sphere
from engine.geometry.precision import fl, fl_cross, fl_dot, fl_normalize_check_small, fl_place, fl_plane_dist
from engine.objects.cylsphere_collision import CylSphere
from engine.objects.obstacle import Obstacle
from engine.terrain.triangle import TerrainTriangle
from engine.transition.sphere_path import SpherePath
from engine.transition.transition import Transition
from engine.world.mover import Mover
from engine.world.transient import TS
from benchmarks.scenes import world_from_heights
from test_objects import GROUND, cell_at, walk

F = np.float32
SINGLE = engine.ACE_COMPAT
DOUBLE = dataclasses.replace(engine.ACE_COMPAT, single_precision=False)
BOTH = pytest.mark.parametrize("settings", [SINGLE, DOUBLE], ids=["single", "double"])

# -- the rounding and the vector helpers -------------------------------------------------


def test_fl_rounds_to_float32_only_when_single() -> None:
    assert fl(0.1, True) == 0.10000000149011612  # the float32 nearest 0.1
    assert fl(0.1, False) == 0.1
    # ties go to even: 1 + 2**-24 is halfway between 1 and 1 + 2**-23, 1 + 3 * 2**-24
    # halfway between 1 + 2**-23 (odd) and 1 + 2**-22 (even)
    assert fl(1.0 + 2.0**-24, True) == 1.0
    assert fl(1.0 + 3 * 2.0**-24, True) == 1.0 + 2.0**-22
    assert fl(1.0 + 2.0**-24, False) == 1.0 + 2.0**-24


def test_dot_cross_and_distance_keep_the_low_bits_only_in_double() -> None:
    # (1 + 2**-12)**2 = 1 + 2**-11 + 2**-24: the last term is half a float32 step,
    # and the tie goes to the even 1 + 2**-11
    a = 1.0 + 2.0**-12
    assert fl_dot(a, 0.0, 0.0, a, 0.0, 0.0, True) == 1.0 + 2.0**-11
    assert fl_dot(a, 0.0, 0.0, a, 0.0, 0.0, False) == 1.0 + 2.0**-11 + 2.0**-24
    assert fl_cross(Vec3(0.0, a, 0.0), Vec3(0.0, 0.0, a), True) == Vec3(1.0 + 2.0**-11, 0.0, 0.0)
    assert fl_cross(Vec3(0.0, a, 0.0), Vec3(0.0, 0.0, a), False) == Vec3(1.0 + 2.0**-11 + 2.0**-24, 0.0, 0.0)
    up = Plane(Vec3(0.0, 0.0, a), -1.0)
    assert fl_plane_dist(0.0, 0.0, a, up, True) == 2.0**-11
    assert fl_plane_dist(0.0, 0.0, a, up, False) == 2.0**-11 + 2.0**-24


def test_normalize_multiplies_by_the_rounded_reciprocal() -> None:
    # (3, 4, 0) / 5 as the client does it: times 1/5. 4 * 0.2 is exact in both
    # precisions; 3 * 0.2 is 0.6000000000000001 in double, 0.6f in float32
    assert fl_normalize_check_small(Vec3(3.0, 4.0, 0.0), False) == Vec3(3 * 0.2, 0.8, 0.0)
    assert fl_normalize_check_small(Vec3(3.0, 4.0, 0.0), True) == Vec3(float(F(0.6)), float(F(0.8)), 0.0)
    assert fl_normalize_check_small(Vec3(EPSILON / 2, 0.0, 0.0), False) is None


@pytest.mark.parametrize(("single", "tol"), [(True, 1e-5), (False, 1e-12)])
def test_an_obstacle_point_is_placed_at_the_working_precision(single: bool, tol: float) -> None:
    # a quarter turn about z at (100.3, 50.7, 20.1), scale 1.5, the point (0.48, 0.1, 1.35):
    # (x, y, z) -> (-y, x, z) * 1.5 + origin
    s = math.sqrt(0.5)
    pos = Position(0xA9B40101, Frame(Vec3(100.3, 50.7, 20.1), Quat(s, 0.0, 0.0, s)))
    p = fl_place(0xA9B40101, pos, Vec3(0.48, 0.1, 1.35), 1.5, single)
    assert p.as_tuple() == pytest.approx((100.3 - 0.15, 50.7 + 0.72, 20.1 + 2.025), abs=tol)
    assert all(float(F(c)) == c for c in p.as_tuple()) == single


# -- planes ----------------------------------------------------------------------------------


def test_a_terrain_plane_at_each_precision() -> None:
    v0, v1, v2 = Vec3(0.0, 0.0, 100.0), Vec3(24.0, 0.0, 103.0), Vec3(24.0, 24.0, 101.0)
    tri = TerrainTriangle(v0, v1, v2)
    assert tri.plane_at(True) is tri.plane
    # by hand: (v1 - v0) x (v2 - v0) = (24, 0, 3) x (24, 24, 1) = (-72, 48, 576)
    n = np.array([-72.0, 48.0, 576.0])
    n = n / math.sqrt(72.0**2 + 48.0**2 + 576.0**2)
    d = -sum(float(np.dot(n, [v.x, v.y, v.z])) for v in (v0, v1, v2)) / 3
    double = tri.plane_at(False)
    assert double.normal.as_tuple() == pytest.approx(tuple(n), abs=1e-15)
    assert double.d == pytest.approx(d, abs=1e-12)
    # the float32 plane is within float32 rounding of it, and not equal
    assert tri.plane.normal.as_tuple() == pytest.approx(tuple(n), abs=1e-7)
    assert tri.plane.d == pytest.approx(d, abs=2e-5)
    assert tri.plane != double
    assert tri.plane_at(False) is double  # computed once


# -- the sphere path ---------------------------------------------------------------------------


@BOTH
def test_the_path_spheres_and_their_shifts_are_kept_at_the_working_precision(settings: engine.EngineSettings) -> None:
    single = settings.single_precision
    path = SpherePath()
    path.single_precision = settings.single_precision
    path.init_sphere([Sphere(Vec3(0.0, 0.0, 0.3), 0.3)], 1.1)
    assert path.local_sphere[0].radius == (float(F(0.3) * F(1.1)) if single else 0.3 * 1.1)
    origin = Vec3(float(F(10.3)), float(F(20.7)), float(F(30.1)))
    pos = Position(0xA9B40001, Frame(origin))
    path.init_path(None, pos, pos)
    path.set_check_pos(pos, None)
    path.add_offset_to_check_pos(Vec3(0.1, 0.1, 0.1))
    got = path.check_pos.frame.origin
    if single:
        assert got == Vec3(float(F(origin.x) + F(0.1)), float(F(origin.y) + F(0.1)), float(F(origin.z) + F(0.1)))
    else:
        assert got == Vec3(origin.x + 0.1, origin.y + 0.1, origin.z + 0.1)


@pytest.mark.parametrize(("settings", "tol"), [(SINGLE, 1e-6), (DOUBLE, 1e-12)], ids=["single", "double"])
def test_local_space_spheres_in_a_turned_cell(settings: engine.EngineSettings, tol: float) -> None:
    # a cell at (10, 20, 30) turned a quarter about z; a sphere centred at (11, 20, 30.5)
    # is at (1, 0, 0.5) from the origin, which the inverse turn takes to (0, -1, 0.5)
    path = SpherePath()
    path.single_precision = settings.single_precision
    path.init_sphere([Sphere(Vec3(0.0, 0.0, 0.5), 0.5)], 1.0)
    mover = Position(0xA9B40001, Frame(Vec3(11.0, 20.0, 30.0)))
    path.init_path(None, mover, mover)
    path.set_check_pos(mover, None)
    s = math.sqrt(0.5)
    cell = Position(0xA9B40001, Frame(Vec3(10.0, 20.0, 30.0), Quat(s, 0.0, 0.0, s)))
    path.cache_local_space_sphere(cell, 1.0)
    assert path.local_space_sphere[0].center.as_tuple() == pytest.approx((0.0, -1.0, 0.5), abs=tol)
    assert path.local_space_z.as_tuple() == pytest.approx((0.0, 0.0, 1.0), abs=tol)


def test_adjust_offset_lifts_onto_the_contact_plane_in_double() -> None:
    """The double-precision counterpart of test_single_precision's AdjustOffset
    test: the same sunk sphere is lifted by (r - dist) / n.z with every
    operation in float64 (there it lands one float32 step lower)."""
    r = 0.5
    fc = [float(F(x)) for x in (116.38134, 44.4162254, 113.96586)]
    fn = [float(F(x)) for x in (-0.296811551, -0.09893719, 0.949797034)]
    d = float(F(-68.86029))
    dist = ((fc[0] * fn[0] + fc[1] * fn[1]) + fc[2] * fn[2]) + d
    expected_z = fc[2] + (r - dist) / fn[2]
    cell = 0xA9B40022
    t = Transition(None, DOUBLE)
    path = t.sphere_path
    path.init_sphere([Sphere(Vec3(0.0, 0.0, r), r)], 1.0)
    pos = Position(cell, Frame(Vec3(fc[0], fc[1], fc[2] - r)))
    path.init_path(None, pos, pos)
    path.set_check_pos(pos, None)
    t.init_contact_plane(cell, Plane(Vec3(*fn), d), False)
    assert t.adjust_offset(Vec3(0.0, 0.0, 0.0)) == Vec3(0.0, 0.0, 0.0)
    assert path.global_sphere[0].center.z == expected_z
    assert float(F(expected_z)) != expected_z  # not a float32: nothing rounded it


# -- the physics step ------------------------------------------------------------------------


@BOTH
def test_a_falling_step(settings: engine.EngineSettings) -> None:
    # airborne, 1.1 m/s along x, gravity -9.8: over 0.1 s it moves
    # v q + a / 2 q^2 = (0.11, 0, -0.049) and its velocity gains a q = -0.98 in z
    mover = Mover(1, [])
    mover.position = Position(0xA9B40001, Frame(Vec3(10.0, 10.0, 60.0)))
    mover.calc_acceleration()
    mover.velocity = Vec3(1.1, 0.0, 0.0)
    frame = mover.integrate(Vec3(0.0, 0.0, 0.0), 0.1, settings)
    o = frame.origin
    if settings.single_precision:
        q = F(0.1)
        half_g = F(-9.8) * F(0.5)
        assert o == Vec3(float(F(10.0) + F(1.1) * q), 10.0, float(F(60.0) + half_g * q * q))
        assert mover.velocity == Vec3(float(F(1.1)), 0.0, float(F(-9.8) * q))
    else:
        assert o.as_tuple() == pytest.approx((10.11, 10.0, 60.0 - 0.049), abs=1e-13)
        assert mover.velocity.as_tuple() == pytest.approx((1.1, 0.0, -0.98), abs=1e-13)
        assert o.x != float(F(o.x))


def test_friction_in_double_precision() -> None:
    # friction 0.95 over 1 s: the speed is scaled by 1 - 0.95 = 0.050000000000000044
    # in double (0.050000011920928955 in float32, test_offset_replay)
    mover = Mover(1, [])
    mover.transient = TS.ACTIVE | TS.CONTACT | TS.ON_WALKABLE
    mover.contact_plane = Plane(Vec3(0.0, 0.0, 1.0), 0.0)
    mover.calc_acceleration()
    mover.velocity = Vec3(1.0, 0.0, 0.0)
    frame = mover.integrate(Vec3(0.0, 0.0, 0.0), 1.0, DOUBLE)
    assert mover.velocity == Vec3(1.0 - 0.95, 0.0, 0.0)
    assert frame.origin == Vec3(1.0 - 0.95, 0.0, 0.0)


def test_a_bounce_in_double_precision() -> None:
    # falling at 2.94 m/s onto a wall tilted 0.6/0.8: the normal part -2.352 is
    # reversed with elasticity 0.05: + 1.05 * 2.352 = 2.4696 along the normal
    mover = Mover(1, [])
    mover.velocity = Vec3(0.0, 0.0, -2.94)
    v = mover._bounce(Vec3(0.6, 0.0, 0.8), False)
    assert v.as_tuple() == pytest.approx((0.6 * 2.4696, 0.0, -2.94 + 0.8 * 2.4696), abs=1e-14)


# -- collisions with objects, whole moves ---------------------------------------------------------


def _flat(settings: engine.EngineSettings) -> engine.World:
    return world_from_heights(lambda bx, by, x, y: 100, settings=settings)


@pytest.mark.parametrize(("settings", "tol"), [(SINGLE, 1e-5), (DOUBLE, 1e-9)], ids=["single", "double"])
def test_a_perfect_clip_missile_stops_where_it_meets_a_cylinder(settings: engine.EngineSettings, tol: float) -> None:
    """CylSphere.CollideWithPoint with PerfectClip: the check position goes back
    to where the sphere touches the wall, 0.6 + 0.5 m from the axis."""
    w = _flat(settings)
    z = GROUND + 1.0
    pillar = Obstacle(0, Position.at(cell_at(60.0, 60.0), Vec3(60.0, 60.0, GROUND)), cyl_spheres=[CylSphere(Vec3(0.0, 0.0, 0.0), 0.6, 4.0)])
    w.get_landcell(cell_at(60.0, 60.0)).shadow_objects.append(pillar)
    arrow = MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.0), 0.5)], state=["PathClipped", "PerfectClip"], step_down=False, gravity=False)
    mid = w.add_mover(arrow, Position.at(cell_at(56.0, 60.0), Vec3(56.0, 60.0, z)))
    r = w.move(mid, Position.at(cell_at(56.0, 60.0), Vec3(64.0, 60.0, z)))
    o = r.position.origin
    assert r.ok
    assert o.as_tuple() == pytest.approx((60.0 - 1.1, 60.0, z), abs=tol)
    assert r.collision_normal is not None
    assert r.collision_normal.as_tuple() == pytest.approx((-1.0, 0.0, 0.0), abs=tol)


@pytest.mark.parametrize(("settings", "tol"), [(SINGLE, 1e-4), (DOUBLE, 1e-9)], ids=["single", "double"])
def test_a_ball_slides_round_another_object_sphere(settings: engine.EngineSettings, tol: float) -> None:
    """Sphere.SlideSphere (object variant): a ball walked into a standing
    sphere keeps its distance (the radius sum less the EPSILON allowances)
    and ends up past it on its own side."""
    w = _flat(settings)
    radius = 0.48
    ball = MoverSpec(spheres=[SphereSpec((0.0, 0.0, radius), radius)], step_up_height=0.4, step_down_height=0.4, state=["Contact", "OnWalkable"])
    rock = Vec3(60.0, 60.0, GROUND + 1.0)
    obstacle = Obstacle(0, Position.at(cell_at(60.0, 60.0), Vec3(60.0, 60.0, GROUND)), spheres=[Sphere(Vec3(0.0, 0.0, 1.0), 1.0)])
    w.get_landcell(cell_at(60.0, 60.0)).shadow_objects.append(obstacle)
    mid = w.add_mover(ball, Position.at(cell_at(57.0, 60.3), Vec3(57.0, 60.3, GROUND)), Plane(Vec3(0.0, 0.0, 1.0), -GROUND), cell_at(57.0, 60.3))
    results = walk(w, mid, Vec3(0.2, 0.0, 0.0), 40)
    slid = 0
    for r in results:
        o = r.position.origin
        assert r.ok and abs(o.z - GROUND) < tol
        assert (o + Vec3(0.0, 0.0, radius) - rock).length() >= radius + 1.0 - 2 * EPSILON - tol
        slid += r.collision_normal is not None
    assert slid > 0
    final = results[-1].position.origin
    assert final.x > 61.0 and final.y > 60.3


def test_the_two_precisions_walk_round_a_pillar_within_float32_rounding() -> None:
    """A cylinder walked round (CylSphere.SlideSphere and its CollisionNormal):
    the double-precision walk stays within float32 rounding of the single one."""
    paths = {}
    for s in (SINGLE, DOUBLE):
        w = _flat(s)
        pillar = Obstacle(0, Position.at(cell_at(60.0, 60.0), Vec3(60.0, 60.0, GROUND)), cyl_spheres=[CylSphere(Vec3(0.0, 0.0, 0.0), 0.6, 4.0)])
        w.get_landcell(cell_at(60.0, 60.0)).shadow_objects.append(pillar)
        ball = MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.48), 0.48)], step_up_height=0.4, step_down_height=0.4, state=["Contact", "OnWalkable"])
        mid = w.add_mover(ball, Position.at(cell_at(56.0, 60.2), Vec3(56.0, 60.2, GROUND)), Plane(Vec3(0.0, 0.0, 1.0), -GROUND), cell_at(56.0, 60.2))
        paths[s.single_precision] = [r.position.origin for r in walk(w, mid, Vec3(0.2, 0.0, 0.0), 45)]
        for o in paths[s.single_precision]:
            assert math.hypot(o.x - 60.0, o.y - 60.0) >= 0.6 + 0.48 - 2 * EPSILON - 1e-4
    single, double = paths[True], paths[False]
    # 45 steps, some sliding: the two stay within a few float32 steps (7.6e-6 m at 60 m) per step
    assert max((a - b).length() for a, b in zip(single, double)) < 1e-3
    assert single != double
    assert single[-1].x > 61.0 and double[-1].x > 61.0
