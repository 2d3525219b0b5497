"""Position: a cell id plus a frame in that cell's landblock coordinates."""

from __future__ import annotations

from .frame import Frame, to_local_xyz
from .landdefs import get_block_offset
from .quaternion import IDENTITY, Quat
from .vec3 import Vec3
from .._compat import mypyc_attr

__all__ = ["Position"]


@mypyc_attr(acyclic=True, free_list_len=1)
class Position:
    """Immutable (cell id, frame). Frame origins are landblock-local metres."""

    __slots__ = ("cell_id", "frame")

    cell_id: int
    frame: Frame

    def __init__(self, cell_id: int, frame: Frame) -> None:
        self.cell_id = cell_id
        self.frame = frame

    @classmethod
    def at(cls, cell_id: int, origin: Vec3, orientation: Quat = IDENTITY) -> Position:
        return cls(cell_id, Frame(origin, orientation))

    def __repr__(self) -> str:
        return f"Position({self.cell_id:08X}, {self.frame.origin!r}, {self.frame.orientation!r})"

    @property
    def origin(self) -> Vec3:
        return self.frame.origin

    @property
    def landblock(self) -> int:
        return (self.cell_id >> 16) & 0xFFFF

    def with_origin(self, origin: Vec3) -> Position:
        return Position(self.cell_id, self.frame.with_origin(origin))

    def with_cell(self, cell_id: int) -> Position:
        return Position(cell_id, self.frame)

    def moved(self, offset: Vec3) -> Position:
        return Position(self.cell_id, self.frame.with_origin(self.frame.origin + offset))

    def equals(self, other: Position) -> bool:
        """Position.Equals: same cell, origins within EPSILON."""
        return self.cell_id == other.cell_id and self.frame.equals_within_epsilon(other.frame)

    # -- conversions (Position.GetOffset / LocalToLocal / LocalToGlobal) --
    def get_offset(self, other: Position) -> Vec3:
        """Vector from self to other, in self's landblock frame."""
        return get_block_offset(self.cell_id, other.cell_id) + other.frame.origin - self.frame.origin

    def local_to_global(self, point: Vec3) -> Vec3:
        return self.frame.local_to_global(point)

    def local_to_global_from(self, other: Position, point: Vec3) -> Vec3:
        """A point given in other's local frame, in self's landblock frame."""
        return get_block_offset(self.cell_id, other.cell_id) + other.frame.local_to_global(point)

    def local_to_local(self, other: Position, point: Vec3) -> Vec3:
        """A point given in other's local frame, in self's local frame
        (global_to_local of local_to_global_from, the same operations in the
        same order, on floats)."""
        off = get_block_offset(self.cell_id, other.cell_id)
        of = other.frame
        oo = of.origin
        om = of._m
        px, py, pz = point.x, point.y, point.z
        if om is None:
            gx = off.x + (oo.x + px)
            gy = off.y + (oo.y + py)
            gz = off.z + (oo.z + pz)
        else:
            gx = off.x + (oo.x + (om.m0 * px + om.m1 * py + om.m2 * pz))
            gy = off.y + (oo.y + (om.m3 * px + om.m4 * py + om.m5 * pz))
            gz = off.z + (oo.z + (om.m6 * px + om.m7 * py + om.m8 * pz))
        return to_local_xyz(self.frame, gx, gy, gz)

    def local_to_global_vec(self, v: Vec3) -> Vec3:
        return self.frame.local_to_global_vec(v)

    def global_to_local_vec(self, v: Vec3) -> Vec3:
        return self.frame.global_to_local_vec(v)
