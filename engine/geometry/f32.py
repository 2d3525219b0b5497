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
import struct

from ..constants import EPSILON

from .plane import Plane
from .vec3 import Vec3

__all__ = ["f32", "vec_f32", "plane_f32", "dot_f32", "plane_dist_f32", "scale_f32", "sub_f32", "cross_f32", "normalize_check_small_f32"]

_pack3 = struct.Struct("<3f")
_pack1 = struct.Struct("<f")
_pack6 = struct.Struct("<6f")


def f32(x: float) -> float:
    return _pack1.unpack(_pack1.pack(x))[0]


def vec_f32(v: Vec3) -> Vec3:
    x, y, z = _pack3.unpack(_pack3.pack(v.x, v.y, v.z))
    return Vec3(x, y, z)


def plane_f32(p: Plane) -> Plane:
    return Plane(vec_f32(p.normal), f32(p.d))


def dot_f32(ax: float, ay: float, az: float, bx: float, by: float, bz: float) -> float:
    """Vector3.Dot in single precision: (x*x' + y*y') + z*z', each step rounded."""
    px, py, pz = _pack3.unpack(_pack3.pack(ax * bx, ay * by, az * bz))
    return _pack1.unpack(_pack1.pack(_pack1.unpack(_pack1.pack(px + py))[0] + pz))[0]


def plane_dist_f32(x: float, y: float, z: float, plane: Plane) -> float:
    """Vector3.Dot(p, normal) + d in single precision."""
    n = plane.normal
    px, py, pz = _pack3.unpack(_pack3.pack(x * n.x, y * n.y, z * n.z))
    s = _pack1.unpack(_pack1.pack(px + py))[0]
    s = _pack1.unpack(_pack1.pack(s + pz))[0]
    return _pack1.unpack(_pack1.pack(s + plane.d))[0]


def scale_f32(v: Vec3, s: float) -> Vec3:
    """v * s in single precision."""
    x, y, z = _pack3.unpack(_pack3.pack(v.x * s, v.y * s, v.z * s))
    return Vec3(x, y, z)


def sub_f32(a: Vec3, b: Vec3) -> Vec3:
    """a - b in single precision."""
    x, y, z = _pack3.unpack(_pack3.pack(a.x - b.x, a.y - b.y, a.z - b.z))
    return Vec3(x, y, z)


def cross_f32(a: Vec3, b: Vec3) -> Vec3:
    """Vector3.Cross in single precision (products rounded, then differences)."""
    p = _pack6.unpack(_pack6.pack(a.y * b.z, a.z * b.y, a.z * b.x, a.x * b.z, a.x * b.y, a.y * b.x))
    x, y, z = _pack3.unpack(_pack3.pack(p[0] - p[1], p[2] - p[3], p[4] - p[5]))
    return Vec3(x, y, z)


def normalize_check_small_f32(v: Vec3) -> Vec3 | None:
    """Vec.NormalizeCheckSmall in single precision: None when shorter than EPSILON."""
    length = f32(math.sqrt(dot_f32(v.x, v.y, v.z, v.x, v.y, v.z)))
    if length < EPSILON:
        return None
    return scale_f32(v, f32(1.0 / length))
