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
from .landdefs import get_block_offset
from .plane import Plane
from .position import Position
from .quaternion import Quat
from .single import to_single
from .vec3 import Vec3

__all__ = ["f32", "vec_f32", "plane_f32", "dot_f32", "plane_dist_f32", "scale_f32", "sub_f32", "cross_f32", "normalize_check_small_f32", "rotate_f32", "unrotate_f32", "local_z_f32", "place_f32"]


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


def _rotation_f32(q: Quat) -> tuple[float, float, float, float, float, float, float, float, float]:
    """The matrix (row-major) of System.Numerics' Vector3.Transform(v, q) in
    float32: every product and sum of the quaternion's doubled components
    rounded, as that routine evaluates them. Kept on the quaternion."""
    m = q.r32
    if m is None:
        qw = to_single(q.w)
        qx = to_single(q.x)
        qy = to_single(q.y)
        qz = to_single(q.z)
        x2 = to_single(qx + qx)
        y2 = to_single(qy + qy)
        z2 = to_single(qz + qz)
        wx2 = to_single(qw * x2)
        wy2 = to_single(qw * y2)
        wz2 = to_single(qw * z2)
        xx2 = to_single(qx * x2)
        xy2 = to_single(qx * y2)
        xz2 = to_single(qx * z2)
        yy2 = to_single(qy * y2)
        yz2 = to_single(qy * z2)
        zz2 = to_single(qz * z2)
        m = (
            to_single(to_single(1.0 - yy2) - zz2), to_single(xy2 - wz2), to_single(xz2 + wy2),
            to_single(xy2 + wz2), to_single(to_single(1.0 - xx2) - zz2), to_single(yz2 - wx2),
            to_single(xz2 - wy2), to_single(yz2 + wx2), to_single(to_single(1.0 - xx2) - yy2),
        )  # fmt: skip
        q.r32 = m
    return m


def _inverse_rotation_f32(q: Quat) -> tuple[float, float, float, float, float, float, float, float, float]:
    """The matrix (row-major) the client's AFrame.GlobalToLocalVec applies:
    the transpose of Matrix4x4.CreateFromQuaternion(q), built in float32 as
    that routine builds it. Kept on the quaternion."""
    m = q.u32
    if m is None:
        qw = to_single(q.w)
        qx = to_single(q.x)
        qy = to_single(q.y)
        qz = to_single(q.z)
        xx = to_single(qx * qx)
        yy = to_single(qy * qy)
        zz = to_single(qz * qz)
        xy = to_single(qx * qy)
        wz = to_single(qz * qw)
        xz = to_single(qz * qx)
        wy = to_single(qy * qw)
        yz = to_single(qy * qz)
        wx = to_single(qx * qw)
        # CreateFromQuaternion's M11..M33; the transpose's row i is its column i
        m11 = to_single(1.0 - to_single(2.0 * to_single(yy + zz)))
        m12 = to_single(2.0 * to_single(xy + wz))
        m13 = to_single(2.0 * to_single(xz - wy))
        m21 = to_single(2.0 * to_single(xy - wz))
        m22 = to_single(1.0 - to_single(2.0 * to_single(zz + xx)))
        m23 = to_single(2.0 * to_single(yz + wx))
        m31 = to_single(2.0 * to_single(xz + wy))
        m32 = to_single(2.0 * to_single(yz - wx))
        m33 = to_single(1.0 - to_single(2.0 * to_single(yy + xx)))
        m = (m11, m12, m13, m21, m22, m23, m31, m32, m33)
        q.u32 = m
    return m


def _apply_f32(m: tuple[float, float, float, float, float, float, float, float, float], v: Vec3) -> Vec3:
    """Row-major matrix times `v`, each product and sum rounded in order."""
    x = v.x
    y = v.y
    z = v.z
    return Vec3(
        to_single(to_single(to_single(x * m[0]) + to_single(y * m[1])) + to_single(z * m[2])),
        to_single(to_single(to_single(x * m[3]) + to_single(y * m[4])) + to_single(z * m[5])),
        to_single(to_single(to_single(x * m[6]) + to_single(y * m[7])) + to_single(z * m[8])),
    )


def rotate_f32(q: Quat, v: Vec3) -> Vec3:
    """`v` rotated by `q` in single precision, as System.Numerics'
    Vector3.Transform(Vector3, Quaternion) evaluates it (used by
    AFrame.Combine and LocalToGlobalVec); exact for the identity."""
    if q.x == 0.0 and q.y == 0.0 and q.z == 0.0:
        return v
    return _apply_f32(_rotation_f32(q), v)


def unrotate_f32(q: Quat, v: Vec3) -> Vec3:
    """`v` rotated by the inverse of `q` in single precision, as the client's
    AFrame.GlobalToLocalVec evaluates it: Vector3.Transform by the transpose
    of Matrix4x4.CreateFromQuaternion(q). Exact for the identity."""
    if q.x == 0.0 and q.y == 0.0 and q.z == 0.0:
        return v
    return _apply_f32(_inverse_rotation_f32(q), v)


def local_z_f32(q: Quat) -> Vec3:
    """unrotate_f32(q, +z): the third column of the inverse matrix's rows."""
    if q.x == 0.0 and q.y == 0.0 and q.z == 0.0:
        return Vec3(0.0, 0.0, 1.0)
    m = _inverse_rotation_f32(q)
    return Vec3(m[2], m[5], m[8])


def place_f32(cell_id: int, position: Position, point: Vec3, scale: float) -> Vec3:
    """`point` of an object at `position`, times `scale`, in the landblock
    frame of cell `cell_id`, in single precision as the client places an
    obstacle's sphere or cylinder (Position.LocalToGlobal(position, point *
    scale): rotated, added to the origin, then the landblock offset)."""
    f = to_single(scale)
    local = Vec3(to_single(to_single(point.x) * f), to_single(to_single(point.y) * f), to_single(to_single(point.z) * f))
    r = rotate_f32(position.frame.orientation, local)
    o = position.frame.origin
    x = to_single(o.x + r.x)
    y = to_single(o.y + r.y)
    z = to_single(o.z + r.z)
    if (cell_id >> 16) != (position.cell_id >> 16):
        block = get_block_offset(cell_id, position.cell_id)
        x = to_single(block.x + x)
        y = to_single(block.y + y)
        z = to_single(block.z + z)
    return Vec3(x, y, z)
