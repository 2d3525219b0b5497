"""Rounding to single precision.

The client keeps positions, planes and velocities as 32-bit floats. The
engine computes in double precision but stores what a move leaves behind at
the client's precision, so the next move starts from the same numbers the
client would (a strict `< 0` test on an offset of 1e-6 m otherwise decides a
slide differently).
"""

from __future__ import annotations

from .plane import Plane
from .single import to_single
from .vec3 import Vec3

__all__ = ["f32", "vec_f32", "plane_f32"]


def f32(x: float) -> float:
    return to_single(x)


def vec_f32(v: Vec3) -> Vec3:
    return Vec3(to_single(v.x), to_single(v.y), to_single(v.z))


def plane_f32(p: Plane) -> Plane:
    return Plane(vec_f32(p.normal), f32(p.d))
