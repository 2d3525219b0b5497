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
from ..geometry.precision import fl, fl_normalize_check_small, fl_place
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
        At the working precision (the client's: floats).
        """
        s = transition.single_precision
        g = transition.sphere_path.global_curr_center[sphere_num].center
        low = self.low_point
        cx = fl(g.x - low.x, s)
        cy = fl(g.y - low.y, s)
        cz = fl(g.z - low.z, s)
        if fl(radsum * radsum, s) < fl(fl(cx * cx, s) + fl(cy * cy, s), s):
            half = fl(self.height * 0.5, s)
            eps = fl(EPSILON, s)
            definite = fl(fl(check_sphere.radius - eps, s) + half, s) >= abs(fl(half - cz, s)) or abs(fl(cz - disp.z, s)) <= eps
            return definite, Vec3(cx, cy, 0.0)
        return True, Vec3(0.0, 0.0, 1.0 if fl(disp.z - cz, s) <= 0.0 else -1.0)

    # -- the dispatcher ------------------------------------------------------
    def intersects_sphere_at(self, position: Position, scale: float, transition: Transition) -> int:
        """Collide the path with this cylsphere of an obstacle at `position`,
        scaled by `scale` (CylSphere.IntersectsSphere(Position, scale, ...))."""
        path = transition.sphere_path
        path.cache_local_space_sphere(position, 1.0)
        # the client's CylSphere(lowPoint, height, radius, scale) and
        # CheckPos.LocalToGlobal(pos, lowPoint), in floats
        s = transition.single_precision
        f = fl(scale, s)
        low = fl_place(path.check_pos.cell_id, position, self.low_point, f, s)
        return CylSphere(low, fl(fl(self.radius, s) * f, s), fl(fl(self.height, s) * f, s)).intersects_sphere(transition)

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

        s = transition.single_precision
        radsum = fl(fl(self.radius - fl(EPSILON, s), s) + glob_sphere.radius, s)

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
        unit = fl_normalize_check_small(normal, transition.single_precision)
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
        unit = fl_normalize_check_small(normal, transition.single_precision)
        if unit is None:
            return _COLLIDED
        return slide_sphere_env(transition, check_sphere, unit, transition.sphere_path.global_curr_center[sphere_num].center)

    def land_on_cylinder(self, transition: Transition, check_sphere: Sphere, disp: Vec3, radsum: float) -> int:
        """Airborne foot sphere meets the cylinder: enter collide mode along
        its collision normal, landing on anything not steeper than LandingZ
        (CylSphere.LandOnCylinder)."""
        _, normal = self.collision_normal(transition, check_sphere, disp, radsum, 0)
        unit = fl_normalize_check_small(normal, transition.single_precision)
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

        The sphere meets the cylinder wall where a quadratic in the step's
        horizontal movement has its root; its discriminant cancels two terms
        of ~1e2, so float32 rounding moves the meeting point and the normal
        in the sixth digit (enough to steer a missile's bounce measurably).
        In single precision as in the client: floats throughout except where
        its 2D squared lengths are doubles (the discriminant is evaluated in
        double from float-rounded squares, and the root's time is rounded
        back to float).
        """
        path = transition.sphere_path
        ci = transition.collision_info
        low = self.low_point
        s = transition.single_precision
        eps = fl(EPSILON, s)
        definite, normal = self.collision_normal(transition, check_sphere, disp, radsum, sphere_num)
        unit = fl_normalize_check_small(normal, s)
        if unit is None:
            return _COLLIDED
        if not transition.object_info.state & OI.PERFECT_CLIP:
            ci.set_collision_normal(unit)
            return _COLLIDED

        gc = path.global_curr_center[0].center
        assert path.curr_pos is not None
        block = get_block_offset(path.curr_pos.cell_id, path.check_pos.cell_id)
        c = check_sphere.center
        mx = fl(block.x + fl(c.x - gc.x, s), s)
        my = fl(block.y + fl(c.y - gc.y, s), s)
        mz = fl(block.z + fl(c.z - gc.z, s), s)
        odx = fl(gc.x - low.x, s)
        ody = fl(gc.y - low.y, s)
        odz = fl(gc.z - low.z, s)
        radsum = fl(radsum + eps, s)
        rr = fl(radsum * radsum, s)

        xy_move_len_sq = fl(fl(mx * mx, s) + fl(my * my, s), s)
        dot2d = fl(fl(mx * odx, s) + fl(my * ody, s), s)
        xy_diff = -dot2d
        diff_sq = fl(xy_diff * xy_diff, s) - (fl(fl(odx * odx, s) + fl(ody * ody, s), s) - rr) * xy_move_len_sq
        diff = fl(math.sqrt(diff_sq), s) if diff_sq >= 0.0 else math.nan
        r = check_sphere.radius

        if not definite:
            if abs(mz) < eps:
                return _COLLIDED
            if mz > 0.0:
                normal = Vec3(0.0, 0.0, -1.0)
                time = -fl(fl(mz + r, s) / mz, s)
            else:
                normal = Vec3(0.0, 0.0, 1.0)
                time = fl(fl(fl(r + self.height, s) - mz, s) / mz, s)
            sx, sy, sz = fl(mx * time, s), fl(my * time, s), fl(mz * time, s)
            px = fl(sx + odx, s)
            py = fl(sy + ody, s)
            if fl(fl(px * px, s) + fl(py * py, s), s) >= rr:
                if abs(xy_move_len_sq) < eps:
                    return _COLLIDED
                if diff_sq >= 0.0 and xy_move_len_sq > eps:
                    time = self._root_time(xy_diff, diff, dot2d, xy_move_len_sq, s)
                    sx, sy, sz = fl(mx * time, s), fl(my * time, s), fl(mz * time, s)
                normal = Vec3(
                    fl(fl(fl(sx + gc.x, s) - low.x, s) / radsum, s),
                    fl(fl(fl(sy + gc.y, s) - low.y, s) / radsum, s),
                    0.0,
                )
            if time < 0.0 or time > 1.0:
                return _COLLIDED
            path.add_offset_to_check_pos(
                Vec3(fl(fl(gc.x - sx, s) - c.x, s), fl(fl(gc.y - sy, s) - c.y, s), fl(fl(gc.z - sz, s) - c.z, s))
            )
            ci.set_collision_normal(normal)
            return _ADJUSTED

        if unit.z != 0.0:
            if abs(mz) < eps:
                return _COLLIDED
            if mz > 0.0:
                time = -fl(fl(odz + r, s) / mz, s)
            else:
                time = fl(fl(fl(r + self.height, s) - odz, s) / mz, s)
            if time < 0.0 or time > 1.0:
                return _COLLIDED
            sx, sy, sz = fl(mx * time, s), fl(my * time, s), fl(mz * time, s)
            path.add_offset_to_check_pos(
                Vec3(fl(fl(gc.x + sx, s) - c.x, s), fl(fl(gc.y + sy, s) - c.y, s), fl(fl(gc.z + sz, s) - c.z, s))
            )
            ci.set_collision_normal(unit)
            return _ADJUSTED

        if diff_sq < 0.0 or xy_move_len_sq < eps:
            return _COLLIDED
        time = self._root_time(xy_diff, diff, dot2d, xy_move_len_sq, s)
        if time < 0.0 or time > 1.0:
            return _COLLIDED
        sx, sy, sz = fl(mx * time, s), fl(my * time, s), fl(mz * time, s)
        normal = Vec3(
            fl(fl(fl(sx + gc.x, s) - low.x, s) / radsum, s),
            fl(fl(fl(sy + gc.y, s) - low.y, s) / radsum, s),
            0.0,
        )
        path.add_offset_to_check_pos(
            Vec3(fl(fl(gc.x + sx, s) - c.x, s), fl(fl(gc.y + sy, s) - c.y, s), fl(fl(gc.z + sz, s) - c.z, s))
        )
        ci.set_collision_normal(normal)
        return _ADJUSTED

    @staticmethod
    def _root_time(xy_diff: float, diff: float, dot2d: float, xy_move_len_sq: float, s: bool) -> float:
        """The step fraction at the wall: the quadratic's root as the client
        picks and rounds it (a float difference over a double, then float)."""
        if fl(xy_diff - diff, s) < 0.0:
            return fl(fl(diff - dot2d, s) / xy_move_len_sq, s)
        return fl(fl(xy_diff - diff, s) / xy_move_len_sq, s)
