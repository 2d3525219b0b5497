"""A moving object's spheres against an obstacle's cylsphere (the client's
CCylSphere, ACE `CylSphere.cs`).

A cylsphere is an upright cylinder given by its low point (centre of the
bottom disc), radius and height. The collision tests treat the moving
sphere against it as a vertical slab test plus a horizontal circle test.

As in the reference:
- `intersects_sphere_at` caches the path's spheres in the obstacle's local
  space (at scale 1) first, and the step-up turns its collision normal by
  that local space's orientation before stepping up;
- the collision normal is measured from the current centre without the
  landblock offset between the current and the check positions;
- the contact planes a cylsphere's top gives are recorded as water planes,
  and the step-down one keeps the contact plane's previous cell id;
- the PerfectClip routine's "not definite" branch measures its times with
  the movement's z where the definite branch uses the sphere's height above
  the low point, and moves back with the opposite sign.
"""

from __future__ import annotations

import math
from typing import Any, Final, TYPE_CHECKING

from ..constants import EPSILON, LANDING_Z
from ..geometry import UNIT_Z, Plane, Position, Sphere, Vec3
from ..geometry.f32 import normalize_check_small_f32, place_f32
from ..geometry.single import to_single
from ..geometry.landdefs import get_block_offset
from ..transition.state import OI, InsertType, TransitionState
from .sphere_collision import slide_sphere_env

if TYPE_CHECKING:
    from ..transition.transition import Transition

__all__ = ["CylSphere"]

_OK: Final = TransitionState.OK
_COLLIDED: Final = TransitionState.COLLIDED
_ADJUSTED: Final = TransitionState.ADJUSTED
_PLACEMENT: Final = InsertType.PLACEMENT
_CONTACT_OR_WALKABLE: Final = OI.CONTACT | OI.ON_WALKABLE
#: the client's EPSILON as the float32 it compares with
_EPSILON_F32: Final = to_single(EPSILON)


class CylSphere:
    """An upright cylinder: `low_point` (bottom centre), `radius`, `height`.

    Instances held by an obstacle are in the obstacle's frame and unscaled;
    `intersects_sphere_at` builds the placed, scaled one for each test.
    """

    __slots__ = ("low_point", "radius", "height")

    def __init__(self, low_point: Vec3, radius: float, height: float) -> None:
        self.low_point = low_point
        self.radius = radius
        self.height = height

    def __repr__(self) -> str:
        return f"CylSphere({self.low_point!r}, r={self.radius!r}, h={self.height!r})"

    @classmethod
    def from_dict(cls, d: Any) -> CylSphere:
        """From a scene dict `{"origin": [x, y, z], "radius", "height"}`."""
        o = d["origin"]
        return cls(Vec3(float(o[0]), float(o[1]), float(o[2])), float(d["radius"]), float(d["height"]))

    @classmethod
    def from_spec(cls, spec: Any) -> CylSphere:
        """From anything with `origin` (3 numbers or a Vec3), `radius`, `height`
        (e.g. engine.CylSphereSpec)."""
        o = spec.origin
        low = o if isinstance(o, Vec3) else Vec3(float(o[0]), float(o[1]), float(o[2]))
        return cls(low, float(spec.radius), float(spec.height))

    # -- tests ------------------------------------------------------------
    def collides_with_sphere(self, check_sphere: Sphere, disp: Vec3, radsum: float) -> bool:
        """Does a sphere at `disp` from the low point overlap the cylinder?
        (CylSphere.CollidesWithSphere)"""
        if disp.x * disp.x + disp.y * disp.y <= radsum * radsum:
            half = self.height * 0.5
            return check_sphere.radius - EPSILON + half >= abs(half - disp.z)
        return False

    def collision_normal(self, transition: Transition, check_sphere: Sphere, disp: Vec3, radsum: float, sphere_num: int) -> tuple[bool, Vec3]:
        """(definite, normal) of a hit (CylSphere.CollisionNormal).

        If the sphere's current centre was outside the cylinder's circle, the
        normal is horizontal, from the axis to it, and definite when the
        sphere was level with the cylinder or did not move vertically.
        Otherwise it came through the top or bottom: the normal is +-z.
        """
        curr = transition.sphere_path.global_curr_center[sphere_num].center - self.low_point
        if radsum * radsum < curr.x * curr.x + curr.y * curr.y:
            half = self.height * 0.5
            definite = check_sphere.radius - EPSILON + half >= abs(half - curr.z) or abs(curr.z - disp.z) <= EPSILON
            return definite, Vec3(curr.x, curr.y, 0.0)
        return True, Vec3(0.0, 0.0, 1.0 if disp.z - curr.z <= 0.0 else -1.0)

    # -- the dispatcher ------------------------------------------------------
    def intersects_sphere_at(self, position: Position, scale: float, transition: Transition) -> int:
        """Collide the path with this cylsphere of an obstacle at `position`,
        scaled by `scale` (CylSphere.IntersectsSphere(Position, scale, ...))."""
        path = transition.sphere_path
        path.cache_local_space_sphere(position, 1.0)
        if path.single_precision:
            # the client's CylSphere(lowPoint, height, radius, scale) and
            # CheckPos.LocalToGlobal(pos, lowPoint), in floats
            f = to_single(scale)
            low = place_f32(path.check_pos.cell_id, position, self.low_point, f)
            return CylSphere(low, to_single(to_single(self.radius) * f), to_single(to_single(self.height) * f)).intersects_sphere(transition)
        low = path.check_pos.local_to_global_from(position, self.low_point * scale)
        return CylSphere(low, self.radius * scale, self.height * scale).intersects_sphere(transition)

    def intersects_sphere(self, transition: Transition) -> int:
        """Collide the path's spheres with this (placed) cylsphere and respond
        (CylSphere.IntersectsSphere(Transition)).

        Same branch order as the sphere version: ethereal/placement overlap,
        step-down onto the top, walkable probe, then contact (step up or
        slide; head sphere slides), path-clipped (collide with the point),
        airborne (land on it; head sphere collides), and collide mode (land on
        the flat top if the step came down through it).
        """
        path = transition.sphere_path
        glob_sphere = path.global_sphere[0]
        disp = glob_sphere.center - self.low_point
        two = path.num_sphere > 1
        glob_sphere_1: Sphere = glob_sphere
        disp_1 = disp
        if two:
            glob_sphere_1 = path.global_sphere[1]
            disp_1 = glob_sphere_1.center - self.low_point

        if path.single_precision:
            radsum = to_single(to_single(self.radius - _EPSILON_F32) + glob_sphere.radius)
        else:
            radsum = self.radius - EPSILON + glob_sphere.radius

        if path.insert_type == _PLACEMENT or path.obstruction_ethereal:
            if self.collides_with_sphere(glob_sphere, disp, radsum):
                return _COLLIDED
            if two and self.collides_with_sphere(glob_sphere_1, disp_1, radsum):
                return _COLLIDED
            return _OK

        if path.step_down:
            return self.step_sphere_down(transition, glob_sphere, disp, radsum)

        if path.check_walkable:
            if self.collides_with_sphere(glob_sphere, disp, radsum):
                return _COLLIDED
            if two and self.collides_with_sphere(glob_sphere_1, disp_1, radsum):
                return _COLLIDED
            return _OK

        if not path.collide:
            state = transition.object_info.state
            if state & _CONTACT_OR_WALKABLE:
                if self.collides_with_sphere(glob_sphere, disp, radsum):
                    return self.step_sphere_up(transition, glob_sphere, disp, radsum)
                if two and self.collides_with_sphere(glob_sphere_1, disp_1, radsum):
                    # (the reference passes the foot sphere's displacement here)
                    return self.slide_sphere(transition, glob_sphere_1, disp, radsum, 1)
            elif state & OI.PATH_CLIPPED:
                if self.collides_with_sphere(glob_sphere, disp, radsum):
                    return self.collide_with_point(transition, glob_sphere, disp, radsum, 0)
            else:
                if self.collides_with_sphere(glob_sphere, disp, radsum):
                    return self.land_on_cylinder(transition, glob_sphere, disp, radsum)
                if two and self.collides_with_sphere(glob_sphere_1, disp_1, radsum):
                    return self.collide_with_point(transition, glob_sphere_1, disp_1, radsum, 1)
            return _OK

        if self.collides_with_sphere(glob_sphere, disp, radsum) or (
            two and self.collides_with_sphere(glob_sphere_1, disp_1, radsum)
        ):
            # collide mode: did this step come down through the top?
            block_offset = path.get_curr_pos_check_pos_block_offset()
            movement = path.global_curr_center[0].center - glob_sphere.center - block_offset
            if abs(movement.z) < EPSILON:
                return _COLLIDED
            timecheck = (self.height + glob_sphere.radius - disp.z) / movement.z
            offset = movement * timecheck
            over = offset + disp
            if radsum * radsum < over.x * over.x + over.y * over.y:
                return _OK
            t = (1.0 - timecheck) * path.walk_interp
            if t >= path.walk_interp or t < -0.1:
                return _COLLIDED
            top_z = glob_sphere.center.z + offset.z - glob_sphere.radius
            ci = transition.collision_info
            ci.set_contact_plane(Plane(UNIT_Z, -top_z), True)
            ci.contact_plane_cell_id = path.check_pos.cell_id
            path.walk_interp = t
            path.add_offset_to_check_pos(offset)
            return _ADJUSTED
        return _OK

    # -- responses -------------------------------------------------------------
    def step_sphere_down(self, transition: Transition, check_sphere: Sphere, disp: Vec3, radsum: float) -> int:
        """Stand the lowered foot sphere on the flat top (CylSphere.StepSphereDown).

        The lift is the top's height above the sphere's bottom; refused
        (COLLIDED) beyond the step-down budget or when there is none. The
        contact plane is horizontal through the top.
        """
        path = transition.sphere_path
        hit = self.collides_with_sphere(check_sphere, disp, radsum)
        if not hit and path.num_sphere > 1:
            hit = self.collides_with_sphere(path.global_sphere[1], path.global_sphere[1].center - self.low_point, radsum)
        if not hit:
            return _OK
        step_scale = path.step_down_amt * path.walk_interp
        if abs(step_scale) < EPSILON:
            return _COLLIDED
        delta_z = self.height + check_sphere.radius - disp.z
        interp = (1.0 - delta_z / step_scale) * path.walk_interp
        if interp >= path.walk_interp or interp < -0.1:
            return _COLLIDED
        c = check_sphere.center
        top_z = c.z + (delta_z - check_sphere.radius)
        ci = transition.collision_info
        ci.set_contact_plane(Plane(UNIT_Z, -top_z), True)
        path.walk_interp = interp
        path.add_offset_to_check_pos(Vec3(0.0, 0.0, delta_z))
        return _ADJUSTED

    def step_sphere_up(self, transition: Transition, check_sphere: Sphere, disp: Vec3, radsum: float) -> int:
        """Walked into the cylinder: step onto its top if within the step-up
        height, else slide round it (CylSphere.StepSphereUp)."""
        if transition.object_info.step_up_height < check_sphere.radius + self.height - disp.z:
            return self.slide_sphere(transition, check_sphere, disp, radsum, 0)
        _, normal = self.collision_normal(transition, check_sphere, disp, radsum, 0)
        unit = normal.normalized_or_none()
        if unit is None:
            return _COLLIDED
        path = transition.sphere_path
        assert path.local_space_pos is not None
        if transition.step_up(path.local_space_pos.local_to_global_vec(unit)):
            return _OK
        return path.step_up_slide(transition)

    def slide_sphere(self, transition: Transition, check_sphere: Sphere, disp: Vec3, radsum: float, sphere_num: int) -> int:
        """Slide path sphere `sphere_num` along the cylinder's wall (or its
        top) (CylSphere.SlideSphere)."""
        _, normal = self.collision_normal(transition, check_sphere, disp, radsum, sphere_num)
        unit = normal.normalized_or_none()
        if unit is None:
            return _COLLIDED
        return slide_sphere_env(transition, check_sphere, unit, transition.sphere_path.global_curr_center[sphere_num].center)

    def land_on_cylinder(self, transition: Transition, check_sphere: Sphere, disp: Vec3, radsum: float) -> int:
        """Airborne foot sphere meets the cylinder: enter collide mode along
        its collision normal, landing on anything not steeper than LandingZ
        (CylSphere.LandOnCylinder)."""
        _, normal = self.collision_normal(transition, check_sphere, disp, radsum, 0)
        unit = normal.normalized_or_none()
        if unit is None:
            return _COLLIDED
        path = transition.sphere_path
        path.set_collide(unit)
        path.walkable_allowance = LANDING_Z
        return _ADJUSTED

    def collide_with_point(self, transition: Transition, check_sphere: Sphere, disp: Vec3, radsum: float, sphere_num: int) -> int:
        """A path-clipped mover or an airborne head sphere hits the cylinder
        (CylSphere.CollideWithPoint).

        Without PerfectClip: record the collision normal, COLLIDED. With it:
        move the check position back to where the sphere meets the wall, top
        or bottom along the step and record that normal, ADJUSTED; COLLIDED
        when the meeting point is outside the step.
        """
        path = transition.sphere_path
        if path.single_precision:
            return self._collide_with_point_f32(transition, check_sphere, disp, radsum, sphere_num)
        ci = transition.collision_info
        definite, normal = self.collision_normal(transition, check_sphere, disp, radsum, sphere_num)
        unit = normal.normalized_or_none()
        if unit is None:
            return _COLLIDED
        normal = unit
        if not transition.object_info.state & OI.PERFECT_CLIP:
            ci.set_collision_normal(normal)
            return _COLLIDED

        glob_center = path.global_curr_center[0].center
        assert path.curr_pos is not None
        movement = get_block_offset(path.curr_pos.cell_id, path.check_pos.cell_id) + (check_sphere.center - glob_center)
        old_disp = glob_center - self.low_point
        radsum += EPSILON

        xy_move_len_sq = movement.x * movement.x + movement.y * movement.y
        dot2d = movement.x * old_disp.x + movement.y * old_disp.y
        xy_diff = -dot2d
        diff_sq = xy_diff * xy_diff - (old_disp.x * old_disp.x + old_disp.y * old_disp.y - radsum * radsum) * xy_move_len_sq
        diff = math.sqrt(diff_sq) if diff_sq >= 0.0 else math.nan

        if not definite:
            if abs(movement.z) < EPSILON:
                return _COLLIDED
            if movement.z > 0.0:
                normal = Vec3(0.0, 0.0, -1.0)
                time = -((movement.z + check_sphere.radius) / movement.z)
            else:
                normal = Vec3(0.0, 0.0, 1.0)
                time = (check_sphere.radius + self.height - movement.z) / movement.z
            scaled = movement * time
            s = scaled + old_disp
            if s.x * s.x + s.y * s.y >= radsum * radsum:
                if abs(xy_move_len_sq) < EPSILON:
                    return _COLLIDED
                if diff_sq >= 0.0 and xy_move_len_sq > EPSILON:
                    if xy_diff - diff < 0.0:
                        time = (diff - dot2d) / xy_move_len_sq
                    else:
                        time = (xy_diff - diff) / xy_move_len_sq
                    scaled = movement * time
                n = (scaled + glob_center - self.low_point) * (1.0 / radsum)
                normal = Vec3(n.x, n.y, 0.0)
            if time < 0.0 or time > 1.0:
                return _COLLIDED
            path.add_offset_to_check_pos(glob_center - scaled - check_sphere.center)
            ci.set_collision_normal(normal)
            return _ADJUSTED

        if normal.z != 0.0:
            if abs(movement.z) < EPSILON:
                return _COLLIDED
            if movement.z > 0.0:
                time = -((old_disp.z + check_sphere.radius) / movement.z)
            else:
                time = (check_sphere.radius + self.height - old_disp.z) / movement.z
            scaled = movement * time
            if time < 0.0 or time > 1.0:
                return _COLLIDED
            path.add_offset_to_check_pos(glob_center + scaled - check_sphere.center)
            ci.set_collision_normal(normal)
            return _ADJUSTED

        if diff_sq < 0.0 or xy_move_len_sq < EPSILON:
            return _COLLIDED
        if xy_diff - diff < 0.0:
            time = (diff - dot2d) / xy_move_len_sq
        else:
            time = (xy_diff - diff) / xy_move_len_sq
        scaled = movement * time
        if time < 0.0 or time > 1.0:
            return _COLLIDED
        n = (scaled + glob_center - self.low_point) * (1.0 / radsum)
        path.add_offset_to_check_pos(glob_center + scaled - check_sphere.center)
        ci.set_collision_normal(Vec3(n.x, n.y, 0.0))
        return _ADJUSTED

    def _collide_with_point_f32(self, transition: Transition, check_sphere: Sphere, disp: Vec3, radsum: float, sphere_num: int) -> int:
        """collide_with_point in the client's precision (CylSphere.CollideWithPoint).

        The sphere meets the cylinder wall where a quadratic in the step's
        horizontal movement has its root; its discriminant cancels two terms
        of ~1e2, so float32 rounding moves the meeting point and the normal
        in the sixth digit (enough to steer a missile's bounce measurably).
        As in the client, floats throughout except where its 2D squared
        lengths are doubles: the discriminant is evaluated in double from
        float-rounded squares, and the root's time is rounded back to float.
        """
        path = transition.sphere_path
        ci = transition.collision_info
        low = self.low_point
        eps = _EPSILON_F32
        g = path.global_curr_center[sphere_num].center
        cx = to_single(g.x - low.x)
        cy = to_single(g.y - low.y)
        cz = to_single(g.z - low.z)
        # CylSphere.CollisionNormal
        if to_single(radsum * radsum) < to_single(to_single(cx * cx) + to_single(cy * cy)):
            nx, ny, nz = cx, cy, 0.0
            half = to_single(self.height * 0.5)
            definite = to_single(to_single(check_sphere.radius - eps) + half) >= abs(to_single(half - cz)) or abs(
                to_single(cz - disp.z)
            ) <= eps
        else:
            nx, ny, nz = 0.0, 0.0, (1.0 if to_single(disp.z - cz) <= 0.0 else -1.0)
            definite = True
        unit = normalize_check_small_f32(Vec3(nx, ny, nz))
        if unit is None:
            return _COLLIDED
        if not transition.object_info.state & OI.PERFECT_CLIP:
            ci.set_collision_normal(unit)
            return _COLLIDED

        gc = path.global_curr_center[0].center
        assert path.curr_pos is not None
        block = get_block_offset(path.curr_pos.cell_id, path.check_pos.cell_id)
        c = check_sphere.center
        mx = to_single(block.x + to_single(c.x - gc.x))
        my = to_single(block.y + to_single(c.y - gc.y))
        mz = to_single(block.z + to_single(c.z - gc.z))
        odx = to_single(gc.x - low.x)
        ody = to_single(gc.y - low.y)
        odz = to_single(gc.z - low.z)
        radsum = to_single(radsum + eps)
        rr = to_single(radsum * radsum)

        xy_move_len_sq = to_single(to_single(mx * mx) + to_single(my * my))
        dot2d = to_single(to_single(mx * odx) + to_single(my * ody))
        xy_diff = -dot2d
        diff_sq = to_single(xy_diff * xy_diff) - (to_single(to_single(odx * odx) + to_single(ody * ody)) - rr) * xy_move_len_sq
        diff = to_single(math.sqrt(diff_sq)) if diff_sq >= 0.0 else math.nan
        r = check_sphere.radius

        if not definite:
            if abs(mz) < eps:
                return _COLLIDED
            if mz > 0.0:
                normal = Vec3(0.0, 0.0, -1.0)
                time = -to_single(to_single(mz + r) / mz)
            else:
                normal = Vec3(0.0, 0.0, 1.0)
                time = to_single(to_single(to_single(r + self.height) - mz) / mz)
            sx, sy, sz = to_single(mx * time), to_single(my * time), to_single(mz * time)
            px = to_single(sx + odx)
            py = to_single(sy + ody)
            if to_single(to_single(px * px) + to_single(py * py)) >= rr:
                if abs(xy_move_len_sq) < eps:
                    return _COLLIDED
                if diff_sq >= 0.0 and xy_move_len_sq > eps:
                    time = self._root_time_f32(xy_diff, diff, dot2d, xy_move_len_sq)
                    sx, sy, sz = to_single(mx * time), to_single(my * time), to_single(mz * time)
                normal = Vec3(
                    to_single(to_single(to_single(sx + gc.x) - low.x) / radsum),
                    to_single(to_single(to_single(sy + gc.y) - low.y) / radsum),
                    0.0,
                )
            if time < 0.0 or time > 1.0:
                return _COLLIDED
            path.add_offset_to_check_pos(
                Vec3(to_single(to_single(gc.x - sx) - c.x), to_single(to_single(gc.y - sy) - c.y), to_single(to_single(gc.z - sz) - c.z))
            )
            ci.set_collision_normal(normal)
            return _ADJUSTED

        if unit.z != 0.0:
            if abs(mz) < eps:
                return _COLLIDED
            if mz > 0.0:
                time = -to_single(to_single(odz + r) / mz)
            else:
                time = to_single(to_single(to_single(r + self.height) - odz) / mz)
            if time < 0.0 or time > 1.0:
                return _COLLIDED
            sx, sy, sz = to_single(mx * time), to_single(my * time), to_single(mz * time)
            path.add_offset_to_check_pos(
                Vec3(to_single(to_single(gc.x + sx) - c.x), to_single(to_single(gc.y + sy) - c.y), to_single(to_single(gc.z + sz) - c.z))
            )
            ci.set_collision_normal(unit)
            return _ADJUSTED

        if diff_sq < 0.0 or xy_move_len_sq < eps:
            return _COLLIDED
        time = self._root_time_f32(xy_diff, diff, dot2d, xy_move_len_sq)
        if time < 0.0 or time > 1.0:
            return _COLLIDED
        sx, sy, sz = to_single(mx * time), to_single(my * time), to_single(mz * time)
        normal = Vec3(
            to_single(to_single(to_single(sx + gc.x) - low.x) / radsum),
            to_single(to_single(to_single(sy + gc.y) - low.y) / radsum),
            0.0,
        )
        path.add_offset_to_check_pos(
            Vec3(to_single(to_single(gc.x + sx) - c.x), to_single(to_single(gc.y + sy) - c.y), to_single(to_single(gc.z + sz) - c.z))
        )
        ci.set_collision_normal(normal)
        return _ADJUSTED

    @staticmethod
    def _root_time_f32(xy_diff: float, diff: float, dot2d: float, xy_move_len_sq: float) -> float:
        """The step fraction at the wall: the quadratic's root as the client
        picks and rounds it (a float difference over a double, then float)."""
        if to_single(xy_diff - diff) < 0.0:
            return to_single(to_single(diff - dot2d) / xy_move_len_sq)
        return to_single(to_single(xy_diff - diff) / xy_move_len_sq)
