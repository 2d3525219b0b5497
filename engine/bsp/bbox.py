"""Axis-aligned boxes (the client's BBox) and the plane-versus-box side test.

Used by the cell BSP's `box_intersects_cell_bsp` and by the cell / part code
that decides which cells an object's parts reach.
"""

from __future__ import annotations

from typing import Final, TYPE_CHECKING
from collections.abc import Iterable

from ..constants import EPSILON
from ..geometry.plane import Plane, Side
from ..geometry.vec3 import Vec3

if TYPE_CHECKING:
    from ..geometry.position import Position

__all__ = ["BBox", "intersect_box"]

_BIG: Final = 3.4028234663852886e38  # float.MaxValue of the reference


class BBox:
    """A box from `min` to `max`. Mutable, like the reference's: the
    adjusting methods grow it in place."""

    __slots__ = ("min", "max")

    min: Vec3
    max: Vec3

    def __init__(self, min_corner: Vec3 | None = None, max_corner: Vec3 | None = None) -> None:
        if min_corner is None or max_corner is None:
            self.init_for_adjustment()
            if min_corner is not None:
                self.min = min_corner
            if max_corner is not None:
                self.max = max_corner
        else:
            self.min = min_corner
            self.max = max_corner

    def __repr__(self) -> str:
        return f"BBox({self.min!r}, {self.max!r})"

    @classmethod
    def from_points(cls, points: Iterable[Vec3]) -> BBox:
        """The smallest box holding every point (an emptied box adjusted by each)."""
        box = cls()
        for p in points:
            box.adjust_bbox(p)
        return box

    def init_for_adjustment(self) -> None:
        """Empty the box so the first adjust_bbox sets it (BBox.InitForAdjustment)."""
        self.min = Vec3(_BIG, _BIG, _BIG)
        self.max = Vec3(-_BIG, -_BIG, -_BIG)

    def adjust_bbox(self, v: Vec3) -> None:
        """Grow the box to hold `v` (BBox.AdjustBBox)."""
        mn, mx = self.min, self.max
        if v.x < mn.x or v.y < mn.y or v.z < mn.z:
            self.min = Vec3(v.x if v.x < mn.x else mn.x, v.y if v.y < mn.y else mn.y, v.z if v.z < mn.z else mn.z)
        if v.x > mx.x or v.y > mx.y or v.z > mx.z:
            self.max = Vec3(v.x if v.x > mx.x else mx.x, v.y if v.y > mx.y else mx.y, v.z if v.z > mx.z else mx.z)

    def build_bounding_box(self, bbox: BBox) -> None:
        """Grow `bbox` to hold this box (BBox.BuildBoundingBox): its min
        against our min, its max against our max, per axis."""
        mn, mx, bmn, bmx = self.min, self.max, bbox.min, bbox.max
        bbox.min = Vec3(min(bmn.x, mn.x), min(bmn.y, mn.y), min(bmn.z, mn.z)) if mn.x < bmn.x or mn.y < bmn.y or mn.z < bmn.z else bmn
        bbox.max = Vec3(max(bmx.x, mx.x), max(bmx.y, mx.y), max(bmx.z, mx.z)) if mx.x > bmx.x or mx.y > bmx.y or mx.z > bmx.z else bmx

    def contains(self, point: Vec3) -> bool:
        """The point is inside or on the box (BBox.Contains)."""
        mn, mx = self.min, self.max
        return mn.x <= point.x <= mx.x and mn.y <= point.y <= mx.y and mn.z <= point.z <= mx.z

    def get_half_extent(self) -> Vec3:
        """Half the box's size per axis. The reference calls this GetCenter,
        but it returns (max - min) / 2, not the center."""
        mn, mx = self.min, self.max
        return Vec3((mx.x - mn.x) * 0.5, (mx.y - mn.y) * 0.5, (mx.z - mn.z) * 0.5)

    def get_corners(self) -> tuple[Vec3, ...]:
        """The eight corners, in the reference's order (BBox.GetCorners)."""
        mn, mx = self.min, self.max
        return (
            Vec3(mn.x, mn.y, mn.z),
            Vec3(mn.x, mn.y, mx.z),
            Vec3(mn.x, mx.y, mn.z),
            Vec3(mn.x, mx.y, mx.z),
            Vec3(mx.x, mn.y, mn.z),
            Vec3(mx.x, mn.y, mx.z),
            Vec3(mx.x, mx.y, mn.z),
            Vec3(mx.x, mx.y, mx.z),
        )

    def convert_to_global(self, pos: Position) -> None:
        """Transform min and max (only those two points) by pos's frame
        (BBox.ConvertToGlobal). With a rotation the result need not be a
        proper box; the reference keeps it that way."""
        frame = pos.frame
        self.min = frame.local_to_global(self.min)
        self.max = frame.local_to_global(self.max)

    def local_to_global(self, from_box: BBox, from_pos: Position, to_pos: Position) -> None:
        """Set this box to `from_box` (in from_pos's frame) expressed in
        to_pos's landblock frame (BBox.LocalToGlobal).

        As in the reference, min and max start as the transformed min and
        max corners, then six more corners (not all eight) widen it.
        """
        self._from_corners(from_box, lambda p: to_pos.local_to_global_from(from_pos, p))

    def local_to_local(self, from_box: BBox, from_pos: Position, to_pos: Position) -> None:
        """Set this box to `from_box` (in from_pos's frame) expressed in
        to_pos's local frame (BBox.LocalToLocal); corners as in local_to_global."""
        self._from_corners(from_box, lambda p: to_pos.local_to_local(from_pos, p))

    def _from_corners(self, from_box: BBox, transform) -> None:  # type: ignore[no-untyped-def]
        mn, mx = from_box.min, from_box.max
        self.min = transform(mn)
        self.max = transform(mx)
        self.adjust_bbox(transform(Vec3(mx.x, mx.y, mn.z)))
        self.adjust_bbox(transform(Vec3(mx.x, mn.y, mx.z)))
        self.adjust_bbox(transform(Vec3(mn.x, mx.y, mx.z)))
        self.adjust_bbox(transform(Vec3(mn.x, mx.y, mn.z)))
        self.adjust_bbox(transform(Vec3(mx.x, mn.y, mn.z)))
        self.adjust_bbox(transform(Vec3(mn.x, mn.y, mx.z)))


def intersect_box(plane: Plane, box: BBox) -> int:
    """Which side of `plane` the box is on (Plane.intersect_box).

    Returns a Side value: FRONT (Positive) or BEHIND (Negative) when the min
    corner and every corner, each with EPSILON of bias, are on that side;
    CROSSING otherwise, and at once when the min corner is within EPSILON of
    the plane.
    """
    n = plane.normal
    mn = box.min
    dist = mn.x * n.x + mn.y * n.y + mn.z * n.z + plane.d
    if dist <= EPSILON:
        if dist >= -EPSILON:
            return Side.CROSSING
        result = Side.BEHIND
    else:
        result = Side.FRONT
    for corner in box.get_corners():
        if plane.side(corner, EPSILON) != result:
            return Side.CROSSING
    return result
