"""A rigid placement (AFrame): an origin and an orientation.

Frames are immutable; "moving" a frame makes a new one. This is what the
client's copy-on-assign Position semantics amount to, and it lets the path,
its backups and the caller share frames without defensive copies. The rotation
matrix is computed once per frame and skipped entirely for the identity
orientation, which nearly every outdoor mover has.
"""

from __future__ import annotations

from ..constants import EPSILON
from .quaternion import IDENTITY, Mat3, Quat
from .single import fl
from .vec3 import Vec3
from .._compat import mypyc_attr

__all__ = ["Frame", "to_local_xyz"]


@mypyc_attr(acyclic=True, free_list_len=1)
class Frame:
    __slots__ = ("origin", "orientation", "_m")

    origin: Vec3
    orientation: Quat
    _m: Mat3 | None

    def __init__(self, origin: Vec3, orientation: Quat = IDENTITY) -> None:
        self.origin = origin
        self.orientation = orientation
        self._m = orientation.cached_matrix()

    def __repr__(self) -> str:
        return f"Frame({self.origin!r}, {self.orientation!r})"

    def with_origin(self, origin: Vec3) -> Frame:
        return Frame(origin, self.orientation)

    def with_orientation(self, orientation: Quat) -> Frame:
        return Frame(self.origin, orientation)

    # -- transforms (AFrame.LocalToGlobal / GlobalToLocal) ----------------
    def local_to_global_vec(self, v: Vec3) -> Vec3:
        m = self._m
        return v if m is None else Vec3(m.m0 * v.x + m.m1 * v.y + m.m2 * v.z, m.m3 * v.x + m.m4 * v.y + m.m5 * v.z, m.m6 * v.x + m.m7 * v.y + m.m8 * v.z)

    def global_to_local_vec(self, v: Vec3) -> Vec3:
        """The inverse rotation: the transpose of the matrix."""
        m = self._m
        return v if m is None else Vec3(m.m0 * v.x + m.m3 * v.y + m.m6 * v.z, m.m1 * v.x + m.m4 * v.y + m.m7 * v.z, m.m2 * v.x + m.m5 * v.y + m.m8 * v.z)

    def local_to_global(self, p: Vec3) -> Vec3:
        """origin + local_to_global_vec(p), without the intermediate vector."""
        o = self.origin
        m = self._m
        if m is None:
            return Vec3(o.x + p.x, o.y + p.y, o.z + p.z)
        x, y, z = p.x, p.y, p.z
        return Vec3(
            o.x + (m.m0 * x + m.m1 * y + m.m2 * z),
            o.y + (m.m3 * x + m.m4 * y + m.m5 * z),
            o.z + (m.m6 * x + m.m7 * y + m.m8 * z),
        )

    def local_to_global_fl(self, p: Vec3, single: bool) -> Vec3:
        """fl_vec(local_to_global(p), single): the same sums, each component rounded to the
        working precision, as one new vector."""
        o = self.origin
        m = self._m
        if m is None:
            return Vec3(fl(o.x + p.x, single), fl(o.y + p.y, single), fl(o.z + p.z, single))
        x, y, z = p.x, p.y, p.z
        return Vec3(
            fl(o.x + (m.m0 * x + m.m1 * y + m.m2 * z), single),
            fl(o.y + (m.m3 * x + m.m4 * y + m.m5 * z), single),
            fl(o.z + (m.m6 * x + m.m7 * y + m.m8 * z), single),
        )

    def global_to_local(self, p: Vec3) -> Vec3:
        """global_to_local_vec(p - origin), without the intermediate vector."""
        return to_local_xyz(self, p.x, p.y, p.z)

    def combine(self, child: Frame, scale: Vec3 | None = None) -> Frame:
        """The frame of `child` (given in self's space) in self's parent space."""
        o = child.origin
        if scale is not None:
            o = Vec3(o.x * scale.x, o.y * scale.y, o.z * scale.z)
        return Frame(self.local_to_global(o), self.orientation * child.orientation)

    def equals_within_epsilon(self, other: Frame) -> bool:
        """AFrame.Equals: origins equal within EPSILON per axis.

        (The client's orientation half compares each frame with itself, so only
        the origins decide.)
        """
        a, b = self.origin, other.origin
        return abs(a.x - b.x) <= EPSILON and abs(a.y - b.y) <= EPSILON and abs(a.z - b.z) <= EPSILON

    def is_finite(self) -> bool:
        return self.origin.is_finite() and self.orientation.is_finite()


def to_local_xyz(frame: Frame, gx: float, gy: float, gz: float) -> Vec3:
    """`frame.global_to_local` of the point (gx, gy, gz)."""
    o = frame.origin
    x = gx - o.x
    y = gy - o.y
    z = gz - o.z
    m = frame._m
    if m is None:
        return Vec3(x, y, z)
    return Vec3(m.m0 * x + m.m3 * y + m.m6 * z, m.m1 * x + m.m4 * y + m.m7 * z, m.m2 * x + m.m5 * y + m.m8 * z)
