"""Slides: turning a blocked step into motion along the obstacle."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..constants import EPSILON
from ..geometry import ZERO, Sphere, Vec3
from ..geometry.precision import fl, fl_add, fl_cross, fl_dot, fl_normalize_check_small, fl_scale, fl_sub
from ..geometry.landdefs import get_block_offset
from .state import TransitionState

if TYPE_CHECKING:
    from .transition import Transition

__all__ = ["slide_sphere", "slide_sphere_object"]


def slide_sphere(t: Transition, collision_normal: Vec3, curr_center: Vec3, sphere: Sphere | None = None) -> int:
    """Slide a path sphere along a wall (Sphere.SlideSphere, environment variant).

    The step's displacement (from `curr_center`, the sphere at the current
    position, to the check position) is projected onto the crease between the
    wall and the ground we stand on; with no crease (wall parallel to the
    ground) it is pushed straight out of the wall. `sphere` is the path sphere
    that slides (the foot sphere unless given; object collisions slide the
    head sphere too).
    Decompiled client: FUN_00538180 (the seed, transition_pseudocode.md).
    """
    path = t.sphere_path
    ci = t.collision_info
    g = path.global_sphere[0] if sphere is None else sphere
    if collision_normal.x == 0.0 and collision_normal.y == 0.0 and collision_normal.z == 0.0:
        path.add_offset_to_check_pos((curr_center - g.center) * 0.5)
        return TransitionState.ADJUSTED

    ci.set_collision_normal(collision_normal)
    assert path.curr_pos is not None
    block_offset = get_block_offset(path.curr_pos.cell_id, path.check_pos.cell_id)
    displacement = block_offset + (g.center - curr_center)

    plane = ci.contact_plane if ci.contact_plane_valid else ci.last_known_contact_plane
    crease = collision_normal.cross(plane.normal)
    crease_len_sq = crease.length_sq()
    if crease_len_sq >= EPSILON:
        along = crease * (crease.dot(displacement) * (1.0 / crease_len_sq))
        if along.length_sq() < EPSILON:
            return TransitionState.COLLIDED
        path.add_offset_to_check_pos(along - displacement)
        return TransitionState.SLID

    if collision_normal.dot(plane.normal) >= 0.0:
        path.add_offset_to_check_pos(collision_normal * -collision_normal.dot(displacement))
        return TransitionState.SLID

    # Wall and ground face each other: give up this step, head back.
    back = (-displacement).normalized_or_none()
    if back is not None:
        ci.set_collision_normal(back)
    return TransitionState.OK


def slide_sphere_object(t: Transition, obstacle_center: Vec3, disp: Vec3, sphere_num: int) -> int:
    """Slide off another object's sphere (Sphere.SlideSphere, object variant).

    At the working precision, in the order the client's expressions evaluate
    (the skid is (offset . dir) dir, then scaled by 1 / |dir|^2).
    Decompiled client: FUN_00538eb0 (the seed, transition_pseudocode.md)."""
    single = t.single_precision
    path = t.sphere_path
    ci = t.collision_info
    g = path.global_sphere[sphere_num]
    curr = path.global_curr_center[sphere_num].center
    n = fl_normalize_check_small(fl_sub(curr, obstacle_center, single), single)
    if n is None:
        return TransitionState.COLLIDED
    ci.set_collision_normal(n)

    plane = ci.contact_plane if ci.contact_plane_valid else ci.last_known_contact_plane
    skid_dir = plane.normal
    direction = fl_cross(n, skid_dir, single)
    assert path.curr_pos is not None
    block_offset = get_block_offset(path.curr_pos.cell_id, path.check_pos.cell_id)
    off = fl_sub(g.center, curr, single)
    if block_offset is not ZERO:
        off = fl_add(off, block_offset, single)
    dir_len_sq = fl_dot(direction.x, direction.y, direction.z, direction.x, direction.y, direction.z, single)
    if dir_len_sq >= EPSILON:
        skid = fl_scale(direction, fl_dot(off.x, off.y, off.z, direction.x, direction.y, direction.z, single), single)
        skid = fl_scale(skid, fl(1.0 / dir_len_sq, single), single)
        if fl_dot(skid.x, skid.y, skid.z, skid.x, skid.y, skid.z, single) < EPSILON:
            return TransitionState.COLLIDED
        path.add_offset_to_check_pos(fl_sub(skid, off, single))
        return TransitionState.SLID

    if fl_dot(skid_dir.x, skid_dir.y, skid_dir.z, disp.x, disp.y, disp.z, single) < 0.0:
        return TransitionState.COLLIDED
    path.add_offset_to_check_pos(fl_scale(n, -fl_dot(off.x, off.y, off.z, n.x, n.y, n.z, single), single))
    return TransitionState.SLID
