"""Placing an object: entering the world, teleporting, initial placement.

Placement does not sweep a path; it tests the spot (Placement insert type:
overlap only), and when sliding is allowed searches rings of growing radius
around it for a free spot, then lands the object with a LandingZ step-down.
"""

from __future__ import annotations

import math
from typing import Final, TYPE_CHECKING

from ..constants import EPSILON, LANDING_Z
from ..geometry import Vec3
from .state import InsertType, TransitionState

if TYPE_CHECKING:
    from .transition import Transition

__all__ = [
    "find_placement_position",
    "find_placement_pos",
    "validate_placement",
    "validate_placement_transition",
    "placement_insert",
]

_OK: Final = TransitionState.OK
_COLLIDED: Final = TransitionState.COLLIDED


def placement_insert(t: Transition) -> int:
    """Collide the check position with its cell and the cells around (PlacementInsert)."""
    path = t.sphere_path
    if path.check_cell is None:
        return _COLLIDED
    check_cell = path.check_cell
    state = t.insert_into_cell(check_cell, 3)
    if state == _OK:
        state = t.check_other_cells(check_cell)
    return state


def _accept_check_pos(t: Transition) -> None:
    """The check position becomes the current one (shared by both validations)."""
    path = t.sphere_path
    path.curr_pos = path.check_pos
    path.curr_cell = path.check_cell
    path.cache_global_curr_center()


def validate_placement(t: Transition, state: int, adjust: bool) -> int:
    """Accept the check position, or retry once after an adjustment (ValidatePlacement)."""
    path = t.sphere_path
    if path.check_cell is None:
        return _COLLIDED
    if state == _OK:
        _accept_check_pos(t)
    elif state in (TransitionState.ADJUSTED, TransitionState.SLID):
        if adjust:
            return validate_placement(t, placement_insert(t), False)
    return state


def validate_placement_transition(t: Transition, state: int) -> int:
    """ValidatePlacementTransition: accept OK; otherwise forget what was touched."""
    path = t.sphere_path
    if path.check_cell is None:
        return _COLLIDED
    if state == _OK:
        _accept_check_pos(t)
    elif state in (_COLLIDED, TransitionState.ADJUSTED, TransitionState.SLID):
        if path.placement_allows_sliding and t.object_info.target_id == 0:
            t.collision_info.reset_collide_objects()
    return state


def _placement_fits(t: Transition) -> bool:
    """Does the check position take the object? Contact and sliding are
    forgotten first (the test FindPlacementPos makes at the spot and at every
    point of its rings)."""
    ci = t.collision_info
    ci.sliding_normal_valid = False
    ci.contact_plane_valid = False
    ci.contact_plane_is_water = False
    return validate_placement_transition(t, t.transitional_insert(3)) == _OK


def find_placement_pos(t: Transition) -> bool:
    """Test the spot, then rings around it out to 4 m (FindPlacementPos)."""
    path = t.sphere_path
    path.set_check_pos(path.curr_pos, path.curr_cell)  # type: ignore[arg-type]
    if _placement_fits(t):
        return True
    if not path.placement_allows_sliding:
        return False

    adjust_rad = 4.0
    sphere_rad = path.local_sphere[0].radius
    fake_sphere = False
    if sphere_rad < 0.125:
        fake_sphere = True
        adjust_rad = 2.0
    elif sphere_rad < 0.48:
        sphere_rad = 0.48

    f_num_steps = 4.0 / sphere_rad
    if fake_sphere:
        f_num_steps *= 0.5
    if f_num_steps <= 1.0:
        return False

    num_steps = math.ceil(f_num_steps)
    dist_per_step = adjust_rad / num_steps
    radians_per_step = math.pi * dist_per_step / sphere_rad

    total_dist = 0.0
    total_rad = 0.0
    for _ in range(num_steps):
        total_dist += dist_per_step
        total_rad += radians_per_step
        rad = math.ceil(total_rad) * 2
        angle = 360.0 / rad
        for j in range(rad):
            path.set_check_pos(path.curr_pos, path.curr_cell)  # type: ignore[arg-type]
            heading = math.radians(angle * j)
            offset = Vec3(math.sin(heading) * total_dist, math.cos(heading) * total_dist, 0.0)
            path.global_offset = t.adjust_offset(offset)
            if path.global_offset.length() >= EPSILON:
                path.add_offset_to_check_pos(path.global_offset)
                if _placement_fits(t):
                    return True
    return False


def find_placement_position(t: Transition) -> bool:
    """Place an object (FindPlacementPosition): initial-placement push-out,
    a free-spot search, then landing by a LandingZ step-down."""
    path = t.sphere_path
    ci = t.collision_info
    oi = t.object_info
    path.set_check_pos(path.curr_pos, path.curr_cell)  # type: ignore[arg-type]
    path.insert_type = InsertType.INITIAL_PLACEMENT

    if path.check_cell is not None:
        state = t.insert_into_cell(path.check_cell, 3)
        if state == _OK:
            state = t.check_other_cells(path.check_cell)
    else:
        state = _COLLIDED

    if validate_placement(t, state, True) != _OK:
        return False

    path.insert_type = InsertType.PLACEMENT
    if not find_placement_pos(t):
        return False

    if not oi.step_down:
        return validate_placement(t, _OK, True) == _OK

    path.walkable_allowance = LANDING_Z
    path.save_check_pos()
    saved_insert_type = path.insert_type
    path.insert_type = InsertType.TRANSITION

    g = path.global_sphere[0]
    step_down_height = oi.step_down_height
    if path.num_sphere < 2 and g.radius * 2.0 < step_down_height:
        step_down_height = g.radius * 0.5

    if step_down_height <= g.radius * 2.0:
        if not t.step_down(step_down_height, LANDING_Z):
            path.restore_check_pos()
            ci.contact_plane_valid = False
            ci.contact_plane_is_water = False
    else:
        step_down_height *= 0.5
        if not t.step_down(step_down_height, LANDING_Z) and not t.step_down(step_down_height, LANDING_Z):
            path.restore_check_pos()
            ci.contact_plane_valid = False
            ci.contact_plane_is_water = False

    path.insert_type = saved_insert_type
    path.walkable = None
    return validate_placement(t, _OK, True) == _OK
