"""Slides: turning a blocked step into motion along the obstacle."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..constants import EPSILON
from ..geometry import ZERO, Sphere, Vec3
from ..geometry.f32 import cross_f32, dot_f32, normalize_check_small_f32, scale_f32, sub_f32
from ..geometry.single import to_single
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
    """Slide off another object's sphere (Sphere.SlideSphere, object variant)."""
    path = t.sphere_path
    if path.single_precision:
        return _slide_sphere_object_f32(t, obstacle_center, disp, sphere_num)
    ci = t.collision_info
    g = path.global_sphere[sphere_num]
    curr = path.global_curr_center[sphere_num].center
    collision_normal = (curr - obstacle_center).normalized_or_none()
    if collision_normal is None:
        return TransitionState.COLLIDED
    ci.set_collision_normal(collision_normal)

    plane = ci.contact_plane if ci.contact_plane_valid else ci.last_known_contact_plane
    skid_dir = plane.normal
    direction = collision_normal.cross(skid_dir)
    assert path.curr_pos is not None
    block_offset = get_block_offset(path.curr_pos.cell_id, path.check_pos.cell_id)
    glob_offset = g.center - curr + block_offset
    dir_len_sq = direction.length_sq()
    if dir_len_sq >= EPSILON:
        along = direction * (glob_offset.dot(direction) * (1.0 / dir_len_sq))
        if along.length_sq() < EPSILON:
            return TransitionState.COLLIDED
        path.add_offset_to_check_pos(along - glob_offset)
        return TransitionState.SLID

    if skid_dir.dot(disp) < 0.0:
        return TransitionState.COLLIDED
    path.add_offset_to_check_pos(collision_normal * -glob_offset.dot(collision_normal))
    return TransitionState.SLID


def _slide_sphere_object_f32(t: Transition, obstacle_center: Vec3, disp: Vec3, sphere_num: int) -> int:
    """slide_sphere_object in the client's single precision, in the order
    its expressions evaluate (the skid is (offset . dir) dir, then scaled by
    1 / |dir|^2)."""
    path = t.sphere_path
    ci = t.collision_info
    g = path.global_sphere[sphere_num]
    curr = path.global_curr_center[sphere_num].center
    n = normalize_check_small_f32(sub_f32(curr, obstacle_center))
    if n is None:
        return TransitionState.COLLIDED
    ci.set_collision_normal(n)

    plane = ci.contact_plane if ci.contact_plane_valid else ci.last_known_contact_plane
    skid_dir = plane.normal
    direction = cross_f32(n, skid_dir)
    assert path.curr_pos is not None
    block_offset = get_block_offset(path.curr_pos.cell_id, path.check_pos.cell_id)
    off = sub_f32(g.center, curr)
    if block_offset is not ZERO:
        off = Vec3(to_single(off.x + block_offset.x), to_single(off.y + block_offset.y), to_single(off.z + block_offset.z))
    dir_len_sq = dot_f32(direction.x, direction.y, direction.z, direction.x, direction.y, direction.z)
    if dir_len_sq >= EPSILON:
        skid = scale_f32(direction, dot_f32(off.x, off.y, off.z, direction.x, direction.y, direction.z))
        skid = scale_f32(skid, to_single(1.0 / dir_len_sq))
        if dot_f32(skid.x, skid.y, skid.z, skid.x, skid.y, skid.z) < EPSILON:
            return TransitionState.COLLIDED
        path.add_offset_to_check_pos(sub_f32(skid, off))
        return TransitionState.SLID

    if dot_f32(skid_dir.x, skid_dir.y, skid_dir.z, disp.x, disp.y, disp.z) < 0.0:
        return TransitionState.COLLIDED
    path.add_offset_to_check_pos(scale_f32(n, -dot_f32(off.x, off.y, off.z, n.x, n.y, n.z)))
    return TransitionState.SLID
