"""Transition: moving an object's spheres from one Position toward another.

The pipeline, top to bottom (the client's CTransition):

    find_transitional_position      split the move into sub-steps of at most
      adjust_offset                 one sphere radius; bend each step along the
      transitional_insert           contact plane and sliding normal; collide
        insert_into_cell            the current cell, then its neighbours;
        check_other_cells           answer collisions by stepping up, stepping
        step_up / step_down         down, sliding or backing off;
        edge_slide
      validate_transition           accept or revert the step, track contact.

Stepping and edge slides live in `stepping.py`, slides in `slide.py`,
placement in `placement.py`, the terrain contact rule in `walkable.py`.
"""

from __future__ import annotations

import math
from typing import Final

from .._compat import mypyc_attr
from ..cells.cell_array import CellArray
from ..cells.find_cell_list import find_cell_list
from ..cells.landscape import Landscape
from ..cells.obj_cell import ObjCell
from ..constants import EPSILON, LANDING_Z
from ..geometry import UNIT_Z, ZERO, Plane, Position, Quat, Sphere, Vec3
from ..geometry.precision import fl, fl_cross, fl_dot, fl_normalize_check_small, fl_plane_dist, fl_scale, fl_sub
from ..geometry.landdefs import adjust_to_outside, get_block_offset
from . import placement, stepping, walkable
from .collision_info import CollisionInfo
from .interface import CellLookup
from .object_info import ObjectInfo
from ..settings import RETAIL, EngineSettings
from .slide import slide_sphere
from .sphere_path import ScaledSpheres, SpherePath
from .state import OI, InsertType, TransitionState

__all__ = ["Transition", "take_transition", "give_back"]

_OK: Final = TransitionState.OK
_COLLIDED: Final = TransitionState.COLLIDED
_ADJUSTED: Final = TransitionState.ADJUSTED
_SLID: Final = TransitionState.SLID
_INVALID: Final = TransitionState.INVALID


@mypyc_attr(allow_interpreted_subclasses=True)
class Transition:
    """One transition: ObjectInfo + SpherePath + CollisionInfo + CellArray.

    `world` is where cells are looked up by id (anything with
    `get_landcell(cell_id)`). Build one, set its parts (or call the init_*
    helpers) and call `find_valid_position()`; every stage is also callable on
    its own, as the client's code calls it.
    """

    __slots__ = ("object_info", "sphere_path", "collision_info", "cell_array", "settings", "single_precision", "world")

    def __init__(self, world: CellLookup, settings: EngineSettings = RETAIL, object_info: ObjectInfo | None = None) -> None:
        self.world = world
        self.settings = settings
        #: settings.single_precision, read once here for every routine of the move that
        #: rounds (the collision layer's too): set with the settings, by __init__ and reset
        self.single_precision = settings.single_precision
        self.object_info = ObjectInfo() if object_info is None else object_info
        self.sphere_path = SpherePath()
        self.sphere_path.single_precision = settings.single_precision
        self.collision_info = CollisionInfo(ace_normals=settings.ace_normals)
        self.cell_array = CellArray(world)

    def reset(self, world: CellLookup, settings: EngineSettings, object_info: ObjectInfo) -> None:
        """Start over as a new transition would (take_transition reuses a finished one this way)."""
        self.world = world
        self.settings = settings
        single = settings.single_precision
        self.single_precision = single
        self.object_info = object_info
        path = self.sphere_path
        path.reset()
        path.single_precision = single
        self.collision_info.reset(settings.ace_normals)
        self.cell_array.reset(world)

    # -- set-up -------------------------------------------------------------
    def init_object(self, object_info: ObjectInfo) -> None:
        self.object_info = object_info

    def init_sphere(self, spheres: list[Sphere], scale: float) -> None:
        self.sphere_path.init_sphere(spheres, scale)

    def init_scaled_spheres(self, scaled: ScaledSpheres) -> None:
        self.sphere_path.init_scaled_spheres(scaled)

    def init_path(self, begin_cell: ObjCell | None, begin_pos: Position | None, end_pos: Position) -> None:
        self.sphere_path.init_path(begin_cell, begin_pos, end_pos)

    def init_contact_plane(self, cell_id: int, plane: Plane, is_water: bool) -> None:
        self.init_last_known_contact_plane(cell_id, plane, is_water)
        ci = self.collision_info
        ci.contact_plane_valid = True
        ci.contact_plane = plane
        ci.contact_plane_is_water = is_water
        ci.contact_plane_cell_id = cell_id

    def init_last_known_contact_plane(self, cell_id: int, plane: Plane, is_water: bool) -> None:
        ci = self.collision_info
        ci.last_known_contact_plane_valid = True
        ci.last_known_contact_plane = plane
        ci.last_known_contact_plane_is_water = is_water
        ci.last_known_contact_plane_cell_id = cell_id

    def init_sliding_normal(self, normal: Vec3) -> None:
        ci = self.collision_info
        ci.sliding_normal_valid = True
        ci.sliding_normal = normal.normalized_or_none() or ZERO

    # -- the main loop --------------------------------------------------------
    def find_valid_position(self) -> bool:
        if self.sphere_path.insert_type == InsertType.TRANSITION:
            return self.find_transitional_position()
        return placement.find_placement_position(self)

    def calc_num_steps(self) -> tuple[Vec3, Vec3, int]:
        """Split the move into sub-steps of at most one sphere radius.

        Returns (offset, offset_per_step, num_steps). A viewer (camera) takes
        whole radius steps and a shorter last one (CalcNumSteps).
        """
        path = self.sphere_path
        if path.begin_pos is None:
            return ZERO, ZERO, 1
        assert path.end_pos is not None
        offset = path.begin_pos.get_offset(path.end_pos)
        dist = offset.length()
        step = dist / (path.local_sphere[0].radius * self.settings.step_length)
        if not self.object_info.state & OI.IS_VIEWER:
            if step > 1.0:
                num_steps = math.ceil(step)
                # offset * (1f / n), as the client splits it
                single = self.single_precision
                return offset, fl_scale(offset, fl(1.0 / num_steps, single), single), num_steps
            if offset.x != 0.0 or offset.y != 0.0 or offset.z != 0.0:
                return offset, offset, 1
            return offset, ZERO, 0
        if dist <= EPSILON:
            return offset, ZERO, 0
        return offset, offset * (1.0 / step), math.floor(step) + 1

    def find_transitional_position(self) -> bool:
        """Walk the path step by step (FindTransitionalPosition)."""
        path = self.sphere_path
        ci = self.collision_info
        oi = self.object_info
        if path.begin_cell is None:
            return False

        state = _OK
        offset, offset_per_step, num_steps = self.calc_num_steps()
        if num_steps > self.settings.max_steps:
            return False

        assert path.curr_pos is not None and path.end_pos is not None and path.begin_pos is not None
        if oi.state & OI.FREE_ROTATE:
            path.curr_pos = Position(path.curr_pos.cell_id, path.curr_pos.frame.with_orientation(path.end_pos.frame.orientation.normalized()))
        path.set_check_pos(path.curr_pos, path.curr_cell)

        if num_steps <= 0:
            if not oi.state & OI.FREE_ROTATE:
                path.curr_pos = Position(path.curr_pos.cell_id, path.curr_pos.frame.with_orientation(path.end_pos.frame.orientation.normalized()))
            path.hits_interior_cell = False
            find_cell_list(path.check_pos, path.num_sphere, path.global_sphere, self.cell_array, False, path)
            return True

        is_viewer = oi.state & OI.IS_VIEWER
        free_rotate = oi.state & OI.FREE_ROTATE
        begin_q = path.begin_pos.frame.orientation
        end_q = path.end_pos.frame.orientation
        rotating = not free_rotate and begin_q != end_q

        for step in range(num_steps):
            if is_viewer and step == num_steps - 1:
                offset_len = offset.length()
                if offset_len > EPSILON:
                    offset_per_step = offset * ((offset_len - path.local_sphere[0].radius * (num_steps - 1)) / offset_len)

            path.global_offset = self.adjust_offset(offset_per_step)
            if not is_viewer and path.global_offset.length_sq() < EPSILON * EPSILON:
                return step != 0 and state == _OK

            if not free_rotate:
                q = Quat.lerp(begin_q, end_q, (step + 1) / num_steps) if rotating else end_q
                if rotating or path.check_pos.frame.orientation != q:
                    path.check_pos = Position(path.check_pos.cell_id, path.check_pos.frame.with_orientation(q))

            ci.sliding_normal_valid = False
            ci.contact_plane_valid = False
            ci.contact_plane_is_water = False

            if path.insert_type != InsertType.TRANSITION:
                inserted = self.transitional_insert(3)
                state = placement.validate_placement_transition(self, inserted)
                if state == _OK:
                    return True
                if not path.placement_allows_sliding:
                    return False
                path.add_offset_to_check_pos(path.global_offset)
            else:
                path.add_offset_to_check_pos(path.global_offset)
                inserted = self.transitional_insert(3)
                state = self.validate_transition(inserted)
                if ci.frames_stationary_fall > 0:
                    break

            if ci.collision_normal_valid and oi.state & OI.PATH_CLIPPED:
                break

        return state == _OK

    def adjust_offset(self, offset: Vec3) -> Vec3:
        """Bend a step along the contact plane and away from the sliding normal,
        and lift the sphere back above the contact plane (AdjustOffset).

        At the working precision; in single precision as the client computes
        it: the lift puts a resting sphere back on its plane every step, and
        its float64 value rounds to a different float32 height often enough
        to decide the next EPSILON test differently.
        """
        single = self.single_precision
        ci = self.collision_info
        check_slide = False
        sn = ci.sliding_normal
        sliding_angle = 0.0
        if ci.sliding_normal_valid:
            sliding_angle = fl_dot(offset.x, offset.y, offset.z, sn.x, sn.y, sn.z, single)
            if sliding_angle < 0.0:
                check_slide = True
            else:
                ci.sliding_normal_valid = False

        if not ci.contact_plane_valid:
            if check_slide:
                offset = fl_sub(offset, fl_scale(sn, sliding_angle, single), single)
            return offset

        plane = ci.contact_plane
        n = plane.normal
        if check_slide:
            crease = fl_normalize_check_small(fl_cross(n, sn, single), single)
            offset = ZERO if crease is None else fl_scale(crease, fl_dot(crease.x, crease.y, crease.z, offset.x, offset.y, offset.z, single), single)
        else:
            collision_angle = fl_dot(offset.x, offset.y, offset.z, n.x, n.y, n.z, single)
            if collision_angle <= 0.0:
                offset = fl_sub(offset, fl_scale(n, collision_angle, single), single)
            else:
                offset = plane.snap_to_plane(offset, single)

        if ci.contact_plane_cell_id == 0 or ci.contact_plane_is_water:
            return offset

        path = self.sphere_path
        g = path.global_sphere[0]
        block_offset = get_block_offset(path.check_pos.cell_id, ci.contact_plane_cell_id)
        c = g.center if block_offset is ZERO else fl_sub(g.center, block_offset, single)
        dist = fl_plane_dist(c.x, c.y, c.z, plane, single)
        if dist >= fl(g.radius - EPSILON, single):
            return offset
        z_dist = fl(fl(g.radius - dist, single) / n.z, single)
        if g.radius > abs(z_dist):
            path.add_offset_to_check_pos(Vec3(0.0, 0.0, z_dist))
        return offset

    # -- one sub-step -----------------------------------------------------------
    def transitional_insert(self, num_insertion_attempts: int) -> int:
        """Collide the check position and respond, a few times (TransitionalInsert)."""
        path = self.sphere_path
        ci = self.collision_info
        oi = self.object_info
        # tested through a local: narrowing `path.check_cell` itself would make the compiled build check
        # each later read of it for a cell, and a slide or step may clear it between rounds
        start_cell = path.check_cell
        if start_cell is None:
            return _OK
        if num_insertion_attempts <= 0:
            return _INVALID

        state = _INVALID
        for _attempt in range(num_insertion_attempts):  # (named: compiled, `_` is boxed every turn)
            state = self.insert_into_cell(path.check_cell, num_insertion_attempts)
            if state == _OK:
                state = self.check_other_cells(path.check_cell)
                if state != _OK:
                    path.neg_poly_hit = False
                if state == _COLLIDED:
                    return state
            elif state == _COLLIDED:
                return state
            elif state == _ADJUSTED:
                path.neg_poly_hit = False
            elif state == _SLID:
                ci.contact_plane_valid = False
                ci.contact_plane_is_water = False
                path.neg_poly_hit = False

            if state != _OK:
                continue

            if not path.collide:
                if path.neg_poly_hit and not path.step_down and not path.step_up:
                    # the head sphere's deferred hit: step up onto it or slide off it
                    path.neg_poly_hit = False
                    if path.neg_step_up:
                        if not self.step_up(path.neg_collision_normal):
                            state = path.step_up_slide(self)
                    else:
                        state = slide_sphere(self, path.neg_collision_normal, path.global_curr_center[0].center)
                    continue

                if (
                    ci.contact_plane_valid
                    or not oi.state & OI.CONTACT
                    or path.step_down
                    or path.check_cell is None
                    or not oi.step_down
                ):
                    return _OK

                # In contact but nothing under us: look for ground a step below.
                z_val, step_down_height = oi.step_search(oi.step_down_height)
                path.walkable_allowance = z_val
                path.save_check_pos()

                radsum = path.global_sphere[0].radius * 2.0
                if path.num_sphere < 2 and radsum < step_down_height:
                    step_down_height = path.global_sphere[0].radius * 0.5

                if radsum >= step_down_height:
                    if self.step_down(step_down_height, z_val):
                        path.walkable = None
                        return _OK
                else:
                    step_down_height *= 0.5
                    if self.step_down(step_down_height, z_val) or self.step_down(step_down_height, z_val):
                        path.walkable = None
                        return _OK

                done, state = stepping.edge_slide(self, state, step_down_height, z_val)
                if done:
                    return state
            else:
                # A collision set collide mode: accept only if we now stand on walkable ground.
                reset = False
                path.collide = False
                if ci.contact_plane_valid and stepping.check_walkable(self, LANDING_Z):
                    saved_insert_type = path.insert_type
                    path.insert_type = InsertType.PLACEMENT
                    state = self.transitional_insert(num_insertion_attempts)
                    path.insert_type = saved_insert_type
                    if state != _OK:
                        state = _OK
                        reset = True
                else:
                    reset = True

                path.walkable = None
                if not reset:
                    return state

                path.restore_check_pos()
                ci.contact_plane_valid = False
                ci.contact_plane_is_water = False
                if ci.last_known_contact_plane_valid:
                    ci.last_known_contact_plane_valid = False
                    oi.stop_velocity()
                else:
                    ci.set_collision_normal(path.step_up_normal)
                return _COLLIDED
        return state

    def insert_into_cell(self, cell: ObjCell | None, num_insertion_attempts: int) -> int:
        """Collide with one cell until it stops sliding us (InsertIntoCell)."""
        if cell is None:
            return _COLLIDED
        ci = self.collision_info
        state = _OK
        for _attempt in range(num_insertion_attempts):
            state = cell.find_collisions(self)
            if state == _OK or state == _COLLIDED:
                return state
            if state == _SLID:
                ci.contact_plane_valid = False
                ci.contact_plane_is_water = False
        return state

    def check_other_cells(self, curr_cell: ObjCell | None) -> int:
        """Collide with every other cell the spheres touch, then re-home the
        check position into the cell that holds it (CheckOtherCells)."""
        path = self.sphere_path
        ci = self.collision_info
        path.hits_interior_cell = False
        new_cell = find_cell_list(path.check_pos, path.num_sphere, path.global_sphere, self.cell_array, True, path)

        for cell in self.cell_array.cells():
            if cell is None or cell is curr_cell:
                continue
            state = cell.find_collisions(self)
            if state == _SLID:
                ci.contact_plane_valid = False
                ci.contact_plane_is_water = False
                return state
            if state == _COLLIDED or state == _ADJUSTED:
                return state

        path.check_cell = new_cell
        if new_cell is not None:
            path.adjust_check_pos(new_cell.id)
            return _OK

        if path.step_down:
            return _COLLIDED

        check_pos = path.check_pos
        cell_id = check_pos.cell_id
        origin = check_pos.frame.origin
        if (cell_id & 0xFFFF) < 0x100:
            cell_id, origin = adjust_to_outside(cell_id, origin)
        if cell_id != 0:
            path.adjust_check_pos(cell_id)
            path.set_check_pos(Position(cell_id, check_pos.frame.with_origin(origin)), None)
            return _OK
        return _COLLIDED

    def build_cell_array(self) -> None:
        path = self.sphere_path
        path.hits_interior_cell = False
        find_cell_list(path.check_pos, path.num_sphere, path.global_sphere, self.cell_array, False, path)

    # -- after each step ----------------------------------------------------------
    def validate_transition(self, state: int) -> int:
        """Accept or revert the step and update contact state (ValidateTransition)."""
        path = self.sphere_path
        ci = self.collision_info
        oi = self.object_info
        moved = True

        assert path.curr_pos is not None
        if state != _OK or path.check_pos.equals(path.curr_pos):
            moved = False
            if state != _OK:
                if state != _INVALID:
                    if ci.last_known_contact_plane_valid:
                        oi.stop_velocity()
                        plane = ci.last_known_contact_plane
                        angle = plane.normal.dot(path.global_curr_center[0].center) + plane.d
                        if path.global_sphere[0].radius + EPSILON > abs(angle):
                            ci.set_contact_plane(plane, ci.last_known_contact_plane_is_water)
                            ci.contact_plane_cell_id = ci.last_known_contact_plane_cell_id
                            if oi.state & OI.ON_WALKABLE:
                                moved = True
                    if not ci.collision_normal_valid:
                        ci.set_collision_normal(UNIT_Z)
                    path.set_check_pos(path.curr_pos, path.curr_cell)
                    self.build_cell_array()
                    state = _OK
            else:
                self.set_current_check_pos()
        else:
            self.set_current_check_pos()

        if ci.collision_normal_valid:
            ci.set_sliding_normal(ci.collision_normal)

        if not oi.state & OI.IS_VIEWER and oi.gravity:
            if not moved:
                if ci.frames_stationary_fall > 0:
                    if ci.frames_stationary_fall > 1:
                        # Stuck for three frames under gravity: stand on a synthetic floor.
                        ci.frames_stationary_fall = 3
                        g = path.global_sphere[0]
                        floor = Plane(UNIT_Z, g.radius - g.center.z)
                        ci.set_contact_plane(floor, False)
                        ci.contact_plane_cell_id = path.check_pos.cell_id
                        if not oi.state & OI.CONTACT:
                            ci.set_collision_normal(UNIT_Z)
                            ci.collided_with_environment = True
                    else:
                        ci.frames_stationary_fall = 2
                else:
                    ci.frames_stationary_fall = 1
            else:
                ci.frames_stationary_fall = 0

        ci.last_known_contact_plane_valid = ci.contact_plane_valid
        if ci.contact_plane_valid:
            ci.last_known_contact_plane = ci.contact_plane
            ci.last_known_contact_plane_cell_id = ci.contact_plane_cell_id
            ci.last_known_contact_plane_is_water = ci.contact_plane_is_water
            oi.state |= OI.CONTACT
            if oi.is_valid_walkable(ci.contact_plane.normal):
                oi.state |= OI.ON_WALKABLE
            else:
                oi.state &= ~OI.ON_WALKABLE
        else:
            oi.state &= ~(OI.CONTACT | OI.ON_WALKABLE)
        return state

    def set_current_check_pos(self) -> None:
        path = self.sphere_path
        path.curr_pos = path.check_pos
        path.curr_cell = path.check_cell
        path.cache_global_curr_center()
        path.set_check_pos(path.curr_pos, path.curr_cell)

    # -- delegates (the client keeps these on CTransition) -------------------------
    def step_up(self, collision_normal: Vec3) -> bool:
        return stepping.step_up(self, collision_normal)

    def step_down(self, step_down_height: float, z_val: float) -> bool:
        return stepping.step_down(self, step_down_height, z_val)

    def slide_sphere(self, collision_normal: Vec3, curr_center: Vec3) -> int:
        """SlideSphere of the path's foot sphere along a global normal (slide.py),
        for the BSP and the objects, which see the transition only through its methods."""
        return slide_sphere(self, collision_normal, curr_center)

    def check_walkable(self, z_check: float) -> bool:
        return stepping.check_walkable(self, z_check)

    def validate_walkable(self, check_sphere: Sphere, plane: Plane, is_water: bool, water_depth: float, cell_id: int) -> int:
        return walkable.validate_walkable(self, check_sphere, plane, is_water, water_depth, cell_id)

    def placement_insert(self) -> int:
        return placement.placement_insert(self)


def take_transition(world: CellLookup, settings: EngineSettings, object_info: ObjectInfo) -> Transition:
    """A transition as Transition(world, settings, object_info) makes it: the landscape's spare one (its
    last move's, given back) reset, else a new one. Reusing it spares a move building and freeing a
    transition's path, collision info and cell array (the client keeps its transitions in a pool too)."""
    if isinstance(world, Landscape):
        t = world.spare_transition
        if t is not None:
            world.spare_transition = None
            t.reset(world, settings, object_info)
            return t
    return Transition(world, settings, object_info)


def give_back(t: Transition) -> None:
    """`t`'s move is over and nothing keeps it: its landscape's next take_transition may reuse it."""
    world = t.world
    if type(t) is Transition and isinstance(world, Landscape):
        world.spare_transition = t
