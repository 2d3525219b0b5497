"""SpherePath: the moving spheres, the positions of the path and its scratch state."""

from __future__ import annotations

from typing import TYPE_CHECKING, Final

from ..geometry import UNIT_Z, ZERO, Frame, Position, Sphere, Vec3

from ..geometry.precision import fl, fl_add, fl_local_z, fl_rotate, fl_scale, fl_unrotate, fl_vec
from ..geometry.landdefs import get_block_offset
from ..settings import RETAIL
from .slide import slide_sphere
from .state import InsertType, TransitionState
from .._compat import mypyc_attr

if TYPE_CHECKING:
    from ..cells.obj_cell import ObjCell
    from ..geometry.polygon import Polygon
    from .transition import Transition

__all__ = ["SpherePath", "ScaledSpheres"]

#: the empty sphere sums of a reset path (never appended to: cache_local_space_sphere replaces the list)
_NO_SUMS: Final[list[tuple[float, float, float, float, float, float]]] = []


@mypyc_attr(acyclic=True)
class ScaledSpheres:
    """The spheres a path moves: at most two of an object's spheres (foot, head), scaled into its frame, and
    the foot sphere's lowest point (the scaling half of SpherePath.InitSphere).

    Never changed once made: a mover keeps its own from move to move while its sphere list, scale and
    precision stay the same (`made_from`), and every path of its moves shares it."""

    __slots__ = ("source", "scale", "single", "spheres", "low_point")

    def __init__(self, source: list[Sphere], scale: float, single: bool) -> None:
        self.source = source
        self.scale = scale
        self.single = single
        # the client's spheres and scale are floats, and so is their product
        f = fl(scale, single)
        spheres: list[Sphere] = []
        for i in range(min(len(source), 2)):
            s = source[i]
            center = fl_vec(s.center, single)
            if f != 1.0:  # (times 1 changes nothing: a float32 stays itself)
                center = fl_scale(center, f, single)
            spheres.append(Sphere(center, fl(fl(s.radius, single) * f, single)))
        self.spheres = spheres
        foot = spheres[0]
        self.low_point = Vec3(foot.center.x, foot.center.y, fl(foot.center.z - foot.radius, single))

    def made_from(self, source: list[Sphere], scale: float, single: bool) -> bool:
        """Whether these are `source` scaled by `scale` at that precision (the list is known by identity:
        a mover's spheres are replaced, never edited in place)."""
        return source is self.source and scale == self.scale and single == self.single


@mypyc_attr(acyclic=True)
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
        "_curr_center_pos",
    )

    def __init__(self) -> None:
        self.local_sphere: list[Sphere] = []
        self.global_sphere: list[Sphere] = []
        self.local_space_sphere: list[Sphere] = []
        self.local_space_curr_center: list[Sphere] = []
        self.global_curr_center: list[Sphere] = []
        #: the working precision of the check position and the sphere caches: the
        #: transition's settings' single_precision, which the transition copies here
        #: once (a bool read where a settings object was read and then its field)
        self.single_precision: bool = RETAIL.single_precision
        self.reset()

    def reset(self) -> None:
        """The state of a new path, for a transition that is reused (Transition.reset). The sphere
        lists are init_sphere's to fill: it reuses the spheres in them."""
        self.num_sphere = 0
        self.local_low_point = ZERO
        self.global_low_point = ZERO
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
        #: the sphere centres of curr_pos and check_pos in their landblock
        #: frame (float32), kept while those two positions stay the same
        self._lss_curr: Position | None = None
        self._lss_check: Position | None = None
        self._lss_sums: list[tuple[float, float, float, float, float, float]] = _NO_SUMS
        #: the position global_curr_center was placed at (None: not placed since init_sphere)
        self._curr_center_pos: Position | None = None

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
        """Take at most two spheres (foot, head), scaled into the mover's frame (SpherePath.InitSphere)."""
        self.init_scaled_spheres(ScaledSpheres(spheres, scale, self.single_precision))

    def init_scaled_spheres(self, scaled: ScaledSpheres) -> None:
        """InitSphere with the scaling already done (a mover keeps its ScaledSpheres from move to move)."""
        local = scaled.spheres
        self.num_sphere = len(local)
        self.local_sphere = local
        self.local_low_point = scaled.low_point
        self._lss_curr = None
        self._curr_center_pos = None
        # the caches' spheres: those of a reused path's last transition when there are as many
        global_sphere = self.global_sphere
        global_curr_center = self.global_curr_center
        if len(global_sphere) == len(local) and len(global_curr_center) == len(local):
            for i in range(len(local)):
                radius = local[i].radius
                g = global_sphere[i]
                g.center = ZERO
                g.radius = radius
                g = global_curr_center[i]
                g.center = ZERO
                g.radius = radius
        else:
            global_sphere.clear()
            global_curr_center.clear()
            for s in local:
                global_sphere.append(Sphere(ZERO, s.radius))
                global_curr_center.append(Sphere(ZERO, s.radius))
        # the local-space spheres are made by their first cache_local_space_sphere (terrain never asks)
        self.local_space_sphere.clear()
        self.local_space_curr_center.clear()

    # -- moving the check position ----------------------------------------
    def add_offset_to_check_pos(self, offset: Vec3) -> None:
        self.shift_check_pos(offset)

    def shift_check_pos(self, offset: Vec3) -> None:
        """Move the check position and its cached global spheres by `offset`,
        keeping them at the working precision (single, as the client does)."""
        single = self.single_precision
        # fl_add written out: the offset's components read once for every point moved
        ox = offset.x
        oy = offset.y
        oz = offset.z
        for sphere in self.global_sphere:
            c = sphere.center
            sphere.center = Vec3(fl(c.x + ox, single), fl(c.y + oy, single), fl(c.z + oz, single))
        c = self.global_low_point
        self.global_low_point = Vec3(fl(c.x + ox, single), fl(c.y + oy, single), fl(c.z + oz, single))
        check = self.check_pos
        frame = check.frame
        c = frame.origin
        origin = Vec3(fl(c.x + ox, single), fl(c.y + oy, single), fl(c.z + oz, single))
        self.check_pos = Position(check.cell_id, Frame(origin, frame.orientation))

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
        single = self.single_precision
        for i in range(self.num_sphere):
            self.global_curr_center[i].center = frame.local_to_global_fl(self.local_sphere[i].center, single)
        self._curr_center_pos = pos

    def cache_global_sphere(self, offset: Vec3 | None) -> None:
        """Move the global spheres by `offset`, or recompute them at check_pos."""
        single = self.single_precision
        if offset is not None:
            for s in self.global_sphere:
                s.center = fl_vec(s.center + offset, single)
            self.global_low_point = fl_vec(self.global_low_point + offset, single)
            return
        check = self.check_pos
        frame = check.frame
        # at the position the current centres were placed at (each step's end: curr_pos becomes check_pos),
        # the same sums give the same vectors: share them (vectors are immutable)
        placed = check is self._curr_center_pos
        for i in range(self.num_sphere):
            g = self.global_sphere[i]
            local = self.local_sphere[i]
            g.radius = local.radius
            g.center = self.global_curr_center[i].center if placed else frame.local_to_global_fl(local.center, single)
        self.global_low_point = frame.local_to_global_fl(self.local_low_point, single)

    def cache_local_space_sphere(self, pos: Position, scale: float) -> None:
        """Express the path's spheres in the frame of `pos` (a cell or a part),
        divided by `scale` (SpherePath.CacheLocalSpaceSphere).

        At the working precision; in single precision as the client computes
        it: each sphere centre carried into `pos`'s frame (Position.LocalToLocal:
        into its landblock frame, across landblocks, then out of `pos`'s
        frame), every sum and product rounded to float32. A floor found in
        that frame is then landed on at the client's coordinates (a sphere
        resting on a ramp sits a float32 step higher or lower otherwise).

        The centres in the landblock frame depend only on curr_pos and
        check_pos (positions are never changed in place, so they are known
        by identity); they are kept for the next cell of the same step."""
        curr = self.curr_pos
        check = self.check_pos
        assert curr is not None
        single = self.single_precision
        if curr is not self._lss_curr or check is not self._lss_check or len(self._lss_sums) != self.num_sphere:
            sums = []
            for i in range(self.num_sphere):
                c = _frame_point(curr, self.local_sphere[i].center, single) if i == 0 else ZERO
                k = _frame_point(check, self.local_sphere[i].center, single)
                sums.append((c.x, c.y, c.z, k.x, k.y, k.z))
            self._lss_sums = sums
            self._lss_curr = curr
            self._lss_check = check
        if len(self.local_space_sphere) != self.num_sphere:
            self.local_space_sphere = [Sphere(ZERO, s.radius) for s in self.local_sphere]
            self.local_space_curr_center = [Sphere(ZERO, s.radius) for s in self.local_sphere]
        inv = fl(1.0 / scale, single)
        q = pos.frame.orientation
        ident = q.x == 0.0 and q.y == 0.0 and q.z == 0.0
        for i in range(self.num_sphere):
            cx, cy, cz, kx, ky, kz = self._lss_sums[i]
            k = _into_frame(pos, check.cell_id, kx, ky, kz, inv, single)
            ls = self.local_space_sphere[i]
            radius = self.local_sphere[i].radius
            if inv != 1.0:
                radius = fl(radius * inv, single)
            ls.center = k
            ls.radius = radius
            if i == 0:
                # only the foot sphere's current centre is ever read (the
                # step's movement in BSPTREE::find_collisions)
                self.local_space_curr_center[0].center = _into_frame(pos, curr.cell_id, cx, cy, cz, inv, single)
        self.local_space_pos = pos
        self.local_space_z = UNIT_Z if ident else fl_local_z(q, single)

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


def _into_frame(pos: Position, cell_id: int, x: float, y: float, z: float, inv: float, single: bool) -> Vec3:
    """A point of `cell_id`'s landblock frame carried into `pos`'s frame and
    divided by the scale (`inv` = 1/scale), rounded as LocalToLocal rounds:
    the block offset added (zero, and exact, within one landblock), the
    origin taken off, the rotation undone, then the scale."""
    if pos.cell_id >> 16 != cell_id >> 16:
        b = get_block_offset(pos.cell_id, cell_id)
        x = fl(b.x + x, single)
        y = fl(b.y + y, single)
        z = fl(b.z + z, single)
    o = pos.frame.origin
    p = Vec3(fl(x - o.x, single), fl(y - o.y, single), fl(z - o.z, single))
    q = pos.frame.orientation
    if not (q.x == 0.0 and q.y == 0.0 and q.z == 0.0):
        p = fl_unrotate(q, p, single)
    if inv != 1.0:
        p = fl_scale(p, inv, single)
    return p


def _frame_point(source: Position, point: Vec3, single: bool) -> Vec3:
    """`point` of `source`'s frame in its landblock frame (AFrame.LocalToGlobal)."""
    sq = source.frame.orientation
    o = source.frame.origin
    if sq.x == 0.0 and sq.y == 0.0 and sq.z == 0.0:
        return Vec3(fl(o.x + point.x, single), fl(o.y + point.y, single), fl(o.z + point.z, single))
    return fl_add(o, fl_rotate(sq, point, single), single)
