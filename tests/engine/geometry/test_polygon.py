"""Polygon tests on geometry small enough to check by hand.

The unit square floor used throughout has corners (0,0,0) (1,0,0) (1,1,0)
(0,1,0), counter-clockwise seen from above, so its plane is z = 0 facing up.
Spheres have radius 0.5; the tests shrink a radius by EPSILON (0.0002) only
where it matters.
"""

from __future__ import annotations

import math

import pytest

from engine.constants import EPSILON, LANDING_Z
from engine.geometry import Side, Sphere, Vec3
from engine.geometry.polygon import CullMode, Polygon, PolyHit, Ray
from engine.transition.sphere_path import SpherePath

UP = Vec3(0.0, 0.0, 1.0)


def approx_vec(v: Vec3 | None, x: float, y: float, z: float, tol: float = 1e-9) -> bool:
    assert v is not None
    return abs(v.x - x) <= tol and abs(v.y - y) <= tol and abs(v.z - z) <= tol


@pytest.fixture
def floor() -> Polygon:
    return Polygon([Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)])


def walk_path(allowance: float = LANDING_Z, walk_interp: float = 1.0) -> SpherePath:
    path = SpherePath()
    path.walkable_allowance = allowance
    path.walk_interp = walk_interp
    return path


# -- plane ------------------------------------------------------------------
def test_plane_of_counter_clockwise_square_faces_up(floor: Polygon) -> None:
    assert approx_vec(floor.plane.normal, 0, 0, 1)
    assert floor.plane.d == 0.0
    assert floor.num_points == 4
    assert floor.sides_type == CullMode.LANDBLOCK


def test_plane_d_is_minus_mean_height_and_clockwise_faces_down() -> None:
    up = Polygon([Vec3(0, 0, 2), Vec3(1, 0, 2), Vec3(0, 1, 2)])
    assert approx_vec(up.plane.normal, 0, 0, 1)
    assert up.plane.d == pytest.approx(-2.0)
    down = Polygon([Vec3(0, 0, 2), Vec3(0, 1, 2), Vec3(1, 0, 2)])
    assert approx_vec(down.plane.normal, 0, 0, -1)
    assert down.plane.d == pytest.approx(2.0)


def test_terrain_triangle_slope_normal() -> None:
    # rises 12 m over 24 m eastwards: normal ~ (-1, 0, 2) / sqrt(5)
    tri = Polygon([Vec3(0, 0, 0), Vec3(24, 0, 12), Vec3(0, 24, 0)])
    s5 = math.sqrt(5.0)
    # the plane is computed in float32, as the client computes it
    assert approx_vec(tri.plane.normal, -1 / s5, 0, 2 / s5, tol=1e-7)
    assert tri.plane.d == pytest.approx(0.0, abs=1e-12)


# -- sphere against polygon -------------------------------------------------
def test_sphere_above_floor_does_not_touch(floor: Polygon) -> None:
    s = Sphere(Vec3(0.5, 0.5, 0.6), 0.5)
    assert not floor.hits_sphere(s)
    hit, contact = floor.polygon_hits_sphere_precise(s)
    assert not hit and contact is None


def test_sphere_just_within_epsilon_does_not_touch(floor: Polygon) -> None:
    # the test radius is r - EPSILON: 0.4999 away is not a touch
    assert not floor.hits_sphere(Sphere(Vec3(0.5, 0.5, 0.4999), 0.5))
    assert floor.hits_sphere(Sphere(Vec3(0.5, 0.5, 0.4997), 0.5))


def test_overlapping_sphere_touches_with_contact_below_center(floor: Polygon) -> None:
    s = Sphere(Vec3(0.25, 0.75, 0.3), 0.5)
    hit, contact = floor.polygon_hits_sphere_precise(s)
    assert hit
    assert approx_vec(contact, 0.25, 0.75, 0.0)


def test_sphere_beside_edge_touches_within_radius(floor: Polygon) -> None:
    # center 0.3 beyond the x = 1 edge, in the plane: touches the edge
    assert floor.hits_sphere(Sphere(Vec3(1.3, 0.5, 0.0), 0.5))
    # 0.6 beyond: too far
    assert not floor.hits_sphere(Sphere(Vec3(1.6, 0.5, 0.0), 0.5))


def test_sphere_beyond_corner_touches_only_within_radius(floor: Polygon) -> None:
    # distance to corner (1,1): sqrt(0.18) = 0.424 < 0.4998
    assert floor.hits_sphere(Sphere(Vec3(1.3, 1.3, 0.0), 0.5))
    # sqrt(0.32) = 0.566 > 0.4998, and beyond both edge segments
    assert not floor.hits_sphere(Sphere(Vec3(1.4, 1.4, 0.0), 0.5))


def test_sphere_beside_edge_and_above_plane(floor: Polygon) -> None:
    # 0.3 above the plane and 0.3 beyond the edge: |(0.3, 0.3)| = 0.424 < 0.4998
    assert floor.hits_sphere(Sphere(Vec3(1.3, 0.5, 0.3), 0.5))
    # 0.4 above and 0.4 beyond: 0.566
    assert not floor.hits_sphere(Sphere(Vec3(1.4, 0.5, 0.4), 0.5))


def test_older_sphere_test_agrees_on_simple_cases(floor: Polygon) -> None:
    for c, expected in [
        (Vec3(0.5, 0.5, 0.3), True),
        (Vec3(0.5, 0.5, 0.6), False),
        (Vec3(1.3, 0.5, 0.0), True),
        (Vec3(1.6, 0.5, 0.0), False),
        (Vec3(1.3, 1.3, 0.0), True),
    ]:
        assert floor.polygon_hits_sphere(Sphere(c, 0.5))[0] is expected


def test_pos_hits_sphere_needs_motion_against_normal(floor: Polygon) -> None:
    s = Sphere(Vec3(0.5, 0.5, 0.3), 0.5)
    hit = PolyHit()
    assert floor.pos_hits_sphere(s, Vec3(0, 0, -0.1), hit)
    assert hit.poly is floor
    assert approx_vec(hit.contact_point, 0.5, 0.5, 0.0)

    # moving away: not a hit, but the touched polygon is still reported
    away = PolyHit()
    assert not floor.pos_hits_sphere(s, Vec3(0, 0, 0.1), away)
    assert away.poly is floor
    # moving along the floor: dot = 0 is "not against"
    assert not floor.pos_hits_sphere(s, Vec3(0.1, 0, 0))
    # not touching: nothing reported
    none = PolyHit()
    assert not floor.pos_hits_sphere(Sphere(Vec3(0.5, 0.5, 2.0), 0.5), Vec3(0, 0, -0.1), none)
    assert none.poly is None


# -- walkables ---------------------------------------------------------------
def test_walkable_hits_sphere_depends_on_allowance(floor: Polygon) -> None:
    s = Sphere(Vec3(0.5, 0.5, 0.3), 0.5)
    assert floor.walkable_hits_sphere(walk_path(LANDING_Z), s, UP)
    # the floor's dot(up, n) = 1 is not > 1
    assert not floor.walkable_hits_sphere(walk_path(1.0), s, UP)
    wall = Polygon([Vec3(0, 0, 0), Vec3(0, 1, 0), Vec3(0, 1, 1), Vec3(0, 0, 1)])
    assert approx_vec(wall.plane.normal, -1, 0, 0) or approx_vec(wall.plane.normal, 1, 0, 0)
    assert not wall.walkable_hits_sphere(walk_path(LANDING_Z), Sphere(Vec3(0.3, 0.5, 0.5), 0.5), UP)


def test_adjust_sphere_to_plane_backs_sphere_onto_floor(floor: Polygon) -> None:
    # sphere moved down by 0.5 and now sinks 0.2 into the floor: back it 0.2
    path = walk_path()
    s = Sphere(Vec3(0.5, 0.5, 0.3), 0.5)
    assert floor.adjust_sphere_to_plane(path, s, Vec3(0, 0, -0.5))
    assert approx_vec(s.center, 0.5, 0.5, 0.5)
    # 0.2 of the 0.5 movement is given back: 60 % of the step remains
    assert path.walk_interp == pytest.approx(0.6)


def test_adjust_sphere_to_plane_refuses_parallel_or_upward_motion(floor: Polygon) -> None:
    path = walk_path()
    s = Sphere(Vec3(0.5, 0.5, 0.3), 0.5)
    assert not floor.adjust_sphere_to_plane(path, s, Vec3(0.5, 0, 0))
    assert not floor.adjust_sphere_to_plane(path, s, Vec3(0, 0, 0.5))
    assert approx_vec(s.center, 0.5, 0.5, 0.3)
    assert path.walk_interp == 1.0


def test_adjust_sphere_to_plane_refuses_too_deep(floor: Polygon) -> None:
    # sunk 0.8 with a 0.5 movement: interp would be 1 - 1.6 = -0.6 < -0.5
    path = walk_path()
    s = Sphere(Vec3(0.5, 0.5, -0.3), 0.5)
    assert not floor.adjust_sphere_to_plane(path, s, Vec3(0, 0, -0.5))


def test_check_walkable_inside_edge_and_outside(floor: Polygon) -> None:
    assert floor.check_walkable(Sphere(Vec3(0.5, 0.5, 3.0), 0.5), UP)
    # 0.3 beyond the x = 1 edge: the full radius reaches, a quarter of r^2 does not
    s = Sphere(Vec3(1.3, 0.5, 0.5), 0.5)
    assert floor.check_walkable(s, UP)
    assert not floor.check_small_walkable(s, UP)
    assert not floor.check_walkable(s, UP, small=True)
    assert not floor.check_walkable(Sphere(Vec3(1.6, 0.5, 0.5), 0.5), UP)
    # a plane facing away from `up` is never walkable
    assert not floor.check_walkable(Sphere(Vec3(0.5, 0.5, 0.5), 0.5), Vec3(0, 0, -1))


def test_find_crossed_edge_reports_the_edge_walked_over(floor: Polygon) -> None:
    assert floor.find_crossed_edge(Sphere(Vec3(0.5, 0.5, 0.5), 0.5), UP) is None
    # across x = 1: the edge normal, pointing back into the floor (-x)
    n = floor.find_crossed_edge(Sphere(Vec3(1.3, 0.5, 0.5), 0.5), UP)
    assert approx_vec(n, -1, 0, 0)
    # across y = 0
    n = floor.find_crossed_edge(Sphere(Vec3(0.5, -0.2, 0.5), 0.5), UP)
    assert approx_vec(n, 0, 1, 0)
    # a vertical plane is parallel to up: no answer
    wall = Polygon([Vec3(0, 0, 0), Vec3(0, 1, 0), Vec3(0, 1, 1), Vec3(0, 0, 1)])
    assert wall.find_crossed_edge(Sphere(Vec3(5, 5, 5), 0.5), UP) is None


def test_walkable_tests_project_along_up_not_along_normal() -> None:
    # a 45 degree ramp z = x over x, y in [0, 1]
    ramp = Polygon([Vec3(0, 0, 0), Vec3(1, 0, 1), Vec3(1, 1, 1), Vec3(0, 1, 0)])
    r2 = math.sqrt(0.5)
    assert approx_vec(ramp.plane.normal, -r2, 0, r2, tol=1e-7)  # float32, as the client
    # high above x = 0.9: straight down lands inside the ramp (along the
    # normal it would land at x = 2.95, outside)
    s = Sphere(Vec3(0.9, 0.5, 5.0), 0.01)
    assert ramp.find_crossed_edge(s, UP) is None
    assert ramp.check_walkable(s, UP)
    s = Sphere(Vec3(1.2, 0.5, 5.0), 0.01)
    assert approx_vec(ramp.find_crossed_edge(s, UP), -r2, 0, -r2)


# -- placement helpers --------------------------------------------------------
def test_adjust_sphere_to_poly_touch_time(floor: Polygon) -> None:
    s = Sphere(Vec3(0, 0, 0), 0.5)
    # from z = 2 moving 4 down: touches at z = 0.5, 1.5 / 4 of the way
    assert floor.adjust_sphere_to_poly(s, Vec3(0.5, 0.5, 2.0), Vec3(0, 0, -4.0)) == pytest.approx(0.375)
    # already overlapping at the start
    assert floor.adjust_sphere_to_poly(s, Vec3(0.5, 0.5, 0.2), Vec3(0, 0, -4.0)) == 1.0
    # moving along the plane
    assert floor.adjust_sphere_to_poly(s, Vec3(0.5, 0.5, 2.0), Vec3(1.0, 0, 0)) == 0.0


def test_adjust_to_placement_poly_pushes_out_by_overlap() -> None:
    wall = Polygon([Vec3(0, 0, 0), Vec3(0, 1, 0), Vec3(0, 1, 1), Vec3(0, 0, 1)])
    if wall.plane.normal.x < 0:
        wall = Polygon(list(reversed(wall.vertices)))
    assert approx_vec(wall.plane.normal, 1, 0, 0)
    hit = Sphere(Vec3(0.2, 0.5, 0.5), 0.5)
    other = Sphere(Vec3(0.2, 0.5, 1.5), 0.5)
    wall.adjust_to_placement_poly(hit, other, 0.5, False, True)
    assert approx_vec(hit.center, 0.5, 0.5, 0.5)
    assert approx_vec(other.center, 0.5, 0.5, 1.5)
    # center behind the plane with solids checked: pushed to r behind it
    behind = Sphere(Vec3(-0.2, 0.5, 0.5), 0.5)
    wall.adjust_to_placement_poly(behind, None, 0.5, False, True)
    assert approx_vec(behind.center, -0.5, 0.5, 0.5)
    # without the solid check, always to r in front
    behind = Sphere(Vec3(-0.2, 0.5, 0.5), 0.5)
    wall.adjust_to_placement_poly(behind, None, 0.5, True, False)
    assert approx_vec(behind.center, 0.5, 0.5, 0.5)


# -- points and rays ------------------------------------------------------------
def test_point_in_polygon(floor: Polygon) -> None:
    assert floor.point_in_polygon(Vec3(0.5, 0.5, 0))
    assert floor.point_in_polygon(Vec3(1.0, 0.5, 0))  # on the edge
    assert not floor.point_in_polygon(Vec3(1.5, 0.5, 0))
    assert not floor.point_in_polygon(Vec3(0.5, -0.01, 0))


def test_point_in_poly_2d_by_winding(floor: Polygon) -> None:
    assert floor.point_in_poly_2d(Vec3(0.5, 0.5, 7), Side.FRONT)
    assert floor.point_in_poly_2d(Vec3(0.0, 0.5, 7), Side.FRONT)
    assert not floor.point_in_poly_2d(Vec3(1.5, 0.5, 7), Side.FRONT)
    cw = Polygon(list(reversed(floor.vertices)))
    assert cw.point_in_poly_2d(Vec3(0.5, 0.5, 0), Side.BEHIND)
    assert not cw.point_in_poly_2d(Vec3(0.5, 0.5, 0), Side.FRONT)
    assert not cw.point_in_poly_2d(Vec3(-0.5, 0.5, 0), Side.BEHIND)


def test_polygon_hits_ray(floor: Polygon) -> None:
    assert floor.polygon_hits_ray(Ray(Vec3(0.5, 0.5, 2), Vec3(0, 0, -1), 5)) == pytest.approx(2.0)
    # single-sided: not from behind
    assert floor.polygon_hits_ray(Ray(Vec3(0.5, 0.5, -2), Vec3(0, 0, 1), 5)) is None
    two_sided = Polygon(floor.vertices, CullMode.NONE)
    assert two_sided.polygon_hits_ray(Ray(Vec3(0.5, 0.5, -2), Vec3(0, 0, 1), 5)) == pytest.approx(2.0)
    # pointing away, parallel, or missing the square
    assert two_sided.polygon_hits_ray(Ray(Vec3(0.5, 0.5, 2), Vec3(0, 0, 1), 5)) is None
    assert floor.polygon_hits_ray(Ray(Vec3(0.5, 0.5, 2), Vec3(1, 0, 0), 5)) is None
    assert floor.polygon_hits_ray(Ray(Vec3(3, 3, 2), Vec3(0, 0, -1), 5)) is None


def test_ray_from_offset() -> None:
    r = Ray.from_offset(Vec3(0, 0, 0), Vec3(3, 4, 0))
    assert r.length == pytest.approx(5.0)
    assert approx_vec(r.dir, 0.6, 0.8, 0)
    # the reference compares offset with the start point: equal ones give a zero ray
    z = Ray.from_offset(Vec3(1, 1, 1), Vec3(1, 1, 1))
    assert z.length == 0.0 and z.dir.is_zero()


def test_make_plane_after_moving_vertices(floor: Polygon) -> None:
    floor.vertices = [Vec3(v.x, v.y, 3.0) for v in floor.vertices]
    floor.make_plane()
    assert floor.plane.d == pytest.approx(-3.0)
    assert floor.hits_sphere(Sphere(Vec3(0.5, 0.5, 3.3), 0.5))
    assert not floor.hits_sphere(Sphere(Vec3(0.5, 0.5, 0.3), 0.5))
    assert EPSILON == 0.0002
