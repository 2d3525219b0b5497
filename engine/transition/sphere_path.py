"""SpherePath: the moving spheres, the positions of the path and its scratch state."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..geometry import UNIT_Z, ZERO, Position, Sphere, Vec3

from ..geometry.f32 import local_z_f32, rotate_f32, scale_f32, unrotate_f32, vec_f32
from ..geometry.single import to_single
from ..geometry.landdefs import get_block_offset
from .slide import slide_sphere
from .state import InsertType, TransitionState

if TYPE_CHECKING:
    from ..cells.obj_cell import ObjCell
    from ..geometry.polygon import Polygon
    from .transition import Transition

__all__ = ["SpherePath"]

class SpherePath:
    """The client's SPHEREPATH.

    Positions are immutable: every "move the check position" here rebinds
    `check_pos` to a new Position, which is exactly the copy semantics the
    client's Position assignments have. The global spheres are cached at the
    check position and shifted in place by offsets, as the client does, so a
    sub-step costs no matrix work for an upright mover.
    """

    __slots__ = (
        "num_sphere",
        "local_sphere",
        "local_low_point",
        "global_sphere",
        "global_low_point",
        "local_space_sphere",
        "local_space_curr_center",
        "global_curr_center",
        "local_space_pos",
        "local_space_z",
        "begin_cell",
        "begin_pos",
        "end_pos",
        "curr_cell",
        "curr_pos",
        "global_offset",
        "step_up",
        "step_up_normal",
        "collide",
        "check_cell",
        "check_pos",
        "insert_type",
        "step_down",
        "backup_cell",
        "backup_check_pos",
        "obstruction_ethereal",
        "hits_interior_cell",
        "building_check",
        "walkable_allowance",
        "walk_interp",
        "step_down_amt",
        "walkable_check_pos",
        "walkable",
        "check_walkable",
        "walkable_up",
        "walkable_pos",
        "walkable_scale",
        "neg_step_up",
        "neg_collision_normal",
        "neg_poly_hit",
        "placement_allows_sliding",
        "single_precision",
        "_lss_curr",
        "_lss_check",
        "_lss_sums",
    )

    def __init__(self) -> None:
        self.num_sphere = 0
        self.local_sphere: list[Sphere] = []
        self.local_low_point = ZERO
        self.global_sphere: list[Sphere] = []
        self.global_low_point = ZERO
        self.local_space_sphere: list[Sphere] = []
        self.local_space_curr_center: list[Sphere] = []
        self.global_curr_center: list[Sphere] = []
        self.local_space_pos: Position | None = None
        self.local_space_z = UNIT_Z
        self.begin_cell: ObjCell | None = None
        self.begin_pos: Position | None = None
        self.end_pos: Position | None = None
        self.curr_cell: ObjCell | None = None
        self.curr_pos: Position | None = None
        self.global_offset = ZERO
        self.step_up = False
        self.step_up_normal = ZERO
        self.collide = False
        self.check_cell: ObjCell | None = None
        self.check_pos: Position = None  # type: ignore[assignment]
        self.insert_type = InsertType.TRANSITION
        self.step_down = False
        self.backup_cell: ObjCell | None = None
        self.backup_check_pos: Position | None = None
        self.obstruction_ethereal = False
        self.hits_interior_cell = False
        self.building_check = False
        self.walkable_allowance = 0.0
        self.walk_interp = 0.0
        self.step_down_amt = 0.0
        self.walkable_check_pos: Sphere | None = None
        self.walkable: Polygon | None = None
        self.check_walkable = False
        self.walkable_up = ZERO
        self.walkable_pos: Position | None = None
        self.walkable_scale = 1.0
        self.neg_step_up = False
        self.neg_collision_normal = ZERO
        self.neg_poly_hit = False
        self.placement_allows_sliding = True
        #: keep the check position and sphere caches in single precision (settings)
        self.single_precision = True
        #: the sphere centres of curr_pos and check_pos in their landblock
        #: frame (float32), kept while those two positions stay the same
        self._lss_curr: Position | None = None
        self._lss_check: Position | None = None
        self._lss_sums: list[tuple[float, float, float, float, float, float]] = []

    # -- set-up (SpherePath.InitPath / InitSphere) -------------------------
    def init_path(self, begin_cell: ObjCell | None, begin_pos: Position | None, end_pos: Position) -> None:
        self.begin_pos = begin_pos
        self.begin_cell = begin_cell
        self.end_pos = end_pos
        if begin_pos is not None:
            self.insert_type = InsertType.TRANSITION
            self.curr_pos = begin_pos
        else:
            self.insert_type = InsertType.PLACEMENT
            self.curr_pos = end_pos
        self.curr_cell = begin_cell
        self.cache_global_curr_center()

    def init_sphere(self, spheres: list[Sphere], scale: float) -> None:
        """Take at most two spheres (foot, head), scaled into the mover's frame."""
        self.num_sphere = min(len(spheres), 2)
        if self.single_precision:
            # the client's spheres and scale are floats, and so is their product
            f = to_single(scale)
            self.local_sphere = [
                Sphere(scale_f32(vec_f32(s.center), f), to_single(to_single(s.radius) * f)) for s in spheres[: self.num_sphere]
            ]
            s0 = self.local_sphere[0]
            self.local_low_point = Vec3(s0.center.x, s0.center.y, to_single(s0.center.z - s0.radius))
        else:
            self.local_sphere = [Sphere(s.center * scale, s.radius * scale) for s in spheres[: self.num_sphere]]
            s0 = self.local_sphere[0]
            self.local_low_point = Vec3(s0.center.x, s0.center.y, s0.center.z - s0.radius)
        self._lss_curr = None
        self.global_sphere = [Sphere(ZERO, s.radius) for s in self.local_sphere]
        self.global_curr_center = [Sphere(ZERO, s.radius) for s in self.local_sphere]
        self.local_space_sphere = [Sphere(ZERO, s.radius) for s in self.local_sphere]
        self.local_space_curr_center = [Sphere(ZERO, s.radius) for s in self.local_sphere]

    # -- moving the check position ----------------------------------------
    def add_offset_to_check_pos(self, offset: Vec3) -> None:
        self.shift_check_pos(offset)

    def shift_check_pos(self, offset: Vec3) -> None:
        """Move the check position and its cached global spheres by `offset`,
        keeping them at single precision as the client does."""
        o = self.check_pos.frame.origin
        ox = offset.x
        oy = offset.y
        oz = offset.z
        if not self.single_precision:
            for sphere in self.global_sphere:
                sphere.center = sphere.center + offset
            self.global_low_point = self.global_low_point + offset
            self.check_pos = self.check_pos.with_origin(o + offset)
            return
        for sphere in self.global_sphere:
            c = sphere.center
            sphere.center = Vec3(to_single(c.x + ox), to_single(c.y + oy), to_single(c.z + oz))
        lp = self.global_low_point
        self.global_low_point = Vec3(to_single(lp.x + ox), to_single(lp.y + oy), to_single(lp.z + oz))
        self.check_pos = self.check_pos.with_origin(Vec3(to_single(o.x + ox), to_single(o.y + oy), to_single(o.z + oz)))

    def adjust_check_pos(self, cell_id: int) -> None:
        """Re-home the check position into `cell_id` (an outdoor cell may be in
        another landblock: the origin is re-expressed there)."""
        if (cell_id & 0xFFFF) < 0x100:
            offset = get_block_offset(cell_id, self.check_pos.cell_id)
            if offset is not ZERO:
                self.cache_global_sphere(offset)
                self.check_pos = Position(cell_id, self.check_pos.frame.with_origin(self.check_pos.frame.origin + offset))
                return
        self.check_pos = self.check_pos.with_cell(cell_id)

    def set_check_pos(self, position: Position, cell: ObjCell | None) -> None:
        self.check_pos = position
        self.check_cell = cell
        self.cache_global_sphere(None)

    def save_check_pos(self) -> None:
        self.backup_cell = self.check_cell
        self.backup_check_pos = self.check_pos

    def restore_check_pos(self) -> None:
        assert self.backup_check_pos is not None
        self.check_pos = self.backup_check_pos
        self.check_cell = self.backup_cell
        self.cache_global_sphere(None)

    # -- sphere caches -----------------------------------------------------
    def cache_global_curr_center(self) -> None:
        pos = self.curr_pos
        assert pos is not None
        frame = pos.frame
        for i in range(self.num_sphere):
            center = frame.local_to_global(self.local_sphere[i].center)
            self.global_curr_center[i].center = vec_f32(center) if self.single_precision else center

    def cache_global_sphere(self, offset: Vec3 | None) -> None:
        """Move the global spheres by `offset`, or recompute them at check_pos."""
        single = self.single_precision
        if offset is not None:
            for s in self.global_sphere:
                s.center = vec_f32(s.center + offset) if single else s.center + offset
            low = self.global_low_point + offset
            self.global_low_point = vec_f32(low) if single else low
            return
        frame = self.check_pos.frame
        for i in range(self.num_sphere):
            g = self.global_sphere[i]
            g.radius = self.local_sphere[i].radius
            center = frame.local_to_global(self.local_sphere[i].center)
            g.center = vec_f32(center) if single else center
        low = frame.local_to_global(self.local_low_point)
        self.global_low_point = vec_f32(low) if single else low

    def cache_local_space_sphere(self, pos: Position, scale: float) -> None:
        """Express the path's spheres in the frame of `pos` (a cell or a part),
        divided by `scale` (SpherePath.CacheLocalSpaceSphere)."""
        curr = self.curr_pos
        check = self.check_pos
        assert curr is not None
        if self.single_precision:
            self._cache_local_space_sphere_f32(pos, curr, check, scale)
            return
        inv = 1.0 / scale
        for i in range(self.num_sphere):
            local = self.local_sphere[i]
            curr_center = pos.local_to_local(curr, local.center)
            check_center = pos.local_to_local(check, local.center)
            if inv != 1.0:  # (x * 1.0 is x exactly: unscaled cells and parts skip the copies)
                curr_center = curr_center * inv
                check_center = check_center * inv
            self.local_space_curr_center[i].center = curr_center
            ls = self.local_space_sphere[i]
            ls.radius = local.radius * inv
            ls.center = check_center
        self.local_space_pos = pos
        z = pos.global_to_local_vec(UNIT_Z)
        self.local_space_z = z

    def _cache_local_space_sphere_f32(self, pos: Position, curr: Position, check: Position, scale: float) -> None:
        """cache_local_space_sphere in the client's single precision: each
        sphere centre carried into `pos`'s frame (Position.LocalToLocal: into
        its landblock frame, across landblocks, then out of `pos`'s frame),
        every sum and product rounded to float32. A floor found in that frame
        is then landed on at the client's coordinates (a sphere resting on a
        ramp sits a float32 step higher or lower otherwise).

        The centres in the landblock frame depend only on curr_pos and
        check_pos (positions are never changed in place, so they are known
        by identity); they are kept for the next cell of the same step."""
        if curr is not self._lss_curr or check is not self._lss_check or len(self._lss_sums) != self.num_sphere:
            sums = []
            for i in range(self.num_sphere):
                c = _frame_point_f32(curr, self.local_sphere[i].center) if i == 0 else ZERO
                k = _frame_point_f32(check, self.local_sphere[i].center)
                sums.append((c.x, c.y, c.z, k.x, k.y, k.z))
            self._lss_sums = sums
            self._lss_curr = curr
            self._lss_check = check
        inv = to_single(1.0 / scale)
        q = pos.frame.orientation
        ident = q.x == 0.0 and q.y == 0.0 and q.z == 0.0
        for i in range(self.num_sphere):
            cx, cy, cz, kx, ky, kz = self._lss_sums[i]
            k = _into_frame_f32(pos, check.cell_id, kx, ky, kz, inv)
            ls = self.local_space_sphere[i]
            radius = self.local_sphere[i].radius
            if inv != 1.0:
                radius = to_single(radius * inv)
            ls.center = k
            ls.radius = radius
            if i == 0:
                # only the foot sphere's current centre is ever read (the
                # step's movement in BSPTREE::find_collisions)
                self.local_space_curr_center[0].center = _into_frame_f32(pos, curr.cell_id, cx, cy, cz, inv)
        self.local_space_pos = pos
        self.local_space_z = UNIT_Z if ident else local_z_f32(q)

    # -- walkable bookkeeping -----------------------------------------------
    def check_walkables(self) -> bool:
        """True unless the remembered walkable polygon no longer holds us up."""
        if self.walkable is None:
            return True
        assert self.walkable_check_pos is not None
        probe = Sphere(self.walkable_check_pos.center, self.walkable_check_pos.radius * 0.5)
        return self.walkable.check_walkable(probe, self.walkable_up)

    def set_walkable(self, sphere: Sphere, poly: Polygon, z_axis: Vec3, local_pos: Position, scale: float) -> None:
        self.walkable_check_pos = sphere.copy()
        self.walkable = poly
        self.walkable_up = z_axis
        self.walkable_pos = local_pos
        self.walkable_scale = scale

    def current_walkable(self) -> Polygon | None:
        """The walkable polygon now (a plain read that no caller narrows)."""
        return self.walkable

    def set_walkable_check_pos(self, sphere: Sphere) -> None:
        self.walkable_check_pos = sphere.copy()

    def is_walkable_allowable(self, z: float) -> bool:
        return z > self.walkable_allowance

    def set_collide(self, collision_normal: Vec3) -> None:
        """Enter collide mode: remember where we were, look for a floor next."""
        self.collide = True
        self.backup_cell = self.check_cell
        self.backup_check_pos = self.check_pos
        self.step_up_normal = collision_normal
        self.walk_interp = 1.0

    def set_neg_poly_hit(self, step_up: bool, collision_normal: Vec3) -> None:
        """Defer a hit of the head sphere until the foot's result is known."""
        self.neg_step_up = step_up
        self.neg_poly_hit = True
        self.neg_collision_normal = -collision_normal

    def get_curr_pos_check_pos_block_offset(self) -> Vec3:
        assert self.curr_pos is not None
        return get_block_offset(self.curr_pos.cell_id, self.check_pos.cell_id)

    # -- slides that live on the path in the client ---------------------------
    def step_up_slide(self, transition: Transition) -> int:
        """Slide along the normal that a failed step-up met (StepUpSlide)."""

        ci = transition.collision_info
        ci.contact_plane_valid = False
        ci.contact_plane_is_water = False
        return slide_sphere(transition, self.step_up_normal, self.global_curr_center[0].center)

    def precipice_slide(self, transition: Transition) -> int:
        """Slide along the edge of the walkable we are about to leave (PrecipiceSlide)."""

        assert self.walkable is not None and self.walkable_check_pos is not None
        edge_normal = self.walkable.find_crossed_edge(self.walkable_check_pos, self.walkable_up)
        if edge_normal is None:
            self.walkable = None
            return TransitionState.COLLIDED
        self.walkable = None
        self.step_up = False
        assert self.walkable_pos is not None and self.curr_pos is not None
        normal = self.walkable_pos.frame.local_to_global_vec(edge_normal)
        block_offset = get_block_offset(self.curr_pos.cell_id, self.check_pos.cell_id)
        moved = self.global_sphere[0].center - self.global_curr_center[0].center + block_offset
        if normal.dot(moved) > 0.0:
            normal = -normal
        return slide_sphere(transition, normal, self.global_curr_center[0].center)


def _into_frame_f32(pos: Position, cell_id: int, x: float, y: float, z: float, inv: float) -> Vec3:
    """A point of `cell_id`'s landblock frame carried into `pos`'s frame and
    divided by the scale (`inv` = 1/scale), in float32 as LocalToLocal does:
    the block offset added (zero, and exact, within one landblock), the
    origin taken off, the rotation undone, then the scale."""
    if pos.cell_id >> 16 != cell_id >> 16:
        b = get_block_offset(pos.cell_id, cell_id)
        x = to_single(b.x + x)
        y = to_single(b.y + y)
        z = to_single(b.z + z)
    o = pos.frame.origin
    p = Vec3(to_single(x - o.x), to_single(y - o.y), to_single(z - o.z))
    q = pos.frame.orientation
    if not (q.x == 0.0 and q.y == 0.0 and q.z == 0.0):
        p = unrotate_f32(q, p)
    if inv != 1.0:
        p = scale_f32(p, inv)
    return p


def _frame_point_f32(source: Position, point: Vec3) -> Vec3:
    """`point` of `source`'s frame in its landblock frame, in single
    precision (AFrame.LocalToGlobal)."""
    sq = source.frame.orientation
    o = source.frame.origin
    if sq.x == 0.0 and sq.y == 0.0 and sq.z == 0.0:
        return Vec3(to_single(o.x + point.x), to_single(o.y + point.y), to_single(o.z + point.z))
    r = rotate_f32(sq, point)
    return Vec3(to_single(o.x + r.x), to_single(o.y + r.y), to_single(o.z + r.z))
