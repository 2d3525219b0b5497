"""The terrain contact rule: ObjectInfo.ValidateWalkable."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Final

from ..constants import EPSILON
from ..geometry import Plane, Sphere, Vec3
from ..geometry.precision import fl, fl_plane_dist
from .object_info import is_valid_walkable
from .state import OI, TransitionState

if TYPE_CHECKING:
    from .transition import Transition

__all__ = ["validate_walkable"]

#: a float64 distance above this is above EPSILON in float32 too (the float32
#: value is within ~1e-4 m of it at any landblock coordinate)
_CLEAR: Final = EPSILON + 1e-3

#: the largest float32: a pull-back beyond it is an infinity in the client
_FLOAT32_MAX: Final = 3.4028234663852886e38


def _representable(v: Vec3) -> bool:
    """Every component finite and within single precision (a NaN fails every comparison)."""
    m = _FLOAT32_MAX
    return -m <= v.x <= m and -m <= v.y <= m and -m <= v.z <= m


def validate_walkable(
    t: Transition, check_sphere: Sphere, plane: Plane, is_water: bool, water_depth: float, cell_id: int
) -> int:
    """Decide how a sphere meets a terrain plane (ObjectInfo.ValidateWalkable).

    `check_sphere` and `plane` are in the frame of cell `cell_id`'s landblock.
    A camera is pulled back along its path to stay above ground. Anything else
    rests on the plane when its low point is within EPSILON of it (lifted by
    the water depth), or is pushed up onto it when below.
    """
    path = t.sphere_path
    ci = t.collision_info
    state = t.object_info.state
    normal = plane.normal

    if state & OI.IS_VIEWER:
        center = check_sphere.center
        dist = center.dot(normal) + plane.d - check_sphere.radius
        begin = path.begin_pos
        began_indoors = begin is not None and (begin.cell_id & 0xFFFF) >= 0x100
        # Retail: a camera clear of the ground is fine; ACE only says so for
        # paths that began indoors (so its outdoor cameras never move).
        clear_ok = began_indoors or not t.settings.ace_outdoor_viewer
        if dist > -EPSILON and clear_ok:
            return TransitionState.OK
        offset = center - path.global_curr_center[0].center
        denom = offset.dot(normal)
        angle = dist / denom if denom != 0.0 else (math.inf if dist >= 0.0 else -math.inf)
        if (angle <= 0.0 or angle > 1.0) and clear_ok:
            return TransitionState.OK
        pull_back = offset * -angle
        if not _representable(pull_back):
            # A step parallel to the plane (or none at all): pulling back along
            # it never reaches the plane, and the quotient is infinite (NaN
            # times a zero step). ACE's C# puts that into the check position,
            # where no cell holds it; here the transition fails at once and
            # the camera stays where it was (docs/divergences.md).
            return TransitionState.INVALID
        path.add_offset_to_check_pos(pull_back)
        ci.set_collision_normal(normal)
        ci.collided_with_environment = True
        return TransitionState.ADJUSTED

    # At the working precision; in single precision as the client computes
    # it: a resting sphere's low point sits within rounding (~1e-5 m at these
    # coordinates) of the EPSILON band, so the float64 value can fall on the
    # other side of it.
    c = check_sphere.center
    low_z = c.z - check_sphere.radius
    if c.x * normal.x + c.y * normal.y + low_z * normal.z + plane.d + water_depth > _CLEAR:
        return TransitionState.OK  # far above the band: rounding cannot matter
    single = t.single_precision
    dist = fl_plane_dist(c.x, c.y, fl(low_z, single), plane, single)
    if water_depth != 0.0:
        dist = fl(dist + fl(water_depth, single), single)
    if dist >= -EPSILON:
        if dist > EPSILON:
            return TransitionState.OK
        if path.step_down or not state & OI.ON_WALKABLE or is_valid_walkable(normal):
            ci.set_contact_plane(plane, is_water)
            ci.contact_plane_cell_id = cell_id
        if not state & OI.CONTACT and not path.step_down:
            ci.set_collision_normal(normal)
            ci.collided_with_environment = True
        return TransitionState.OK

    if path.check_walkable:
        return TransitionState.COLLIDED
    z_dist = fl(dist / normal.z, single)
    if path.step_down or not state & OI.ON_WALKABLE or is_valid_walkable(normal):
        ci.set_contact_plane(plane, is_water)
        ci.contact_plane_cell_id = cell_id
        if path.step_down:
            interp = (1.0 - -1.0 / (path.step_down_amt * path.walk_interp) * z_dist) * path.walk_interp
            if interp >= path.walk_interp or interp < -0.1:
                return TransitionState.COLLIDED
            path.walk_interp = interp
        path.add_offset_to_check_pos(Vec3(0.0, 0.0, -z_dist))
    if not state & OI.CONTACT and not path.step_down:
        ci.set_collision_normal(normal)
        ci.collided_with_environment = True
    return TransitionState.ADJUSTED
