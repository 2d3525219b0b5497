"""Broad phase: pass over the live movers a path's spheres cannot reach.

The client's CObjCell::find_obj_collisions hands every object shadowed into a
cell to that object's own find_obj_collisions, at every sub-step. In a crowd
most of them are metres away, and each still costs a full test. A live mover
(`MoverObstacle`: its cylspheres, else its spheres, never BSP parts) answers
OK and changes nothing unless one of the path's spheres at the check position
overlaps one of its shapes:

- every branch of the sphere and cylsphere tests that answers anything but OK,
  or writes to the transition (contact plane, collision normal, collide-object
  list, walk interpolation, check position, step-up), first finds such an
  overlap (`hit0`/`hit1`, CylSphere.CollidesWithSphere), with one exception:
  in collide mode a single-sphere path against a sphere goes on to the
  landing solve without one, so a single-sphere path in collide mode is never
  culled (`may_touch` answers True);
- what the obstacle test writes before that (the ethereal-obstruction flag,
  the cylsphere's local-space cache) is put back or re-made by its next user:
  `obstruction_ethereal` is False again whenever an obstacle answers OK, and
  every reader of the local-space spheres caches them itself first;
- the cell's loop only continues past an OK answer, so a culled obstacle
  cannot change which obstacle answers first.

A mover's shape fits in an axis-aligned box around its placed spheres and
cylsphere cylinders; a path sphere of radius r overlaps the shape only if its
centre is inside that box grown by r. (The tests measure the head sphere's
overlap with the foot sphere's radius, radsum, as the reference does: the box
is grown by the larger of the two.) The box is kept on the mover
(`Mover.broad_phase_bounds`) and placed again whenever the mover's Position
object (immutable) is not the one it was placed for, so it follows every
change of position, including those that cast no new shadows (a turn in
place, a move within EPSILON, a failed move's new heading).
"""

from __future__ import annotations

import math
from typing import Final, TYPE_CHECKING

from ..geometry import Frame, Position, Quat
from ..geometry.landdefs import get_block_offset
from ..objects.obstacle import MoverObstacle

if TYPE_CHECKING:
    from ..transition.sphere_path import SpherePath

__all__ = ["ShapeBounds", "PathReach", "may_touch", "mover_bounds", "path_reach"]

#: Slack added to every box side: the narrow phase places the shapes in single
#: precision (errors of order 1e-5 m at landblock scale) and overlaps within
#: EPSILON count; a centimetre covers both many times over.
MARGIN: Final = 0.01
#: How much wider than may_touch's test the cell loop's first look is
#: (path_reach): comparisons that round differently by an ulp cannot pass
#: over a mover may_touch would keep.
SLACK: Final = 1e-6


class ShapeBounds:
    """An axis-aligned box holding a mover's placed shapes, in the frame of
    its position's landblock, for the Position it was made for.

    Kept as the shapes' extent about the origin (`off_*`, for one orientation)
    plus the origin, so that a mover that only walked (the same orientation
    object, a new origin) gets its box by six additions, in place, instead of
    placing every shape again: in a crowd every mover's box is remade after
    each of its moves. `block` is the landblock of the position's cell (the
    cell loop's first look compares it)."""

    __slots__ = ("position", "orientation", "block", "off_min_x", "off_min_y", "off_min_z", "off_max_x",
                 "off_max_y", "off_max_z", "min_x", "min_y", "min_z", "max_x", "max_y", "max_z")

    def __init__(self, obstacle: MoverObstacle, position: Position, scale: float) -> None:
        # (every field set here, unconditionally: compiled, reads of them then need no "is it set" check)
        frame = position.frame
        o = frame.origin
        lo_x, lo_y, lo_z, hi_x, hi_y, hi_z = _extent(obstacle, frame, scale)
        self.orientation: Quat = frame.orientation
        self.off_min_x = lo_x
        self.off_min_y = lo_y
        self.off_min_z = lo_z
        self.off_max_x = hi_x
        self.off_max_y = hi_y
        self.off_max_z = hi_z
        self.position = position
        self.block = position.cell_id >> 16
        self.min_x = o.x + lo_x
        self.min_y = o.y + lo_y
        self.min_z = o.z + lo_z
        self.max_x = o.x + hi_x
        self.max_y = o.y + hi_y
        self.max_z = o.z + hi_z

    def place(self, obstacle: MoverObstacle, position: Position, scale: float) -> None:
        """The box at `position`: the extent moved to its origin (measured again first if the
        orientation is another object; rounding of the sums is far inside MARGIN)."""
        frame = position.frame
        if frame.orientation is not self.orientation:
            lo_x, lo_y, lo_z, hi_x, hi_y, hi_z = _extent(obstacle, frame, scale)
            self.orientation = frame.orientation
            self.off_min_x = lo_x
            self.off_min_y = lo_y
            self.off_min_z = lo_z
            self.off_max_x = hi_x
            self.off_max_y = hi_y
            self.off_max_z = hi_z
        o = frame.origin
        self.position = position
        self.block = position.cell_id >> 16
        self.min_x = o.x + self.off_min_x
        self.min_y = o.y + self.off_min_y
        self.min_z = o.z + self.off_min_z
        self.max_x = o.x + self.off_max_x
        self.max_y = o.y + self.off_max_y
        self.max_z = o.z + self.off_max_z


def _extent(obstacle: MoverObstacle, frame: Frame, scale: float) -> tuple[float, float, float, float, float, float]:
    """The shapes' extent about the frame's origin at its orientation, MARGIN included:
    (min x, min y, min z, max x, max y, max z)."""
    lo_x = lo_y = lo_z = math.inf  # (float("inf") would parse the text on every call, compiled)
    hi_x = hi_y = hi_z = -math.inf
    for sphere in obstacle.spheres:
        c = frame.local_to_global_vec(sphere.center * scale)
        r = sphere.radius * scale
        lo_x, lo_y, lo_z = min(lo_x, c.x - r), min(lo_y, c.y - r), min(lo_z, c.z - r)
        hi_x, hi_y, hi_z = max(hi_x, c.x + r), max(hi_y, c.y + r), max(hi_z, c.z + r)
    for cyl in obstacle.cyl_spheres:
        # an upright cylinder from its placed low point (CylSphere.intersects_sphere_at)
        low = frame.local_to_global_vec(cyl.low_point * scale)
        r = cyl.radius * scale
        lo_x, lo_y, lo_z = min(lo_x, low.x - r), min(lo_y, low.y - r), min(lo_z, low.z)
        hi_x, hi_y, hi_z = max(hi_x, low.x + r), max(hi_y, low.y + r), max(hi_z, low.z + cyl.height * scale)
    return (lo_x - MARGIN, lo_y - MARGIN, lo_z - MARGIN, hi_x + MARGIN, hi_y + MARGIN, hi_z + MARGIN)


def mover_bounds(obstacle: MoverObstacle) -> ShapeBounds:
    """The box of the obstacle's mover where it stands now (kept on the mover).

    Placed again, in place, when the mover's Position object is not the one
    it was placed for. Its scale is read then too: a mover's scale is fixed
    for its life (World.update_mover gives the object a new Mover)."""
    mover = obstacle.mover
    position: Position = mover.position
    bounds: ShapeBounds | None = mover.broad_phase_bounds
    if bounds is None:
        bounds = ShapeBounds(obstacle, position, mover.scale)
        mover.broad_phase_bounds = bounds
    elif bounds.position is not position:
        bounds.place(obstacle, position, mover.scale)
    return bounds


def may_touch(obstacle: MoverObstacle, path: SpherePath) -> bool:
    """Can the obstacle's test at the path's check position answer anything
    but OK (or change anything)? False only when no path sphere reaches the
    box of its shapes."""
    num_sphere = path.num_sphere
    if num_sphere == 0 or (path.collide and num_sphere < 2):
        return True  # (the single-sphere landing solve needs no overlap)
    bounds = mover_bounds(obstacle)
    check_cell = path.check_pos.cell_id
    cell = bounds.position.cell_id
    off_x = off_y = 0.0
    if (check_cell ^ cell) >> 16:  # in another landblock: move the spheres into its frame
        offset = get_block_offset(check_cell, cell)
        off_x, off_y = offset.x, offset.y
    foot_radius = path.global_sphere[0].radius
    for i in range(num_sphere if num_sphere < 2 else 2):
        sphere = path.global_sphere[i]
        c = sphere.center
        # the tests measure the head sphere's overlap with the foot sphere's radius
        r = sphere.radius if sphere.radius > foot_radius else foot_radius
        x = c.x - off_x
        y = c.y - off_y
        z = c.z
        if (
            bounds.min_x - r <= x <= bounds.max_x + r
            and bounds.min_y - r <= y <= bounds.max_y + r
            and bounds.min_z - r <= z <= bounds.max_z + r
        ):
            return True
    return False


#: path_reach's answer: (can the loop look first, the check cell's landblock,
#: min x, max x, min y, max y)
PathReach = tuple[bool, int, float, float, float, float]


def path_reach(path: SpherePath) -> PathReach:
    """The footprint every may_touch test of the path's spheres at the check
    position looks within: the x and y extent of the (up to two) spheres, each
    grown by the radius may_touch grows it by, plus SLACK, in the frame of the
    check cell's landblock. A mover in that landblock whose box misses it
    would fail may_touch; the cell's loop passes over it without calling it.

    The first field is False when may_touch culls nothing (no spheres, or a
    single-sphere path in collide mode): then nothing may be passed over.
    Computed again after every obstacle test the loop runs (a test may move
    the check position or shift the spheres)."""
    num_sphere = path.num_sphere
    block = path.check_pos.cell_id >> 16
    if num_sphere == 0 or (path.collide and num_sphere < 2):
        return (False, block, 0.0, 0.0, 0.0, 0.0)
    foot_radius = path.global_sphere[0].radius
    lo_x = lo_y = math.inf
    hi_x = hi_y = -math.inf
    for i in range(num_sphere if num_sphere < 2 else 2):
        sphere = path.global_sphere[i]
        c = sphere.center
        r = (sphere.radius if sphere.radius > foot_radius else foot_radius) + SLACK
        lo_x, lo_y = min(lo_x, c.x - r), min(lo_y, c.y - r)
        hi_x, hi_y = max(hi_x, c.x + r), max(hi_y, c.y + r)
    return (True, block, lo_x, hi_x, lo_y, hi_y)
