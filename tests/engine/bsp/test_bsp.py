"""BSP tests: hand-built rooms and crates with answers visible from the geometry,
the transition-facing queries (find_collisions and friends) on a fake
transition, and sanity checks on the shared reference scenes' BSPs.

Geometry used throughout:
- the *room*: x, y in [-2, 2], z in [0, 3], faces pointing inwards, laid out
  as the client stores a cell (planes chained on the positive side, each
  negative leaf solid with its face, the inner leaf listing every face);
- the *crate*: x, y in [-1, 1], z in [0, 2], faces pointing outwards, laid
  out as the client stores an object (empty positive leaves outside, the
  innermost negative leaf solid with every face).
Movers have a foot sphere of radius 0.5 (center 0.5 above the mover's origin)
and, where said, a head sphere of radius 0.5 one metre above the foot.
"""

from __future__ import annotations

import json
import math
from typing import Any

import pytest

from engine.bsp import (
    BBox,
    BoundingType,
    BSPLeaf,
    BSPNode,
    BSPTree,
    build_bsp,
    build_polygons,
    intersect_box,
    plane_local_to_global,
)
from engine.constants import EPSILON, FLOOR_Z, LANDING_Z
from engine.geometry import Frame, Plane, Position, Quat, Side, Sphere, Vec3
from engine.geometry.polygon import Polygon, PolyHit
from engine.transition.collision_info import CollisionInfo
from engine.transition.object_info import ObjectInfo
from engine.transition.sphere_path import SpherePath
from engine.transition.state import OI, InsertType, TransitionState
from engine.transition.transition import Transition
from support.shared_data import SCENES, needs_shared

CELL = 0xA9B40100
R = 0.5


# -- geometry helpers ---------------------------------------------------------------
def close(v: Vec3 | None, x: float, y: float, z: float, tol: float = 1e-9) -> bool:
    assert v is not None
    return abs(v.x - x) <= tol and abs(v.y - y) <= tol and abs(v.z - z) <= tol


def quad(a: tuple, b: tuple, c: tuple, d: tuple, facing: Vec3) -> Polygon:
    """A rectangle whose plane faces `facing` (vertex order flipped if needed)."""
    pts = [Vec3(*a), Vec3(*b), Vec3(*c), Vec3(*d)]
    p = Polygon(pts)
    if p.plane.normal.dot(facing) < 0:
        p = Polygon(list(reversed(pts)))
    assert p.plane.normal.dot(facing) > 0.999999
    return p


def box_faces(lo: tuple, hi: tuple, inward: bool) -> dict[str, Polygon]:
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    s = 1.0 if inward else -1.0
    return {
        "bottom": quad((x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0), Vec3(0, 0, s)),
        "top": quad((x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1), Vec3(0, 0, -s)),
        "west": quad((x0, y0, z0), (x0, y1, z0), (x0, y1, z1), (x0, y0, z1), Vec3(s, 0, 0)),
        "east": quad((x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1), Vec3(-s, 0, 0)),
        "south": quad((x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1), Vec3(0, s, 0)),
        "north": quad((x0, y1, z0), (x1, y1, z0), (x1, y1, z1), (x0, y1, z1), Vec3(0, -s, 0)),
    }


def bounding(lo: tuple, hi: tuple) -> Sphere:
    c = Vec3((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2)
    r = math.dist(lo, hi) / 2 * 1.01
    return Sphere(c, r)


def room_tree(lo=(-2.0, -2.0, 0.0), hi=(2.0, 2.0, 3.0)) -> tuple[BSPTree, dict[str, Polygon]]:
    faces = box_faces(lo, hi, inward=True)
    sphere = bounding(lo, hi)
    node: BSPNode = BSPLeaf(0, list(faces.values()), sphere, solid=False)
    for i, face in reversed(list(enumerate(faces.values()))):
        node = BSPNode(face.plane, node, BSPLeaf(i + 1, [face], sphere, solid=True), sphere)
    return BSPTree(node), faces


def crate_tree(lo=(-1.0, -1.0, 0.0), hi=(1.0, 1.0, 2.0)) -> tuple[BSPTree, dict[str, Polygon]]:
    faces = box_faces(lo, hi, inward=False)
    sphere = bounding(lo, hi)
    node: BSPNode = BSPLeaf(6, list(faces.values()), sphere, solid=True)
    for i, face in reversed(list(enumerate(faces.values()))):
        node = BSPNode(face.plane, BSPLeaf(i, [], sphere), node, sphere)
    return BSPTree(node), faces


def single_poly_tree(poly: Polygon) -> BSPTree:
    """A polygon on the splitting plane, listed in both leaves, as the client stores one."""
    verts = poly.vertices
    c = Vec3(sum(v.x for v in verts) / len(verts), sum(v.y for v in verts) / len(verts), sum(v.z for v in verts) / len(verts))
    sphere = Sphere(c, max((v - c).length() for v in verts) * 1.01)
    return BSPTree(BSPNode(poly.plane, BSPLeaf(0, [poly], sphere), BSPLeaf(1, [poly], sphere, solid=True), sphere))


DOWN = Vec3(0, 0, -1)
UP = Vec3(0, 0, 1)


# -- the transition side -----------------------------------------------------------
# The room cell sits at (100, 50, 20) turned 90 degrees about z: local (x, y, z)
# is global (100 - y, 50 + x, 20 + z). Local +x normals become global +y.
C45 = math.sqrt(0.5)
CELL_FRAME = Frame(Vec3(100.0, 50.0, 20.0), Quat(C45, 0.0, 0.0, C45))
CELL_POS = Position(CELL, CELL_FRAME)
#: normals rotated out of the turned cell come out as the client's float32
#: rotation makes them: within a float32 step (6e-8) of the exact value
F32_TOL = 1e-7


def to_global(local: Vec3) -> Vec3:
    return Vec3(100.0 - local.y, 50.0 + local.x, 20.0 + local.z)


class FakeTransition(Transition):
    """A real transition with no world behind it and a scripted step_up:
    the BSP's answers can be checked without a cell around it."""

    def __init__(self, path: SpherePath, state: int = 0, step_up_result: bool = True) -> None:
        super().__init__(None)
        self.sphere_path = path
        self.collision_info = CollisionInfo()
        self.object_info = ObjectInfo(state)
        self.step_up_result = step_up_result
        self.step_up_calls: list[Vec3] = []

    def step_up(self, collision_normal: Vec3) -> bool:
        # what the real step-up leaves behind for a slide, then the scripted answer
        self.step_up_calls.append(collision_normal)
        self.sphere_path.step_up_normal = collision_normal
        return self.step_up_result


def make_path(curr_local: Vec3, check_local: Vec3, head: bool = False, cell_pos: Position = CELL_POS) -> SpherePath:
    """A path whose foot sphere center moves from curr_local to check_local (cell-local)."""
    spheres = [Sphere(Vec3(0, 0, R), R)]
    if head:
        spheres.append(Sphere(Vec3(0, 0, R + 1.0), R))
    path = SpherePath()
    path.init_sphere(spheres, 1.0)
    lift = Vec3(0, 0, R)
    curr = Position(CELL, Frame(cell_pos.frame.local_to_global(curr_local) - lift))
    check = Position(CELL, Frame(cell_pos.frame.local_to_global(check_local) - lift))
    path.init_path(None, curr, check)
    path.set_check_pos(check, None)
    path.cache_local_space_sphere(cell_pos, 1.0)
    path.walkable_allowance = FLOOR_Z
    return path


def test_cell_frame_is_what_the_tests_assume() -> None:
    assert close(CELL_FRAME.local_to_global(Vec3(1, 0, 0)), 100.0, 51.0, 20.0, 1e-12)
    assert close(CELL_FRAME.local_to_global(Vec3(0, 1, 0)), 99.0, 50.0, 20.0, 1e-12)
    path = make_path(Vec3(1.4, 0, 1.5), Vec3(1.7, 0, 1.5))
    # carried through the landblock frame in single precision, as the client
    # does: at ~50 m a float32 step is 3.8e-6 m
    assert close(path.local_space_sphere[0].center, 1.7, 0, 1.5, 1e-5)
    assert close(path.local_space_curr_center[0].center, 1.4, 0, 1.5, 1e-5)


# -- sphere_intersects_poly ------------------------------------------------------------
def test_sphere_above_floor_does_not_intersect() -> None:
    tree, _ = room_tree()
    hits, poly, _ = tree.sphere_intersects_poly(Sphere(Vec3(0, 0, 1.5), R), DOWN * 0.1)
    assert not hits and poly is None
    # 0.5 above the floor is touching only within EPSILON: not a hit
    hits, poly, _ = tree.sphere_intersects_poly(Sphere(Vec3(0, 0, 0.4999), R), DOWN * 0.1)
    assert not hits and poly is None


def test_sphere_sinking_into_floor_hits_it_below_its_center() -> None:
    tree, faces = room_tree()
    hits, poly, contact = tree.sphere_intersects_poly(Sphere(Vec3(0.3, -0.4, 0.3), R), DOWN * 0.1)
    assert hits
    assert poly is faces["bottom"]
    assert close(contact, 0.3, -0.4, 0.0)


def test_wall_hit_returns_the_wall_polygon() -> None:
    tree, faces = room_tree()
    s = Sphere(Vec3(1.7, 0.0, 1.5), R)  # 0.2 into the east wall x = 2
    hits, poly, contact = tree.sphere_intersects_poly(s, Vec3(0.3, 0, 0))
    assert hits
    assert poly is faces["east"]
    assert close(contact, 2.0, 0.0, 1.5)


def test_overlapping_wall_while_moving_away_reports_polygon_without_hit() -> None:
    tree, faces = room_tree()
    s = Sphere(Vec3(1.7, 0.0, 1.5), R)
    hits, poly, _ = tree.sphere_intersects_poly(s, Vec3(-0.3, 0, 0))
    assert not hits
    assert poly is faces["east"]


def test_sphere_outside_bounding_sphere_is_rejected_at_the_root() -> None:
    tree, _ = room_tree()
    hits, poly, _ = tree.sphere_intersects_poly(Sphere(Vec3(50, 0, 1), R), Vec3(-1, 0, 0))
    assert not hits and poly is None


def test_corner_sphere_hits_first_face_in_leaf_order() -> None:
    tree, faces = room_tree()
    # in the corner near the floor and the east wall: both touched; the floor
    # comes first in the inner leaf
    hits, poly, _ = tree.sphere_intersects_poly(Sphere(Vec3(1.7, 0.0, 0.3), R), Vec3(0.1, 0, -0.1))
    assert hits and poly is faces["bottom"]


# -- find_walkable / hits_walkable -------------------------------------------------------
def test_find_walkable_lands_sphere_at_radius_above_floor() -> None:
    tree, faces = room_tree()
    path = SpherePath()
    path.walkable_allowance = FLOOR_Z
    path.walk_interp = 1.0
    s = Sphere(Vec3(0.5, 0.5, 0.3), R)
    poly = tree.find_walkable(path, s, Vec3(0, 0, -0.5), UP)
    assert poly is faces["bottom"]
    assert close(s.center, 0.5, 0.5, 0.5)
    assert path.walk_interp == pytest.approx(0.6)  # 0.2 of the 0.5 step given back


def test_find_walkable_ignores_walls_and_ceiling() -> None:
    tree, _ = room_tree()
    path = SpherePath()
    path.walkable_allowance = LANDING_Z
    path.walk_interp = 1.0
    # pressed into the ceiling moving up, and into a wall moving sideways
    s = Sphere(Vec3(0, 0, 2.7), R)
    assert tree.find_walkable(path, s, Vec3(0, 0, 0.5), UP) is None
    s2 = Sphere(Vec3(1.7, 0, 1.5), R)
    assert tree.find_walkable(path, s2, Vec3(0.5, 0, 0), UP) is None
    assert close(s.center, 0, 0, 2.7) and close(s2.center, 1.7, 0, 1.5)
    assert path.walk_interp == 1.0


def test_hits_walkable() -> None:
    tree, _ = room_tree()
    path = SpherePath()
    path.walkable_allowance = FLOOR_Z
    assert tree.hits_walkable(path, Sphere(Vec3(0, 0, 0.45), R), UP)
    assert not tree.hits_walkable(path, Sphere(Vec3(0, 0, 1.5), R), UP)
    assert not tree.hits_walkable(path, Sphere(Vec3(1.7, 0, 1.5), R), UP)


# -- solids ---------------------------------------------------------------------------------
def test_room_interior_is_not_solid_and_beyond_a_wall_is() -> None:
    tree, _ = room_tree()
    assert not tree.sphere_intersects_solid(Sphere(Vec3(0, 0, 1.5), R), True)
    # center 0.6 beyond the east wall: in its solid leaf, touching no polygon
    beyond = Sphere(Vec3(2.6, 0, 1.5), R)
    assert tree.sphere_intersects_solid(beyond, True)
    assert not tree.sphere_intersects_solid(beyond, False)
    # overlapping the wall from inside: a polygon is touched
    assert tree.sphere_intersects_solid(Sphere(Vec3(1.7, 0, 1.5), R), False)


def test_closed_box_solid_leaf_makes_inside_solid() -> None:
    tree, _ = crate_tree()
    inside = Sphere(Vec3(0.0, 0.0, 1.0), 0.2)
    assert tree.sphere_intersects_solid(inside, True)
    assert not tree.sphere_intersects_solid(inside, False)  # touches no face
    assert not tree.sphere_intersects_solid(Sphere(Vec3(3.0, 0, 1.0), R), True)
    assert tree.sphere_intersects_solid(Sphere(Vec3(1.3, 0, 1.0), R), False)
    assert tree.point_intersects_solid(Vec3(0.2, 0.3, 1.0))
    assert not tree.point_intersects_solid(Vec3(2.0, 0.0, 1.0))


def test_sphere_intersects_solid_poly_reports_face_and_center() -> None:
    tree, faces = crate_tree()
    # touching the east face from outside: the outer leaf is empty, the face
    # is found in the solid leaf
    hits, poly, center_solid = tree.sphere_intersects_solid_poly(Sphere(Vec3(1.3, 0, 1.0), R), R, True)
    assert hits and poly is faces["east"] and not center_solid
    hits, poly, center_solid = tree.sphere_intersects_solid_poly(Sphere(Vec3(0, 0, 1.0), 0.2), 0.2, True)
    assert hits and poly is None and center_solid


def test_solid_poly_on_centers_side_answers_center_solid() -> None:
    # Reference behaviour: when the sphere straddles a plane and the polygon is
    # found on the center's side, the answer is the center-solid flag (False in
    # a room), not True.
    tree, faces = room_tree()
    hits, poly, center_solid = tree.sphere_intersects_solid_poly(Sphere(Vec3(1.7, 0, 1.5), R), R, True)
    assert not hits and poly is faces["east"] and not center_solid


# -- cell BSP ---------------------------------------------------------------------------
def box_planes(lo: tuple, hi: tuple) -> list[tuple[tuple[float, float, float], float]]:
    return [
        ((0.0, 0.0, 1.0), -lo[2]),
        ((0.0, 0.0, -1.0), hi[2]),
        ((1.0, 0.0, 0.0), -lo[0]),
        ((-1.0, 0.0, 0.0), hi[0]),
        ((0.0, 1.0, 0.0), -lo[1]),
        ((0.0, -1.0, 0.0), hi[1]),
    ]


BOX_PLANES = box_planes((-2, -2, 0), (2, 2, 3))


def box_cell_dict(lo: tuple, hi: tuple) -> dict[str, Any]:
    """A cell BSP as the scene format writes it: inward planes along pos_node."""
    node: dict[str, Any] = {"type": "LEAF", "leaf_index": 0}
    for n, d in reversed(box_planes(lo, hi)):
        node = {"type": "BPnn", "splitting_plane": {"normal": list(n), "d": d}, "pos_node": node}
    return node


def test_point_inside_cell_bsp_for_box_cell() -> None:
    cell = build_bsp(box_cell_dict((-2, -2, 0), (2, 2, 3)))
    assert cell.point_inside_cell_bsp(Vec3(0, 0, 1.5))
    assert cell.point_inside_cell_bsp(Vec3(1.99, -1.99, 2.99))
    assert cell.point_inside_cell_bsp(Vec3(0, 0, 0))  # on the floor
    assert cell.point_inside_cell_bsp(Vec3(0, 0, -0.0001))  # within EPSILON
    assert not cell.point_inside_cell_bsp(Vec3(0, 0, -0.001))
    assert not cell.point_inside_cell_bsp(Vec3(2.5, 0, 1.5))
    assert not cell.point_inside_cell_bsp(Vec3(0, 0, 3.5))


def test_sphere_intersects_cell_bsp_with_slack() -> None:
    cell = build_bsp(box_cell_dict((-2, -2, 0), (2, 2, 3)))
    # a leaf ends the chain: its zero plane is straddled, so the best answer
    # for a sphere well inside is "partially" (reference behaviour)
    assert cell.sphere_intersects_cell_bsp(Sphere(Vec3(0, 0, 1.5), R)) == BoundingType.PARTIALLY_INSIDE
    # 0.505 beyond the east wall is within r + 0.01: still partially inside
    assert cell.sphere_intersects_cell_bsp(Sphere(Vec3(2.505, 0, 1.5), R)) == BoundingType.PARTIALLY_INSIDE
    # 0.52 beyond: outside
    assert cell.sphere_intersects_cell_bsp(Sphere(Vec3(2.52, 0, 1.5), R)) == BoundingType.OUTSIDE
    # a chain ending in a node without positive child (built by hand: the dat
    # tags never allow it) calls a sphere clear of every plane entirely inside
    last: BSPNode | None = None
    for n, d in reversed(BOX_PLANES):
        last = BSPNode(Plane(Vec3(*n), d), last, None)
    assert last is not None
    open_chain = BSPTree(last)
    assert open_chain.sphere_intersects_cell_bsp(Sphere(Vec3(0, 0, 1.5), R)) == BoundingType.ENTIRELY_INSIDE
    assert open_chain.sphere_intersects_cell_bsp(Sphere(Vec3(1.8, 0, 1.5), R)) == BoundingType.PARTIALLY_INSIDE


def test_box_intersects_cell_bsp() -> None:
    cell = build_bsp(box_cell_dict((-2, -2, 0), (2, 2, 3)))
    assert cell.box_intersects_cell_bsp(BBox(Vec3(-1, -1, 0.5), Vec3(1, 1, 2)))
    assert cell.box_intersects_cell_bsp(BBox(Vec3(1, -1, 0.5), Vec3(3, 1, 2)))  # through the east wall
    assert not cell.box_intersects_cell_bsp(BBox(Vec3(-4, -1, 0.5), Vec3(-3, 1, 2)))  # west, outside
    assert not cell.box_intersects_cell_bsp(BBox(Vec3(-1, -1, -2), Vec3(1, 1, -1)))  # below the floor
    # only planes with the min corner behind them are examined: a box whose
    # min corner is inside but reaching past the east wall is kept
    assert cell.box_intersects_cell_bsp(BBox(Vec3(1.5, -1, 0.5), Vec3(9, 1, 2)))


def test_intersect_box_sides() -> None:
    plane = Plane(Vec3(1, 0, 0), -2.0)  # x = 2, facing +x
    assert intersect_box(plane, BBox(Vec3(3, 0, 0), Vec3(4, 1, 1))) == Side.FRONT
    assert intersect_box(plane, BBox(Vec3(0, 0, 0), Vec3(1, 1, 1))) == Side.BEHIND
    assert intersect_box(plane, BBox(Vec3(1, 0, 0), Vec3(3, 1, 1))) == Side.CROSSING
    assert intersect_box(plane, BBox(Vec3(2, 0, 0), Vec3(3, 1, 1))) == Side.CROSSING


def test_bbox_basics() -> None:
    box = BBox.from_points([Vec3(1, 2, 3), Vec3(-1, 5, 0), Vec3(0, 0, 1)])
    assert close(box.min, -1, 0, 0) and close(box.max, 1, 5, 3)
    assert box.contains(Vec3(0, 1, 1)) and not box.contains(Vec3(0, 6, 1))
    corners = box.get_corners()
    assert len(corners) == 8 and close(corners[0], -1, 0, 0) and close(corners[7], 1, 5, 3)
    assert close(box.get_half_extent(), 1, 2.5, 1.5)
    moved = BBox()
    moved.local_to_global(box, Position(CELL, Frame(Vec3(10, 0, 0))), Position(CELL, Frame(Vec3(0, 0, 0))))
    assert close(moved.min, 9, 0, 0) and close(moved.max, 11, 5, 3)


# -- plane transform ------------------------------------------------------------------------
@pytest.mark.parametrize(("single", "tol"), [(True, 1e-6), (False, 1e-12)])
def test_plane_local_to_global(single: bool, tol: float) -> None:
    floor = Plane(Vec3(0, 0, 1), 0.0)
    g = plane_local_to_global(CELL_POS, CELL_POS, floor, 1.0, single)
    assert close(g.normal, 0, 0, 1, tol) and g.d == pytest.approx(-20.0)
    east = Plane(Vec3(-1, 0, 0), 2.0)  # local x = 2, facing -x
    g = plane_local_to_global(CELL_POS, CELL_POS, east, 1.0, single)
    # global: the plane y = 52 facing -y
    assert close(g.normal, 0, -1, 0, tol) and g.d == pytest.approx(52.0)
    # measured from the next landblock east (0xAAB4): x shifts by -192
    unturned = Position(CELL, Frame(Vec3(100, 50, 20)))
    g = plane_local_to_global(Position(0xAAB40001, Frame(Vec3(0, 0, 0))), unturned, east, 1.0, single)
    assert close(g.normal, -1, 0, 0) and g.d == pytest.approx(-90.0)
    # with a part's scale, d is multiplied by it (the floor contact plane the client keeps)
    g = plane_local_to_global(Position(0xAAB40001, Frame(Vec3(0, 0, 0))), unturned, east, 3.0, single)
    assert g.d == pytest.approx(-270.0)


# -- find_collisions: every branch ------------------------------------------------------------
def test_placement_insert_type_is_a_solid_test() -> None:
    tree, _ = room_tree()
    t = FakeTransition(make_path(Vec3(0, 0, 1.5), Vec3(0, 0, 1.5)))
    t.sphere_path.insert_type = InsertType.PLACEMENT
    assert tree.find_collisions(t, 1.0) == TransitionState.OK
    t = FakeTransition(make_path(Vec3(1.7, 0, 1.5), Vec3(1.7, 0, 1.5)))
    t.sphere_path.insert_type = InsertType.PLACEMENT
    assert tree.find_collisions(t, 1.0) == TransitionState.COLLIDED


def test_ethereal_obstruction_and_building_check() -> None:
    tree, _ = room_tree()
    t = FakeTransition(make_path(Vec3(2.6, 0, 1.5), Vec3(2.6, 0, 1.5)))
    path = t.sphere_path
    path.obstruction_ethereal = True
    assert tree.find_collisions(t, 1.0) == TransitionState.COLLIDED  # center in solid
    path.building_check = True
    path.hits_interior_cell = True  # no center check: nothing touched
    assert tree.find_collisions(t, 1.0) == TransitionState.OK
    path.hits_interior_cell = False
    assert tree.find_collisions(t, 1.0) == TransitionState.COLLIDED


def test_check_walkable_probe() -> None:
    tree, _ = room_tree()
    t = FakeTransition(make_path(Vec3(0, 0, 0.45), Vec3(0, 0, 0.45)))
    t.sphere_path.check_walkable = True
    assert tree.find_collisions(t, 1.0) == TransitionState.COLLIDED
    t = FakeTransition(make_path(Vec3(0, 0, 1.5), Vec3(0, 0, 1.5)))
    t.sphere_path.check_walkable = True
    assert tree.find_collisions(t, 1.0) == TransitionState.OK


def test_step_down_lands_on_floor_and_sets_contact_plane() -> None:
    tree, faces = room_tree()
    # the step-down probe has lowered the sphere 0.1: it is 0.05 into the floor
    t = FakeTransition(make_path(Vec3(0.5, 0.5, 0.55), Vec3(0.5, 0.5, 0.45)))
    path = t.sphere_path
    path.step_down = True
    path.step_down_amt = 0.1
    path.walk_interp = 1.0
    before = path.check_pos.frame.origin
    assert tree.find_collisions(t, 1.0) == TransitionState.ADJUSTED
    after = path.check_pos.frame.origin
    assert close(after - before, 0, 0, 0.05, 1e-5)  # positions are kept in single precision
    assert close(path.global_sphere[0].center, *to_global(Vec3(0.5, 0.5, 0.5)).as_tuple(), 1e-5)
    ci = t.collision_info
    assert ci.contact_plane_valid and not ci.contact_plane_is_water
    assert close(ci.contact_plane.normal, 0, 0, 1, 1e-9) and ci.contact_plane.d == pytest.approx(-20.0)
    assert ci.contact_plane_cell_id == CELL
    assert path.walkable is faces["bottom"]
    assert path.walk_interp == pytest.approx(0.5, abs=1e-4)  # 0.05 m of 0.1 m, to a float32 step at ~50 m


def test_step_down_finds_nothing_in_the_air() -> None:
    tree, _ = room_tree()
    t = FakeTransition(make_path(Vec3(0, 0, 1.6), Vec3(0, 0, 1.5)))
    t.sphere_path.step_down = True
    t.sphere_path.step_down_amt = 0.1
    t.sphere_path.walk_interp = 1.0
    assert tree.find_collisions(t, 1.0) == TransitionState.OK
    assert not t.collision_info.contact_plane_valid


def test_collide_mode_lands_on_floor() -> None:
    tree, faces = room_tree()
    t = FakeTransition(make_path(Vec3(0, 0, 1.0), Vec3(0, 0, 0.3)))
    path = t.sphere_path
    path.collide = True
    path.walk_interp = 1.0
    before = path.check_pos.frame.origin
    assert tree.find_collisions(t, 1.0) == TransitionState.ADJUSTED
    assert close(path.check_pos.frame.origin - before, 0, 0, 0.2, 1e-5)  # positions are kept in single precision
    assert t.collision_info.contact_plane_valid
    assert t.collision_info.contact_plane.d == pytest.approx(-20.0)
    assert path.walkable is faces["bottom"]
    assert path.walk_interp == pytest.approx(1.0 - 0.2 / 0.7, abs=1e-5)  # float32 positions at ~50 m


def test_collide_mode_without_floor_is_ok() -> None:
    tree, _ = room_tree()
    t = FakeTransition(make_path(Vec3(0, 0, 1.6), Vec3(0, 0, 1.5)))
    t.sphere_path.collide = True
    t.sphere_path.walk_interp = 1.0
    assert tree.find_collisions(t, 1.0) == TransitionState.OK


def test_contact_wall_hit_steps_up_with_global_normal() -> None:
    tree, _ = room_tree()
    t = FakeTransition(make_path(Vec3(1.4, 0, 1.5), Vec3(1.7, 0, 1.5)), OI.CONTACT, step_up_result=True)
    assert tree.find_collisions(t, 1.0) == TransitionState.OK
    assert len(t.step_up_calls) == 1
    # the east wall faces local -x, i.e. global -y in the turned cell
    assert close(t.step_up_calls[0], 0, -1, 0, F32_TOL)


def test_contact_failed_step_up_slides() -> None:
    tree, _ = room_tree()
    t = FakeTransition(make_path(Vec3(1.4, 0, 1.5), Vec3(1.7, 0, 1.5)), OI.CONTACT, step_up_result=False)
    before = t.sphere_path.check_pos.frame.origin
    assert tree.find_collisions(t, 1.0) == TransitionState.SLID
    ci = t.collision_info
    # the slide off the east wall (global -y): normal recorded, pushed back out along it
    assert ci.collision_normal_valid and close(ci.collision_normal, 0, -1, 0, F32_TOL)
    assert t.sphere_path.check_pos.frame.origin.y < before.y


def lintel_tree() -> BSPTree:
    """A wall at x = 2 facing -x, only from z = 1.2 up: the head hits it, the foot passes under."""
    return single_poly_tree(quad((2, -2, 1.2), (2, 2, 1.2), (2, 2, 3), (2, -2, 3), Vec3(-1, 0, 0)))


def kerb_tree() -> BSPTree:
    """A wall at x = 2 facing -x, only up to z = 0.8: the foot hits it, the head passes over."""
    return single_poly_tree(quad((2, -2, 0), (2, 2, 0), (2, 2, 0.8), (2, -2, 0.8), Vec3(-1, 0, 0)))


def test_contact_head_hit_slides() -> None:
    t = FakeTransition(make_path(Vec3(1.4, 0, 0.5), Vec3(1.7, 0, 0.5), head=True), OI.CONTACT)
    before = t.sphere_path.check_pos.frame.origin
    assert lintel_tree().find_collisions(t, 1.0) == TransitionState.SLID
    assert t.step_up_calls == []  # the head slides; only a foot hit steps up
    ci = t.collision_info
    assert ci.collision_normal_valid and close(ci.collision_normal, 0, -1, 0, F32_TOL)
    assert t.sphere_path.check_pos.frame.origin.y < before.y


def test_contact_head_overlap_moving_away_defers_slide() -> None:
    t = FakeTransition(make_path(Vec3(1.8, 0, 0.5), Vec3(1.7, 0, 0.5), head=True), OI.CONTACT)
    path = t.sphere_path
    assert lintel_tree().find_collisions(t, 1.0) == TransitionState.OK
    assert path.neg_poly_hit and not path.neg_step_up
    # NegPolyHit stores the reversed global normal
    assert close(path.neg_collision_normal, 0, 1, 0, F32_TOL)


def test_contact_foot_overlap_moving_away_defers_step_up() -> None:
    t = FakeTransition(make_path(Vec3(1.8, 0, 0.5), Vec3(1.7, 0, 0.5), head=True), OI.CONTACT)
    path = t.sphere_path
    assert kerb_tree().find_collisions(t, 1.0) == TransitionState.OK
    assert t.step_up_calls == []
    assert path.neg_poly_hit and path.neg_step_up
    assert close(path.neg_collision_normal, 0, 1, 0, F32_TOL)


def test_airborne_wall_hit_enters_collide_mode() -> None:
    tree, _ = room_tree()
    t = FakeTransition(make_path(Vec3(1.4, 0, 1.5), Vec3(1.7, 0, 1.5)))
    path = t.sphere_path
    assert tree.find_collisions(t, 1.0) == TransitionState.ADJUSTED
    assert path.collide
    assert close(path.step_up_normal, 0, -1, 0, F32_TOL)
    assert path.walkable_allowance == LANDING_Z
    assert path.backup_check_pos is path.check_pos
    assert not t.collision_info.collision_normal_valid


def test_airborne_overlap_moving_away_also_enters_collide_mode() -> None:
    tree, _ = room_tree()
    t = FakeTransition(make_path(Vec3(1.8, 0, 1.5), Vec3(1.7, 0, 1.5)))
    assert tree.find_collisions(t, 1.0) == TransitionState.ADJUSTED
    assert t.sphere_path.collide


def test_airborne_clear_is_ok() -> None:
    tree, _ = room_tree()
    t = FakeTransition(make_path(Vec3(0, 0, 1.6), Vec3(0, 0, 1.5)))
    assert tree.find_collisions(t, 1.0) == TransitionState.OK
    assert not t.sphere_path.collide


def test_airborne_head_hit_collides() -> None:
    t = FakeTransition(make_path(Vec3(1.4, 0, 0.5), Vec3(1.7, 0, 0.5), head=True))
    assert lintel_tree().find_collisions(t, 1.0) == TransitionState.COLLIDED
    ci = t.collision_info
    assert ci.collision_normal_valid and close(ci.collision_normal, 0, -1, 0, F32_TOL)
    assert not t.sphere_path.collide


def test_path_clipped_missile_collides_with_normal() -> None:
    tree, _ = room_tree()
    t = FakeTransition(make_path(Vec3(1.4, 0, 1.5), Vec3(1.7, 0, 1.5)), OI.PATH_CLIPPED)
    assert tree.find_collisions(t, 1.0) == TransitionState.COLLIDED
    assert t.collision_info.collision_normal_valid
    assert close(t.collision_info.collision_normal, 0, -1, 0, F32_TOL)
    assert not t.sphere_path.collide


def test_perfect_clip_collides_without_normal() -> None:
    # Reference behaviour: adjust_to_plane's bisection starts with both bounds
    # at 1 and gives up, so a PerfectClip missile ends COLLIDED, normal unset.
    tree, faces = room_tree()
    t = FakeTransition(make_path(Vec3(1.4, 0, 1.5), Vec3(1.7, 0, 1.5)), OI.PATH_CLIPPED | OI.PERFECT_CLIP)
    before = t.sphere_path.check_pos.frame.origin
    assert tree.find_collisions(t, 1.0) == TransitionState.COLLIDED
    assert not t.collision_info.collision_normal_valid
    assert t.sphere_path.check_pos.frame.origin == before
    s = Sphere(Vec3(1.7, 0, 1.5), R)
    assert not tree.adjust_to_plane(s, Vec3(1.4, 0, 1.5), faces["east"], Vec3(2, 0, 1.5))


# -- placement_insert ---------------------------------------------------------------------------
CRATE_POS = Position(CELL, Frame(Vec3(50.0, 60.0, 10.0)))


def test_placement_insert_pushes_sphere_out_of_wall_by_overlap() -> None:
    tree, _ = crate_tree()
    # 0.2 into the crate's east face
    t = FakeTransition(make_path(Vec3(1.3, 0, 1.0), Vec3(1.3, 0, 1.0), cell_pos=CRATE_POS))
    before = t.sphere_path.check_pos.frame.origin
    assert tree.placement_insert(t) == TransitionState.ADJUSTED
    assert close(t.sphere_path.check_pos.frame.origin - before, 0.2, 0, 0, 1e-5)  # positions are kept in single precision


def test_placement_insert_pushes_both_spheres_together() -> None:
    tree, _ = crate_tree()
    t = FakeTransition(make_path(Vec3(1.3, 0, 0.7), Vec3(1.3, 0, 0.7), head=True, cell_pos=CRATE_POS))
    before = t.sphere_path.check_pos.frame.origin
    assert tree.placement_insert(t) == TransitionState.ADJUSTED
    assert close(t.sphere_path.check_pos.frame.origin - before, 0.2, 0, 0, 1e-5)  # positions are kept in single precision


def test_placement_insert_clear_sphere_is_ok_and_unmoved() -> None:
    tree, _ = crate_tree()
    t = FakeTransition(make_path(Vec3(3.0, 0, 1.0), Vec3(3.0, 0, 1.0), cell_pos=CRATE_POS))
    before = t.sphere_path.check_pos.frame.origin
    assert tree.placement_insert(t) == TransitionState.OK
    assert t.sphere_path.check_pos.frame.origin == before


def test_placement_insert_deep_inside_crate_reference_behaviour() -> None:
    # Center 1 m from every face: rounds 0 and 1 find the center in solid with
    # no face touched and double the test radius (0.5 -> 1 -> 2); with radius 2
    # every plane is straddled, the solid leaf's answer is dropped for the
    # empty outer leaves', the test answers False, and placement "adjusts" by
    # nothing.
    tree, _ = crate_tree()
    t = FakeTransition(make_path(Vec3(0, 0, 1.0), Vec3(0, 0, 1.0), cell_pos=CRATE_POS))
    before = t.sphere_path.check_pos.frame.origin
    assert tree.placement_insert(t) == TransitionState.ADJUSTED
    assert close(t.sphere_path.check_pos.frame.origin - before, 0, 0, 0, 1e-12)


# -- builders ---------------------------------------------------------------------------------
def test_build_from_scene_dicts() -> None:
    verts = {"0": [0, 0, 0], "1": [1, 0, 0], "2": [1, 1, 0], "3": [0, 1, 0]}
    polys = build_polygons({"7": {"vertex_ids": [0, 1, 2, 3], "sides_type": 0}}, verts)
    assert list(polys) == [7] and polys[7].poly_id == 7
    sphere = {"origin": [0.5, 0.5, 0], "radius": 0.75}
    node = {
        "type": "BPnN",
        "splitting_plane": {"normal": [0, 0, 1], "d": 0},
        "sphere": sphere,
        "pos_node": {"type": "LEAF", "leaf_index": 0, "solid": 0, "sphere": sphere, "in_polys": [7]},
        "neg_node": {"type": "LEAF", "leaf_index": 1, "solid": 1, "sphere": sphere, "in_polys": [7]},
    }
    tree = build_bsp(node, polys)
    assert isinstance(tree.root_node.neg_node, BSPLeaf) and tree.root_node.neg_node.solid
    hits, poly, _ = tree.sphere_intersects_poly(Sphere(Vec3(0.5, 0.5, 0.3), R), DOWN)
    assert hits and poly is polys[7]


def test_builder_rejects_bad_input() -> None:
    sphere = {"origin": [0, 0, 0], "radius": 1}
    with pytest.raises(ValueError):
        build_bsp({"type": "LEAF", "leaf_index": 0, "solid": 0, "sphere": sphere, "in_polys": [3]}, {})
    with pytest.raises(ValueError):  # physics node with one child
        build_bsp(
            {"type": "BPIn", "splitting_plane": {"normal": [0, 0, 1], "d": 0}, "sphere": sphere,
             "pos_node": {"type": "LEAF", "leaf_index": 0, "solid": 0, "sphere": sphere, "in_polys": []}},
            {},
        )
    with pytest.raises(ValueError):
        build_bsp({"type": "XXXX", "splitting_plane": {"normal": [0, 0, 1], "d": 0}})
    with pytest.raises(ValueError):
        build_polygons({"0": {"vertex_ids": [0, 1, 9]}}, {"0": [0, 0, 0], "1": [1, 0, 0]})


# -- the shared reference scenes ------------------------------------------------------------------
def load_scene(name: str) -> dict[str, Any]:
    return json.loads((SCENES / f"{name}.json").read_text())


def scene_bsps(scene: dict[str, Any]):  # type: ignore[no-untyped-def]
    """(label, physics tree, polygons, cell tree or None) for every BSP of a scene."""
    for env_id, env in scene.get("environments", {}).items():
        for idx, cs in env["cell_structs"].items():
            polys = build_polygons(cs["physics_polygons"], cs["vertices"])
            yield f"{env_id}/{idx}", build_bsp(cs["physics_bsp"], polys), polys, build_bsp(cs["cell_bsp"])
    for gid, g in scene.get("gfx_objs", {}).items():
        if "physics_bsp" in g:
            polys = build_polygons(g["physics_polygons"], g["vertices"])
            yield gid, build_bsp(g["physics_bsp"], polys), polys, None


needs_scenes = needs_shared


@needs_scenes
@pytest.mark.parametrize("name", ["house", "interior", "cellar", "dungeon", "objects"])
def test_scene_bsps_are_sane(name: str) -> None:
    for label, tree, polys, _cell in scene_bsps(load_scene(name)):
        for node in tree.root_node.iter_nodes():
            assert node.sphere is not None, label
            if isinstance(node, BSPLeaf):
                # every polygon of a leaf lies within the leaf's bounding sphere
                for p in node.polygons:
                    for v in p.vertices:
                        assert (v - node.sphere.center).length() <= node.sphere.radius + 1e-3, (label, node)
            else:
                assert node.pos_node is not None and node.neg_node is not None, label
        for p in polys.values():
            assert abs(p.plane.normal.length() - 1.0) < 2e-7, label  # a float32 unit vector, as the client makes it
            for v in p.vertices:  # planar
                assert abs(p.plane.distance(v)) < 1e-4, (label, p)


@needs_scenes
@pytest.mark.parametrize("name", ["house", "interior"])
def test_room_centres_are_inside_their_cells_and_floors_face_up(name: str) -> None:
    for label, tree, polys, cell in scene_bsps(load_scene(name)):
        if cell is None:
            continue
        bottom = min(v.z for p in polys.values() for v in p.vertices)
        floors = [p for p in polys.values() if all(abs(v.z - bottom) < 1e-6 for v in p.vertices)]
        assert floors, label
        for f in floors:
            assert close(f.plane.normal, 0, 0, 1, 1e-9), (label, f)
        # the middle of the floor, a metre up, is inside the cell
        xs = [v.x for f in floors for v in f.vertices]
        ys = [v.y for f in floors for v in f.vertices]
        mid = Vec3((min(xs) + max(xs)) / 2, (min(ys) + max(ys)) / 2, bottom + 1.0)
        assert cell.point_inside_cell_bsp(mid), label
        assert not cell.point_inside_cell_bsp(mid + Vec3(0, 0, -2.0)), label
        assert not cell.point_inside_cell_bsp(mid + Vec3(100.0, 0, 0)), label
        assert cell.sphere_intersects_cell_bsp(Sphere(mid, R)) != BoundingType.OUTSIDE
        assert not tree.sphere_intersects_solid(Sphere(mid, R), True), label
        # a sphere dropped onto the floor lands at z = floor + r
        path = SpherePath()
        path.walkable_allowance = FLOOR_Z
        path.walk_interp = 1.0
        s = Sphere(Vec3(mid.x, mid.y, bottom + 0.3), R)
        hit = tree.find_walkable(path, s, Vec3(0, 0, -0.5), UP)
        assert hit is not None and hit in floors, label
        assert s.center.z == pytest.approx(bottom + R), label


@needs_scenes
def test_interior_rooms_are_told_apart_by_their_cell_bsps() -> None:
    scene = load_scene("interior")
    cs = scene["environments"]["0D000001"]["cell_structs"]
    room0 = build_bsp(cs["0"]["cell_bsp"])
    room1 = build_bsp(cs["1"]["cell_bsp"])
    # room 0 spans x in [-5, 0]; room 1 x in [0, 6] with its floor 0.25 up
    assert room0.point_inside_cell_bsp(Vec3(-2.5, 0, 1)) and not room1.point_inside_cell_bsp(Vec3(-2.5, 0, 1))
    assert room1.point_inside_cell_bsp(Vec3(3, 0, 1)) and not room0.point_inside_cell_bsp(Vec3(3, 0, 1))
    assert not room1.point_inside_cell_bsp(Vec3(3, 0, 0.2))


@needs_scenes
def test_house_wall_and_placement_against_real_cell() -> None:
    scene = load_scene("house")
    cs = scene["environments"]["0D000001"]["cell_structs"]["0"]
    polys = build_polygons(cs["physics_polygons"], cs["vertices"])
    tree = build_bsp(cs["physics_bsp"], polys)
    # the east wall x = 3.75 is polygon 1, facing into the room
    s = Sphere(Vec3(3.45, 0, 1.5), R)
    hits, poly, contact = tree.sphere_intersects_poly(s, Vec3(0.2, 0, 0))
    assert hits and poly is polys[1]
    assert close(poly.plane.normal, -1, 0, 0, 1e-9)
    assert close(contact, 3.75, 0, 1.5, 1e-9)
    # the doorway gap in the south wall (x in [-0.75, 0.75], z < 2.25) lets a sphere through
    hits, poly, _ = tree.sphere_intersects_poly(Sphere(Vec3(0, -2.75, 1.0), 0.4), Vec3(0, -0.2, 0))
    assert not hits and poly is None
    # initial placement overlapping the wall from inside: the wall is found on
    # the center's side, so placement answers OK without a push (reference)
    room_pos = Position(CELL, Frame(Vec3(108.0, 108.0, 112.5)))
    t = FakeTransition(make_path(Vec3(3.45, 0, 1.5), Vec3(3.45, 0, 1.5), cell_pos=room_pos))
    before = t.sphere_path.check_pos.frame.origin
    assert tree.placement_insert(t) == TransitionState.OK
    assert t.sphere_path.check_pos.frame.origin == before


@needs_scenes
def test_objects_crate_like_gfx_objs_are_solid_inside() -> None:
    scene = load_scene("objects")
    for gid in ("01000002", "01000003"):
        g = scene["gfx_objs"][gid]
        polys = build_polygons(g["physics_polygons"], g["vertices"])
        tree = build_bsp(g["physics_bsp"], polys)
        top = max(v.z for v in g_vertices(g))
        inside = Sphere(Vec3(0, 0, top / 2), 0.05)
        assert tree.sphere_intersects_solid(inside, True), gid
        assert not tree.sphere_intersects_solid(Sphere(Vec3(0, 0, top + 2.0), R), True), gid
        # a sphere dropped onto the top lands at top + r
        path = SpherePath()
        path.walkable_allowance = FLOOR_Z
        path.walk_interp = 1.0
        s = Sphere(Vec3(0.1, 0.1, top + 0.3), R)
        assert tree.find_walkable(path, s, Vec3(0, 0, -0.5), UP) is not None
        assert s.center.z == pytest.approx(top + R)


def g_vertices(g: dict[str, Any]) -> list[Vec3]:
    return [Vec3(*v) for v in g["vertices"].values()]


def test_epsilon_is_the_clients() -> None:
    assert EPSILON == 0.0002
    assert PolyHit().poly is None
