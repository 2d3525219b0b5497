"""Rounding to single precision.

The client keeps positions, planes and velocities as 32-bit floats. The
engine computes in double precision but stores what a move leaves behind at
the client's precision, so the next move starts from the same numbers the
client would (a strict `< 0` test on an offset of 1e-6 m otherwise decides a
slide differently).

A few computations inside a move are also done at the client's precision,
because their float64 value lands on the other side of an EPSILON test or
an f32 rounding boundary often enough to change a decision: terrain planes
(`Plane.from_points_f32`), the terrain contact distance (ValidateWalkable),
AdjustOffset, and the per-step offset. The helpers below emulate C# float
arithmetic on float32 inputs: each operation is done in float64 (exact for
products, and correctly rounded after a second rounding for +, -, /, sqrt)
and rounded to float32, in the order the client's expression evaluates.
"""

from __future__ import annotations

import math

from ..constants import EPSILON
from .plane import Plane
from .quaternion import Quat
from .single import to_single
from .vec3 import Vec3

__all__ = ["f32", "vec_f32", "plane_f32", "dot_f32", "plane_dist_f32", "scale_f32", "sub_f32", "cross_f32", "normalize_check_small_f32", "rotate_f32"]


def f32(x: float) -> float:
    return to_single(x)


def vec_f32(v: Vec3) -> Vec3:
    return Vec3(to_single(v.x), to_single(v.y), to_single(v.z))


def plane_f32(p: Plane) -> Plane:
    return Plane(vec_f32(p.normal), f32(p.d))


def dot_f32(ax: float, ay: float, az: float, bx: float, by: float, bz: float) -> float:
    """Vector3.Dot in single precision: (x*x' + y*y') + z*z', each step rounded."""
    return to_single(to_single(to_single(ax * bx) + to_single(ay * by)) + to_single(az * bz))


def plane_dist_f32(x: float, y: float, z: float, plane: Plane) -> float:
    """Vector3.Dot(p, normal) + d in single precision."""
    n = plane.normal
    return to_single(to_single(to_single(to_single(x * n.x) + to_single(y * n.y)) + to_single(z * n.z)) + plane.d)


def scale_f32(v: Vec3, s: float) -> Vec3:
    """v * s in single precision."""
    return Vec3(to_single(v.x * s), to_single(v.y * s), to_single(v.z * s))


def sub_f32(a: Vec3, b: Vec3) -> Vec3:
    """a - b in single precision."""
    return Vec3(to_single(a.x - b.x), to_single(a.y - b.y), to_single(a.z - b.z))


def cross_f32(a: Vec3, b: Vec3) -> Vec3:
    """Vector3.Cross in single precision (products rounded, then differences)."""
    return Vec3(
        to_single(to_single(a.y * b.z) - to_single(a.z * b.y)),
        to_single(to_single(a.z * b.x) - to_single(a.x * b.z)),
        to_single(to_single(a.x * b.y) - to_single(a.y * b.x)),
    )


def normalize_check_small_f32(v: Vec3) -> Vec3 | None:
    """Vec.NormalizeCheckSmall in single precision: None when shorter than EPSILON."""
    length = f32(math.sqrt(dot_f32(v.x, v.y, v.z, v.x, v.y, v.z)))
    if length < EPSILON:
        return None
    return scale_f32(v, f32(1.0 / length))


def rotate_f32(q: Quat, v: Vec3) -> Vec3:
    """`v` rotated by `q` in single precision, as System.Numerics'
    Vector3.Transform(Vector3, Quaternion) evaluates it (used by
    AFrame.Combine); exact for the identity."""
    if q.x == 0.0 and q.y == 0.0 and q.z == 0.0:
        return v
    x2 = to_single(q.x + q.x)
    y2 = to_single(q.y + q.y)
    z2 = to_single(q.z + q.z)
    wx2 = to_single(q.w * x2)
    wy2 = to_single(q.w * y2)
    wz2 = to_single(q.w * z2)
    xx2 = to_single(q.x * x2)
    xy2 = to_single(q.x * y2)
    xz2 = to_single(q.x * z2)
    yy2 = to_single(q.y * y2)
    yz2 = to_single(q.y * z2)
    zz2 = to_single(q.z * z2)
    r00 = to_single(to_single(1.0 - yy2) - zz2)
    r01 = to_single(xy2 - wz2)
    r02 = to_single(xz2 + wy2)
    r10 = to_single(xy2 + wz2)
    r11 = to_single(to_single(1.0 - xx2) - zz2)
    r12 = to_single(yz2 - wx2)
    r20 = to_single(xz2 - wy2)
    r21 = to_single(yz2 + wx2)
    r22 = to_single(to_single(1.0 - xx2) - yy2)
    return Vec3(
        to_single(to_single(to_single(v.x * r00) + to_single(v.y * r01)) + to_single(v.z * r02)),
        to_single(to_single(to_single(v.x * r10) + to_single(v.y * r11)) + to_single(v.z * r12)),
        to_single(to_single(to_single(v.x * r20) + to_single(v.y * r21)) + to_single(v.z * r22)),
    )
