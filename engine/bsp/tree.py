"""BSPTree: the collision response of a physics BSP, and the cell BSP tests.

`find_collisions` is what an EnvCell (its cell structure's physics BSP, in
cell-local space) and an object part (its GfxObj's physics BSP, in part-local
space divided by the part's scale) run for every sub-step: the transition's
spheres must already be cached in that local space
(`SpherePath.cache_local_space_sphere`). `placement_insert` replaces it when
the path is an initial placement.

Every state returned is a `TransitionState` int. Offsets found in local space
are turned into the check position's frame with `path.local_space_pos` and
multiplied by `scale`, as the reference does.

What this module needs from the transition (duck-typed):
`transition.sphere_path` (a SpherePath), `transition.collision_info` (a
CollisionInfo), `transition.object_info.state` (OI bits),
`transition.step_up(global_normal) -> bool`, `transition.slide_sphere(normal,
curr_center) -> int` and `path.step_up_slide(transition) -> int`: the
interface engine.transition.interface spells out.
"""

from __future__ import annotations

from typing import Final, TYPE_CHECKING

from ..constants import ADJUST_TO_PLANE_ITERATIONS, LANDING_Z, PLACEMENT_ITERATIONS
from ..geometry.precision import fl, fl_dot, fl_rotate, fl_scale, fl_sub
from ..geometry.landdefs import get_block_offset
from ..geometry.plane import Plane
from ..geometry.polygon import Polygon, PolyHit
from ..geometry.sphere import Sphere
from ..geometry.vec3 import Vec3
from ..transition.state import OI, InsertType, TransitionState
from .node import BSPNode

if TYPE_CHECKING:
    from ..geometry.position import Position
    from ..transition.sphere_path import SpherePath
    from ..transition.transition import Transition
    from .bbox import BBox

__all__ = ["BSPTree", "plane_local_to_global"]

_OK: Final = TransitionState.OK
_COLLIDED: Final = TransitionState.COLLIDED
_ADJUSTED: Final = TransitionState.ADJUSTED


def plane_local_to_global(to: Position, from_: Position, local_plane: Plane, scale: float, single: bool) -> Plane:
    """A plane given in from_'s local frame, in to's landblock frame, with d
    then multiplied by `scale` (PlaneExtensions.LocalToGlobal; what a found
    floor's contact plane is).

    The normal is rotated by from_'s orientation; d is re-measured through
    the plane's point nearest from_'s origin (normal * -d), carried into to's
    landblock. At the working precision (`single`: the client's, the normal
    and the point rotated as System.Numerics rotates, each sum, product and
    the dot product rounded to float32).
    """
    n = local_plane.normal
    q = from_.frame.orientation
    normal = fl_rotate(q, n, single)
    r = fl_rotate(q, fl_scale(n, -local_plane.d, single), single)
    o = from_.frame.origin
    block = get_block_offset(to.cell_id, from_.cell_id)
    px = fl(block.x + fl(o.x + r.x, single), single)
    py = fl(block.y + fl(o.y + r.y, single), single)
    pz = fl(block.z + fl(o.z + r.z, single), single)
    d = -fl_dot(normal.x, normal.y, normal.z, px, py, pz, single)
    return Plane(normal, fl(d * scale, single))


def _global_vec(path: SpherePath, v: Vec3) -> Vec3:
    """A vector of the path's local space in the landblock frame
    (LocalSpacePos.LocalToGlobalVec), at the path's working precision."""
    lsp = path.local_space_pos
    assert lsp is not None
    return fl_rotate(lsp.frame.orientation, v, path.single_precision)


def _global_offset(path: SpherePath, moved: Vec3, start: Vec3, scale: float) -> Vec3:
    """How far a local-space sphere moved, in the landblock frame and scaled
    (LocalToGlobalVec(moved - start) * scale), at the path's working precision."""
    single = path.single_precision
    v = _global_vec(path, fl_sub(moved, start, single))
    return v if scale == 1.0 else fl_scale(v, fl(scale, single), single)


def _land_on_walkable(transition: Transition, valid_pos: Sphere, poly: Polygon, local_center: Vec3, scale: float, invalidate_cells: bool) -> int:
    """Move the check position by what find_walkable moved the (part-space)
    sphere `local_center` -> `valid_pos`, make the polygon's plane the
    contact plane (global, d times scale, not water, in the check position's
    cell) and the walkable: the landing shared by BSPTREE::find_collisions'
    collide branch (which also invalidates the cell array) and
    BSPTREE::step_sphere_down. Returns ADJUSTED."""
    path = transition.sphere_path
    local_space_pos = path.local_space_pos
    assert local_space_pos is not None
    offset = _global_offset(path, valid_pos.center, local_center, scale)
    if invalidate_cells:
        path.add_offset_to_check_pos(offset)
    else:
        path.shift_check_pos(offset)
    plane = plane_local_to_global(path.check_pos, local_space_pos, poly.plane, scale, path.single_precision)
    ci = transition.collision_info
    ci.set_contact_plane(plane, False)
    ci.contact_plane_cell_id = path.check_pos.cell_id
    path.set_walkable(valid_pos, poly, path.local_space_z, local_space_pos, scale)
    return _ADJUSTED


class BSPTree:
    """A BSP tree and the queries the transition makes of it (the client's BSPTREE)."""

    __slots__ = ("root_node",)

    root_node: BSPNode

    def __init__(self, root_node: BSPNode) -> None:
        self.root_node = root_node

    def __repr__(self) -> str:
        return f"BSPTree({self.root_node!r})"

    def get_sphere(self) -> Sphere | None:
        """The root's bounding sphere (the GfxObj's PhysicsSphere)."""
        return self.root_node.sphere

    # -- plain queries (conveniences over the root) -------------------------
    def sphere_intersects_poly(self, check_pos: Sphere, movement: Vec3) -> tuple[bool, Polygon | None, Vec3]:
        """(hits, polygon, contact point) of BSPNODE::sphere_intersects_poly
        on the root. `polygon` can be set while `hits` is False: the sphere
        overlaps it but moves away from it.
        Decompiled client: FUN_00539500 (the seed, transition_pseudocode.md)."""
        hit = PolyHit()
        result = self.root_node.sphere_intersects_poly(check_pos, movement, hit)
        return result, hit.poly, hit.contact_point

    def sphere_intersects_solid(self, check_pos: Sphere, center_check: bool) -> bool:
        """BSPNODE::sphere_intersects_solid on the root."""
        return self.root_node.sphere_intersects_solid(check_pos, center_check)

    def sphere_intersects_solid_poly(
        self, check_pos: Sphere, radius: float, center_check: bool
    ) -> tuple[bool, Polygon | None, bool]:
        """(answer, polygon, center in solid) of
        BSPNODE::sphere_intersects_solid_poly on the root, from a fresh start."""
        hit = PolyHit()
        result = self.root_node.sphere_intersects_solid_poly(check_pos, radius, hit, center_check)
        return result, hit.poly, hit.center_solid

    def find_walkable(self, path: SpherePath, valid_pos: Sphere, movement: Vec3, up: Vec3) -> Polygon | None:
        """BSPNODE::find_walkable on the root: moves `valid_pos`, returns the
        polygon it was last settled on (None: unchanged).
        Decompiled client: FUN_0053a040 (the seed, transition_pseudocode.md)."""
        return self.root_node.find_walkable(path, valid_pos, movement, up)

    def hits_walkable(self, path: SpherePath, valid_pos: Sphere, up: Vec3) -> bool:
        """BSPNODE::hits_walkable on the root.
        Decompiled client: FUN_0053a230 (the seed, transition_pseudocode.md)."""
        return self.root_node.hits_walkable(path, valid_pos, up)

    def point_intersects_solid(self, point: Vec3) -> bool:
        return self.root_node.point_intersects_solid(point)

    # -- cell BSP ---------------------------------------------------------------
    def point_inside_cell_bsp(self, point: Vec3) -> bool:
        """Is a cell-local point inside the cell? (BSPTREE::point_inside_cell_bsp)"""
        return self.root_node.point_inside_cell_bsp(point)

    def sphere_intersects_cell_bsp(self, sphere: Sphere) -> int:
        """A BoundingType for a cell-local sphere (BSPTREE::sphere_intersects_cell_bsp)."""
        return self.root_node.sphere_intersects_cell_bsp(sphere)

    def box_intersects_cell_bsp(self, box: BBox) -> bool:
        """Can a cell-local box reach into the cell? (BSPTREE::box_intersects_cell_bsp)"""
        return self.root_node.box_intersects_cell_bsp(box)

    # -- collision response -------------------------------------------------------
    def find_collisions(self, transition: Transition, scale: float) -> int:
        """Collide the path's local-space spheres with this tree
        (BSPTREE::find_collisions).

        In order: placement or ethereal obstruction (solid test only); the
        walkable probe (`path.check_walkable`); step-down; collide mode (land
        on a walkable); in contact (step up, or defer the head sphere's hit
        with NegPolyHit); airborne (enter collide mode, PerfectClip for path-
        clipped movers, head sphere collides).
        """
        path = transition.sphere_path
        spheres = path.local_space_sphere
        center = path.local_space_curr_center[0].center
        local_sphere = spheres[0]
        local_sphere_1 = spheres[1] if path.num_sphere > 1 else None
        c = local_sphere.center
        movement = Vec3(c.x - center.x, c.y - center.y, c.z - center.z)
        root = self.root_node

        if path.insert_type == InsertType.PLACEMENT or path.obstruction_ethereal:
            clear_cell = True
            if path.building_check:
                clear_cell = not path.hits_interior_cell
            if root.sphere_intersects_solid(local_sphere, clear_cell) or (
                path.num_sphere > 1 and root.sphere_intersects_solid(local_sphere_1, clear_cell)  # type: ignore[arg-type]
            ):
                return _COLLIDED
            return _OK

        if path.check_walkable:
            return self.check_walkable(path, local_sphere, scale)

        if path.step_down:
            return self.step_sphere_down(transition, local_sphere, scale)

        if path.collide:
            valid_pos = Sphere(local_sphere.center, local_sphere.radius)
            hit_poly = root.find_walkable(path, valid_pos, movement, path.local_space_z)
            if hit_poly is None:
                return _OK
            return _land_on_walkable(transition, valid_pos, hit_poly, local_sphere.center, scale, True)

        state = transition.object_info.state
        hit = PolyHit()

        if state & OI.CONTACT:
            if root.sphere_intersects_poly(local_sphere, movement, hit):
                return self.step_sphere_up(transition, hit.poly.plane.normal)  # type: ignore[union-attr]
            if path.num_sphere > 1:
                # the head sphere has its own polygon; the contact point is shared
                hit_1 = PolyHit()
                hit_1.contact_point = hit.contact_point
                if root.sphere_intersects_poly(local_sphere_1, movement, hit_1):  # type: ignore[arg-type]
                    return self.slide_sphere(transition, hit_1.poly.plane.normal)  # type: ignore[union-attr]
                if hit_1.poly is not None:
                    return self.neg_poly_hit(path, hit_1.poly, False)
                if hit.poly is not None:
                    return self.neg_poly_hit(path, hit.poly, True)
            return _OK

        if root.sphere_intersects_poly(local_sphere, movement, hit) or hit.poly is not None:
            if state & OI.PATH_CLIPPED:
                return self.collide_with_pt(transition, local_sphere, center, hit.poly, hit.contact_point, scale)  # type: ignore[arg-type]
            normal = _global_vec(path, hit.poly.plane.normal)  # type: ignore[union-attr]
            path.walkable_allowance = LANDING_Z
            path.set_collide(normal)
            return _ADJUSTED

        if path.num_sphere > 1:
            # `hit.found()`, not `hit.poly`: the test above narrowed `hit.poly` to None, and the
            # compiled build would check that narrowed type against the polygon this query sets
            if root.sphere_intersects_poly(local_sphere_1, movement, hit) or hit.found() is not None:  # type: ignore[arg-type]
                poly = hit.found()  # set by the query above
                assert poly is not None
                normal = _global_vec(path, poly.plane.normal)
                transition.collision_info.set_collision_normal(normal)
                return _COLLIDED

        return _OK

    def check_walkable(self, path: SpherePath, check_pos: Sphere, scale: float) -> int:
        """The walkable probe: COLLIDED when a walkable polygon holds up the
        sphere, else OK (BSPTREE::check_walkable; `scale` is unused)."""
        valid_pos = Sphere(check_pos.center, check_pos.radius)
        if self.root_node.hits_walkable(path, valid_pos, path.local_space_z):
            return _COLLIDED
        return _OK

    def step_sphere_down(self, transition: Transition, check_pos: Sphere, scale: float) -> int:
        """Look for a floor below the sphere within the remaining step-down
        distance (BSPTREE::step_sphere_down).

        On finding one: moves the check position onto it (without
        invalidating the cell array, unlike add_offset_to_check_pos), sets
        the contact plane (global, d times scale, not water, in the check
        position's cell) and the walkable, and returns ADJUSTED. Else OK.
        """
        path = transition.sphere_path
        step_down_amount = -(path.step_down_amt * path.walk_interp)
        movement = path.local_space_z * step_down_amount * (1.0 / scale)
        valid_pos = Sphere(check_pos.center, check_pos.radius)
        poly_hit = self.root_node.find_walkable(path, valid_pos, movement, path.local_space_z)
        if poly_hit is None:
            return _OK
        # the cell array stays valid here, unlike add_offset_to_check_pos
        return _land_on_walkable(transition, valid_pos, poly_hit, check_pos.center, scale, False)

    def step_sphere_up(self, transition: Transition, collision_normal: Vec3) -> int:
        """Try to step up onto what the sphere ran into; slide along it when
        that fails (BSPTREE::step_sphere_up). `collision_normal` is local."""
        path = transition.sphere_path
        glob_normal = _global_vec(path, collision_normal)
        if transition.step_up(glob_normal):
            return _OK
        return path.step_up_slide(transition)

    def slide_sphere(self, transition: Transition, collision_normal: Vec3) -> int:
        """Slide the foot sphere along a local-space normal
        (BSPTREE::slide_sphere, i.e. the global sphere's SlideSphere from the
        current center)."""
        path = transition.sphere_path
        glob_normal = _global_vec(path, collision_normal)
        return transition.slide_sphere(glob_normal, path.global_curr_center[0].center)

    def neg_poly_hit(self, path: SpherePath, hit_poly: Polygon, step_up: bool) -> int:
        """Defer a polygon hit to the transition (BSPTREE::NegPolyHit); OK."""
        normal = _global_vec(path, hit_poly.plane.normal)
        path.set_neg_poly_hit(step_up, normal)
        return _OK

    def collide_with_pt(
        self,
        transition: Transition,
        check_pos: Sphere,
        cur_pos: Vec3,
        hit_poly: Polygon,
        contact_point: Vec3,
        scale: float,
    ) -> int:
        """A path-clipped mover hit `hit_poly` (BSPTREE::collide_with_pt).

        Without PerfectClip: record the polygon's normal as the collision
        normal, COLLIDED. With it: move the check position back to where the
        sphere touches (adjust_to_plane), record the normal, ADJUSTED; if that
        fails, COLLIDED with no collision normal recorded.
        """
        path = transition.sphere_path
        ci = transition.collision_info
        local_space_pos = path.local_space_pos
        assert local_space_pos is not None
        collision_normal = _global_vec(path, hit_poly.plane.normal)
        if not transition.object_info.state & OI.PERFECT_CLIP:
            ci.set_collision_normal(collision_normal)
            return _COLLIDED
        valid_pos = Sphere(check_pos.center, check_pos.radius)
        if not self.adjust_to_plane(valid_pos, cur_pos, hit_poly, contact_point):
            return _COLLIDED
        ci.set_collision_normal(collision_normal)
        offset = _global_offset(path, valid_pos.center, check_pos.center, scale)
        path.add_offset_to_check_pos(offset)
        return _ADJUSTED

    def adjust_to_plane(self, check_pos: Sphere, cur_pos: Vec3, hit_poly: Polygon, contact_point: Vec3) -> bool:
        """Search the time along cur_pos -> check_pos at which the sphere
        just touches (BSPTREE::adjust_to_plane, 15 iterations).

        Moves `check_pos` in place. Transcribed as the reference has it: a
        first loop that only accepts a touch time of exactly 1 (the sphere
        at `cur_pos` overlapping the plane) and stops once the sphere there
        hits nothing, then a bisection between the bounds found. Since both
        bounds are then 1, the bisection gives up at once: the routine
        answers False whatever the geometry (so PerfectClip collisions end
        COLLIDED). Kept literally so as to agree with the reference.
        """
        movement = check_pos.center - cur_pos
        lower_time = 0.0
        upper_time = 1.0
        hit = PolyHit()
        hit.poly = hit_poly
        hit.contact_point = contact_point
        root = self.root_node
        max_iterations = ADJUST_TO_PLANE_ITERATIONS
        for i in range(max_iterations):
            touch_time = hit.poly.adjust_sphere_to_poly(check_pos, cur_pos, movement)  # type: ignore[union-attr]
            if touch_time == 1.0:
                check_pos.center = cur_pos + movement * touch_time
                if not root.sphere_intersects_poly(check_pos, movement, hit):
                    lower_time = touch_time
                    break
                upper_time = touch_time
            if i == max_iterations - 1:
                return False
        for _ in range(max_iterations):
            average_time = (lower_time + upper_time) * 0.5
            check_pos.center = cur_pos + movement * average_time
            if not root.sphere_intersects_poly(check_pos, movement, hit):
                upper_time = (lower_time + upper_time) * 0.5
            else:
                lower_time = (lower_time + upper_time) * 0.5
            if upper_time - lower_time < 0.02:
                return False
        return True

    def placement_insert(self, transition: Transition) -> int:
        """Push the path's spheres out of solid geometry for an initial
        placement (BSPTREE::placement_insert, 20 iterations).

        Each round tests the foot sphere, then the head sphere, with the
        test radius starting at the foot's radius; a touched polygon pushes
        both spheres along its normal (adjust_to_placement_poly), a solid
        center without a polygon doubles the radius. OK when the first round
        finds nothing, ADJUSTED (check position moved by the push) when a
        later one does, COLLIDED after 20 rounds. As in the reference, the
        touched polygon is remembered across rounds.
        """
        path = transition.sphere_path
        s0 = path.local_space_sphere[0]
        valid_pos = Sphere(s0.center, s0.radius)
        rad = valid_pos.radius
        valid_pos_1: Sphere | None = None
        if path.num_sphere > 1:
            s1 = path.local_space_sphere[1]
            valid_pos_1 = Sphere(s1.center, s1.radius)
        clear_cell = True
        if path.building_check:
            clear_cell = not path.hits_interior_cell
        root = self.root_node
        hit = PolyHit()
        for i in range(PLACEMENT_ITERATIONS):
            hit.center_solid = False
            if root.sphere_intersects_solid_poly(valid_pos, rad, hit, clear_cell):
                if hit.poly is not None:
                    hit.poly.adjust_to_placement_poly(valid_pos, valid_pos_1, rad, hit.center_solid, clear_cell)
                    continue
            elif path.num_sphere >= 2:
                assert valid_pos_1 is not None
                if root.sphere_intersects_solid_poly(valid_pos_1, rad, hit, clear_cell):
                    if hit.poly is not None:
                        hit.poly.adjust_to_placement_poly(valid_pos_1, valid_pos, rad, hit.center_solid, clear_cell)
                        continue
                else:
                    return self.placement_insert_inner(valid_pos, path, i)
            else:
                return self.placement_insert_inner(valid_pos, path, i)
            rad *= 2.0
        return _COLLIDED

    def placement_insert_inner(self, valid_pos: Sphere, path: SpherePath, i: int) -> int:
        """OK if placement needed no push (round 0); else move the check
        position by the push, ADJUSTED (no scale applied, as in the reference)."""
        if i == 0:
            return _OK
        path.add_offset_to_check_pos(_global_offset(path, valid_pos.center, path.local_space_sphere[0].center, 1.0))
        return _ADJUSTED
