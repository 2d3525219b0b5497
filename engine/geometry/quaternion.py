"""Unit quaternions for orientations, stored [w, x, y, z] as in the formats."""

from __future__ import annotations

import math
from typing import Final

from ..constants import EPSILON
from .vec3 import Vec3
from .._compat import mypyc_attr

__all__ = ["Quat", "IDENTITY", "Mat3"]

_Matrix = tuple[float, float, float, float, float, float, float, float, float]


@mypyc_attr(acyclic=True)
class Mat3:
    """A row-major 3x3 rotation matrix kept as nine native floats (m0..m8,
    the entries of `Quat.rotation_matrix` in order), so compiled transforms
    read them without unboxing tuple items."""

    __slots__ = ("m0", "m1", "m2", "m3", "m4", "m5", "m6", "m7", "m8")

    m0: float
    m1: float
    m2: float
    m3: float
    m4: float
    m5: float
    m6: float
    m7: float
    m8: float

    def __init__(self, m: _Matrix) -> None:
        self.m0, self.m1, self.m2, self.m3, self.m4, self.m5, self.m6, self.m7, self.m8 = m

    def as_tuple(self) -> _Matrix:
        return (self.m0, self.m1, self.m2, self.m3, self.m4, self.m5, self.m6, self.m7, self.m8)


@mypyc_attr(acyclic=True)
class Quat:
    """An orientation quaternion (w + xi + yj + zk)."""

    __slots__ = ("w", "x", "y", "z", "_m", "_m_known", "r32", "u32", "r64", "u64")

    w: float
    x: float
    y: float
    z: float
    _m: Mat3 | None
    _m_known: bool
    #: the client's rotation matrices (engine.geometry.precision), once
    #: computed: in single precision (r32, u32) and in double (r64, u64)
    r32: _Matrix | None
    u32: _Matrix | None
    r64: _Matrix | None
    u64: _Matrix | None

    def __init__(self, w: float = 1.0, x: float = 0.0, y: float = 0.0, z: float = 0.0) -> None:
        self.w = w
        self.x = x
        self.y = y
        self.z = z
        self._m = None
        self._m_known = False
        self.r32 = None
        self.u32 = None
        self.r64 = None
        self.u64 = None

    def cached_matrix(self) -> Mat3 | None:
        """The rotation matrix, computed once; None for the identity (no work to do)."""
        if not self._m_known:
            self._m = None if self.is_identity() else Mat3(self.rotation_matrix())
            self._m_known = True
        return self._m

    def __eq__(self, o: object) -> bool:
        return (
            isinstance(o, Quat)
            and self.w == o.w
            and self.x == o.x
            and self.y == o.y
            and self.z == o.z
        )

    def __hash__(self) -> int:
        return hash((self.w, self.x, self.y, self.z))

    def __repr__(self) -> str:
        return f"Quat({self.w!r}, {self.x!r}, {self.y!r}, {self.z!r})"

    def as_tuple(self) -> tuple[float, float, float, float]:
        return (self.w, self.x, self.y, self.z)

    def is_identity(self) -> bool:
        return self.x == 0.0 and self.y == 0.0 and self.z == 0.0 and self.w == 1.0

    def is_finite(self) -> bool:
        # x - x is 0 exactly for a finite x (as in Vec3.is_finite: no call by name when compiled)
        w, x, y, z = self.w, self.x, self.y, self.z
        return w - w == 0.0 and x - x == 0.0 and y - y == 0.0 and z - z == 0.0

    def is_valid(self) -> bool:
        """Finite and of unit length within 5 EPSILON (`Quaternion.IsValid`)."""
        if not self.is_finite():
            return False
        return abs(self.length() - 1.0) <= EPSILON * 5.0

    def length(self) -> float:
        return math.sqrt(self.w * self.w + self.x * self.x + self.y * self.y + self.z * self.z)

    def normalized(self) -> Quat:
        n = self.length()
        if n == 0.0:
            return Quat()
        inv = 1.0 / n
        return Quat(self.w * inv, self.x * inv, self.y * inv, self.z * inv)

    def conjugate(self) -> Quat:
        return Quat(self.w, -self.x, -self.y, -self.z)

    def __mul__(self, o: Quat) -> Quat:
        """Hamilton product: rotate by `o` first, then by self."""
        return Quat(
            self.w * o.w - self.x * o.x - self.y * o.y - self.z * o.z,
            self.w * o.x + self.x * o.w + self.y * o.z - self.z * o.y,
            self.w * o.y - self.x * o.z + self.y * o.w + self.z * o.x,
            self.w * o.z + self.x * o.y - self.y * o.x + self.z * o.w,
        )

    def rotation_matrix(self) -> _Matrix:
        """Row-major 3x3 matrix R with R @ v equal to rotating v by self."""
        w, x, y, z = self.w, self.x, self.y, self.z
        xx, yy, zz = x * x, y * y, z * z
        xy, xz, yz = x * y, x * z, y * z
        wx, wy, wz = w * x, w * y, w * z
        return (
            1.0 - 2.0 * (yy + zz), 2.0 * (xy - wz), 2.0 * (xz + wy),
            2.0 * (xy + wz), 1.0 - 2.0 * (xx + zz), 2.0 * (yz - wx),
            2.0 * (xz - wy), 2.0 * (yz + wx), 1.0 - 2.0 * (xx + yy),
        )

    def rotate(self, v: Vec3) -> Vec3:
        m = self.rotation_matrix()
        return Vec3(
            m[0] * v.x + m[1] * v.y + m[2] * v.z,
            m[3] * v.x + m[4] * v.y + m[5] * v.z,
            m[6] * v.x + m[7] * v.y + m[8] * v.z,
        )

    @staticmethod
    def lerp(a: Quat, b: Quat, t: float) -> Quat:
        """Normalised linear blend along the shorter arc.

        The client's frame rotation interpolation (AFrame.InterpolateRotation):
        flip `b` when the two lie in opposite hemispheres, blend, renormalise.
        """
        s = 1.0 - t
        if a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z < 0.0:
            t = -t
        return Quat(
            s * a.w + t * b.w, s * a.x + t * b.x, s * a.y + t * b.y, s * a.z + t * b.z
        ).normalized()

    @staticmethod
    def from_heading(degrees: float) -> Quat:
        """Orientation facing `degrees` clockwise from north (AC heading)."""
        # AC heading 0 faces +y (north); 90 faces +x (east): a yaw of -heading about z.
        half = -math.radians(degrees) * 0.5
        return Quat(math.cos(half), 0.0, 0.0, math.sin(half))


IDENTITY: Final = Quat(1.0, 0.0, 0.0, 0.0)
