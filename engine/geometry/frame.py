"""A rigid placement (AFrame): an origin and an orientation.

Frames are immutable; "moving" a frame makes a new one. This is what the
client's copy-on-assign Position semantics amount to, and it lets the path,
its backups and the caller share frames without defensive copies. The rotation
matrix is computed once per frame and skipped entirely for the identity
orientation, which nearly every outdoor mover has.
"""

from __future__ import annotations

from ..constants import EPSILON
from .quaternion import IDENTITY, Quat
from .vec3 import Vec3

__all__ = ["Frame"]

_Matrix = tuple[float, float, float, float, float, float, float, float, float]


class Frame:
    __slots__ = ("origin", "orientation", "_m")

    origin: Vec3
    orientation: Quat
    _m: _Matrix | None

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
        if m is None:
            return v
        return Vec3(
            m[0] * v.x + m[1] * v.y + m[2] * v.z,
            m[3] * v.x + m[4] * v.y + m[5] * v.z,
            m[6] * v.x + m[7] * v.y + m[8] * v.z,
        )

    def global_to_local_vec(self, v: Vec3) -> Vec3:
        m = self._m
        if m is None:
            return v
        # the transpose of a rotation is its inverse
        return Vec3(
            m[0] * v.x + m[3] * v.y + m[6] * v.z,
            m[1] * v.x + m[4] * v.y + m[7] * v.z,
            m[2] * v.x + m[5] * v.y + m[8] * v.z,
        )

    def local_to_global(self, p: Vec3) -> Vec3:
        return self.origin + self.local_to_global_vec(p)

    def global_to_local(self, p: Vec3) -> Vec3:
        return self.global_to_local_vec(p - self.origin)

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
