"""Stepping up onto obstacles, down onto ground, and sliding along edges.

StepUp raises nothing: the sphere is already where the blocked step put it;
it probes *down* from there by the object's step-up height for walkable
ground. StepDown lowers the check position and collides it with the step-down
flag set, so the cells answer with the ground they find.
"""

from __future__ import annotations

from typing import Final, TYPE_CHECKING

from ..geometry import ZERO, Plane, Vec3
from ..geometry.precision import fl_add, fl_cross, fl_dot, fl_normalize_check_small, fl_scale, fl_sub
from ..geometry.landdefs import get_block_offset
from .state import OI, InsertType, TransitionState

if TYPE_CHECKING:
    from .transition import Transition

__all__ = ["step_up", "step_down", "check_walkable", "edge_slide", "cliff_slide", "set_edge_slide"]

_OK: Final = TransitionState.OK
_COLLIDED: Final = TransitionState.COLLIDED


def step_up(t: Transition, collision_normal: Vec3) -> bool:
    """Try to climb onto what we walked into (Transition.StepUp)."""
    path = t.sphere_path
    ci = t.collision_info
    oi = t.object_info
    ci.contact_plane_valid = False
    ci.contact_plane_is_water = False

    path.step_up = True
    path.step_up_normal = collision_normal

    z_landing, step_down_height = oi.step_search(oi.step_up_height)
    path.walkable_allowance = z_landing
    path.backup_cell = path.check_cell
    path.backup_check_pos = path.check_pos

    stepped = step_down(t, step_down_height, z_landing)

    path.step_up = False
    path.walkable = None
    if not stepped:
        path.restore_check_pos()
    return stepped


def step_down(t: Transition, step_down_height: float, z_val: float) -> bool:
    """Probe down by `step_down_height` for ground walkable at `z_val`
    and confirm the spot with a placement check (Transition.StepDown)."""
    path = t.sphere_path
    ci = t.collision_info
    path.neg_poly_hit = False
    path.step_down = True
    path.step_down_amt = step_down_height
    path.walk_interp = 1.0

    if not path.step_up:
        path.shift_check_pos(Vec3(0.0, 0.0, -step_down_height))

    state = t.transitional_insert(5)
    path.step_down = False

    if (
        state == _OK
        and ci.contact_plane_valid
        and ci.contact_plane.normal.z >= z_val
        and (not t.object_info.state & OI.EDGE_SLIDE or path.step_up or check_walkable(t, z_val))
    ):
        saved_insert_type = path.insert_type
        path.insert_type = InsertType.PLACEMENT
        state = t.transitional_insert(1)
        path.insert_type = saved_insert_type
        return state == _OK
    return False


def check_walkable(t: Transition, z_check: float) -> bool:
    """Is there walkable ground a step below? (Transition.CheckWalkable)

    True when the object is not on walkable ground, when the remembered
    walkable polygon still supports it, or when a probe one step down
    collides with something.
    """
    path = t.sphere_path
    oi = t.object_info
    if not oi.state & OI.ON_WALKABLE or path.check_walkables():
        return True

    path.backup_check_pos = path.check_pos
    path.backup_cell = path.check_cell

    step_height = oi.step_down_height
    path.walkable_allowance = z_check
    path.check_walkable = True

    g = path.global_sphere[0]
    if path.num_sphere < 2 and step_height > g.radius * 2.0:
        step_height = g.radius * 0.5
    if step_height > g.radius * 2.0:
        step_height *= 0.5

    path.add_offset_to_check_pos(Vec3(0.0, 0.0, -step_height))
    state = t.transitional_insert(1)

    path.check_walkable = False
    assert path.backup_check_pos is not None
    path.set_check_pos(path.backup_check_pos, path.backup_cell)
    return state != _OK


def cliff_slide(t: Transition, contact_plane: Plane) -> int:
    """Slide sideways along the crease between an unwalkable slope and the
    last ground we stood on (Transition.CliffSlide)."""
    path = t.sphere_path
    ci = t.collision_info
    single = t.single_precision
    crease = fl_cross(contact_plane.normal, ci.last_known_contact_plane.normal, single)
    # the horizontal direction across the crease: (-cy, cx, 0) of the z-less crease
    n = fl_normalize_check_small(Vec3(-crease.y, crease.x, 0.0), single)
    if n is None:
        return _OK
    assert path.curr_pos is not None
    block_offset = get_block_offset(path.curr_pos.cell_id, path.check_pos.cell_id)
    moved = fl_sub(path.global_sphere[0].center, path.global_curr_center[0].center, single)
    if block_offset is not ZERO:
        moved = fl_add(moved, block_offset, single)
    angle = fl_dot(n.x, n.y, n.z, moved.x, moved.y, moved.z, single)
    if angle <= 0.0:
        path.add_offset_to_check_pos(fl_scale(n, angle, single))
        ci.set_collision_normal(n)
    else:
        path.add_offset_to_check_pos(fl_scale(n, -angle, single))
        ci.set_collision_normal(-n)
    return TransitionState.ADJUSTED


def set_edge_slide(t: Transition, unwalkable: bool, state: int) -> int:
    """Undo an edge-slide probe (SetEdgeSlide). The client's valid_cell flag
    only marked the cell array valid, which nothing reads, so it is gone."""
    path = t.sphere_path
    ci = t.collision_info
    if unwalkable:
        path.walkable = None
    path.restore_check_pos()
    ci.contact_plane_valid = False
    ci.contact_plane_is_water = False
    return state


def edge_slide(t: Transition, state: int, step_down_height: float, z_val: float) -> tuple[bool, int]:
    """Keep a grounded creature from walking off an edge (Transition.EdgeSlide).

    Returns (done, state): `done` tells TransitionalInsert to return `state`
    now; otherwise it tries again with `state`.
    """
    path = t.sphere_path
    ci = t.collision_info
    oi = t.object_info
    if not oi.state & OI.ON_WALKABLE or not oi.state & OI.EDGE_SLIDE:
        return True, set_edge_slide(t, True, _OK)

    if ci.contact_plane_valid and ci.contact_plane.normal.z < z_val:
        return False, set_edge_slide(t, True, cliff_slide(t, ci.contact_plane))

    if path.walkable is not None:
        state = set_edge_slide(t, False, path.precipice_slide(t))
        return state == _COLLIDED, state

    if ci.contact_plane_valid:
        return True, set_edge_slide(t, True, _OK)

    # Nothing below: step back to where we were and look for the edge from there.
    back = path.global_curr_center[0].center - path.global_sphere[0].center
    path.add_offset_to_check_pos(back)
    step_down(t, step_down_height, z_val)
    ci.contact_plane_valid = False
    ci.contact_plane_is_water = False
    path.restore_check_pos()

    # read through a call: the step-down above may have found a walkable
    if path.current_walkable() is not None:
        assert path.walkable_pos is not None
        path.cache_local_space_sphere(path.walkable_pos, path.walkable_scale)
        path.set_walkable_check_pos(path.local_space_sphere[0])
        state = path.precipice_slide(t)
        return state == _COLLIDED, state

    path.walkable = None
    return True, _COLLIDED
