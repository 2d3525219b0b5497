"""Rounding to single precision.

The client keeps positions, planes and velocities as 32-bit floats. The
engine computes in double precision but stores what a move leaves behind at
the client's precision, so the next move starts from the same numbers the
client would (a strict `< 0` test on an offset of 1e-6 m otherwise decides a
slide differently).
"""

from __future__ import annotations

import struct

from .plane import Plane
from .vec3 import Vec3

__all__ = ["f32", "vec_f32", "plane_f32"]

_pack3 = struct.Struct("<3f")
_pack1 = struct.Struct("<f")


def f32(x: float) -> float:
    return _pack1.unpack(_pack1.pack(x))[0]


def vec_f32(v: Vec3) -> Vec3:
    x, y, z = _pack3.unpack(_pack3.pack(v.x, v.y, v.z))
    return Vec3(x, y, z)


def plane_f32(p: Plane) -> Plane:
    return Plane(vec_f32(p.normal), f32(p.d))
