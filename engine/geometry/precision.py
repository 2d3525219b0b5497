"""Arithmetic at the engine's working precision.

The client keeps positions, planes and velocities as 32-bit floats. With
EngineSettings.single_precision (the default) the engine computes in double
precision but stores what a move leaves behind at the client's precision, so
the next move starts from the same numbers the client would (a strict `< 0`
test on an offset of 1e-6 m otherwise decides a slide differently).

A few computations inside a move are also done at the client's precision,
because their float64 value lands on the other side of an EPSILON test or
an f32 rounding boundary often enough to change a decision: planes
(`Plane.from_points`), the terrain contact distance (ValidateWalkable),
AdjustOffset, slides, the per-step offset. The helpers below emulate C#
float arithmetic on float32 inputs: each operation is done in float64 (exact
for products, and correctly rounded after a second rounding for +, -, /,
sqrt) and rounded to float32, in the order the client's expression
evaluates.

Every helper takes `single`, the setting, and rounds through `fl` (the one
place the setting takes effect): with `single` false the same expressions
run in double precision.
"""

from __future__ import annotations

import math

from ..constants import EPSILON
from .landdefs import get_block_offset
from .plane import Plane
from .position import Position
from .quaternion import Quat
from .single import fl
from .vec3 import Vec3

__all__ = [
    "fl",
    "fl_vec",
    "fl_plane",
    "fl_dot",
    "fl_plane_dist",
    "fl_scale",
    "fl_add",
    "fl_sub",
    "fl_cross",
    "fl_normalize_check_small",
    "fl_rotate",
    "fl_unrotate",
    "fl_local_z",
    "fl_place",
]

_Matrix = tuple[float, float, float, float, float, float, float, float, float]


def fl_vec(v: Vec3, single: bool) -> Vec3:
    """`v` at the working precision: `v` itself in double precision, or when its
    components are float32 values already (what a move stores mostly is)."""
    if not single:
        return v
    x = fl(v.x, True)
    y = fl(v.y, True)
    z = fl(v.z, True)
    if x == v.x and y == v.y and z == v.z:
        return v  # (vectors are immutable: sharing is a copy)
    return Vec3(x, y, z)


def fl_plane(p: Plane, single: bool) -> Plane:
    """`p` at the working precision: `p` itself in double precision, or when it is
    a float32 plane already."""
    if not single:
        return p
    normal = fl_vec(p.normal, True)
    d = fl(p.d, True)
    if normal is p.normal and d == p.d:
        return p
    return Plane(normal, d)


def fl_dot(ax: float, ay: float, az: float, bx: float, by: float, bz: float, single: bool) -> float:
    """Vector3.Dot: (x*x' + y*y') + z*z', each step rounded."""
    return fl(fl(fl(ax * bx, single) + fl(ay * by, single), single) + fl(az * bz, single), single)


def fl_plane_dist(x: float, y: float, z: float, plane: Plane, single: bool) -> float:
    """Vector3.Dot(p, normal) + d, each step rounded."""
    n = plane.normal
    # (written out rather than through fl_dot: one call less on the walkable test's path)
    return fl(fl(fl(fl(x * n.x, single) + fl(y * n.y, single), single) + fl(z * n.z, single), single) + plane.d, single)


def fl_scale(v: Vec3, s: float, single: bool) -> Vec3:
    """v * s."""
    return Vec3(fl(v.x * s, single), fl(v.y * s, single), fl(v.z * s, single))


def fl_add(a: Vec3, b: Vec3, single: bool) -> Vec3:
    """a + b."""
    return Vec3(fl(a.x + b.x, single), fl(a.y + b.y, single), fl(a.z + b.z, single))


def fl_sub(a: Vec3, b: Vec3, single: bool) -> Vec3:
    """a - b."""
    return Vec3(fl(a.x - b.x, single), fl(a.y - b.y, single), fl(a.z - b.z, single))


def fl_cross(a: Vec3, b: Vec3, single: bool) -> Vec3:
    """Vector3.Cross (products rounded, then differences)."""
    return Vec3(
        fl(fl(a.y * b.z, single) - fl(a.z * b.y, single), single),
        fl(fl(a.z * b.x, single) - fl(a.x * b.z, single), single),
        fl(fl(a.x * b.y, single) - fl(a.y * b.x, single), single),
    )


def fl_normalize_check_small(v: Vec3, single: bool) -> Vec3 | None:
    """Vec.NormalizeCheckSmall: None when shorter than EPSILON."""
    length = fl(math.sqrt(fl_dot(v.x, v.y, v.z, v.x, v.y, v.z, single)), single)
    if length < EPSILON:
        return None
    return fl_scale(v, fl(1.0 / length, single), single)


def _rotation(q: Quat, single: bool) -> _Matrix:
    """The matrix (row-major) of System.Numerics' Vector3.Transform(v, q):
    every product and sum of the quaternion's doubled components rounded,
    as that routine evaluates them. Kept on the quaternion, one per precision."""
    m = q.r32 if single else q.r64
    if m is None:
        qw = fl(q.w, single)
        qx = fl(q.x, single)
        qy = fl(q.y, single)
        qz = fl(q.z, single)
        x2 = fl(qx + qx, single)
        y2 = fl(qy + qy, single)
        z2 = fl(qz + qz, single)
        wx2 = fl(qw * x2, single)
        wy2 = fl(qw * y2, single)
        wz2 = fl(qw * z2, single)
        xx2 = fl(qx * x2, single)
        xy2 = fl(qx * y2, single)
        xz2 = fl(qx * z2, single)
        yy2 = fl(qy * y2, single)
        yz2 = fl(qy * z2, single)
        zz2 = fl(qz * z2, single)
        m = (
            fl(fl(1.0 - yy2, single) - zz2, single), fl(xy2 - wz2, single), fl(xz2 + wy2, single),
            fl(xy2 + wz2, single), fl(fl(1.0 - xx2, single) - zz2, single), fl(yz2 - wx2, single),
            fl(xz2 - wy2, single), fl(yz2 + wx2, single), fl(fl(1.0 - xx2, single) - yy2, single),
        )  # fmt: skip
        if single:
            q.r32 = m
        else:
            q.r64 = m
    return m


def _inverse_rotation(q: Quat, single: bool) -> _Matrix:
    """The matrix (row-major) the client's AFrame.GlobalToLocalVec applies:
    the transpose of Matrix4x4.CreateFromQuaternion(q), built as that
    routine builds it. Kept on the quaternion, one per precision."""
    m = q.u32 if single else q.u64
    if m is None:
        qw = fl(q.w, single)
        qx = fl(q.x, single)
        qy = fl(q.y, single)
        qz = fl(q.z, single)
        xx = fl(qx * qx, single)
        yy = fl(qy * qy, single)
        zz = fl(qz * qz, single)
        xy = fl(qx * qy, single)
        wz = fl(qz * qw, single)
        xz = fl(qz * qx, single)
        wy = fl(qy * qw, single)
        yz = fl(qy * qz, single)
        wx = fl(qx * qw, single)
        # CreateFromQuaternion's M11..M33; the transpose's row i is its column i
        m11 = fl(1.0 - fl(2.0 * fl(yy + zz, single), single), single)
        m12 = fl(2.0 * fl(xy + wz, single), single)
        m13 = fl(2.0 * fl(xz - wy, single), single)
        m21 = fl(2.0 * fl(xy - wz, single), single)
        m22 = fl(1.0 - fl(2.0 * fl(zz + xx, single), single), single)
        m23 = fl(2.0 * fl(yz + wx, single), single)
        m31 = fl(2.0 * fl(xz + wy, single), single)
        m32 = fl(2.0 * fl(yz - wx, single), single)
        m33 = fl(1.0 - fl(2.0 * fl(yy + xx, single), single), single)
        m = (m11, m12, m13, m21, m22, m23, m31, m32, m33)
        if single:
            q.u32 = m
        else:
            q.u64 = m
    return m


def _apply(m: _Matrix, v: Vec3, single: bool) -> Vec3:
    """Row-major matrix times `v`, each product and sum rounded in order."""
    x = v.x
    y = v.y
    z = v.z
    return Vec3(
        fl(fl(fl(x * m[0], single) + fl(y * m[1], single), single) + fl(z * m[2], single), single),
        fl(fl(fl(x * m[3], single) + fl(y * m[4], single), single) + fl(z * m[5], single), single),
        fl(fl(fl(x * m[6], single) + fl(y * m[7], single), single) + fl(z * m[8], single), single),
    )


def fl_rotate(q: Quat, v: Vec3, single: bool) -> Vec3:
    """`v` rotated by `q` as System.Numerics' Vector3.Transform(Vector3,
    Quaternion) evaluates it (used by AFrame.Combine and LocalToGlobalVec);
    exact for the identity."""
    if q.x == 0.0 and q.y == 0.0 and q.z == 0.0:
        return v
    return _apply(_rotation(q, single), v, single)


def fl_unrotate(q: Quat, v: Vec3, single: bool) -> Vec3:
    """`v` rotated by the inverse of `q` as the client's
    AFrame.GlobalToLocalVec evaluates it: Vector3.Transform by the transpose
    of Matrix4x4.CreateFromQuaternion(q). Exact for the identity."""
    if q.x == 0.0 and q.y == 0.0 and q.z == 0.0:
        return v
    return _apply(_inverse_rotation(q, single), v, single)


def fl_local_z(q: Quat, single: bool) -> Vec3:
    """fl_unrotate(q, +z): the third column of the inverse matrix's rows."""
    if q.x == 0.0 and q.y == 0.0 and q.z == 0.0:
        return Vec3(0.0, 0.0, 1.0)
    m = _inverse_rotation(q, single)
    return Vec3(m[2], m[5], m[8])


def fl_place(cell_id: int, position: Position, point: Vec3, scale: float, single: bool) -> Vec3:
    """`point` of an object at `position`, times `scale`, in the landblock
    frame of cell `cell_id`, as the client places an obstacle's sphere or
    cylinder (Position.LocalToGlobal(position, point * scale): rotated, added
    to the origin, then the landblock offset)."""
    f = fl(scale, single)
    local = Vec3(fl(fl(point.x, single) * f, single), fl(fl(point.y, single) * f, single), fl(fl(point.z, single) * f, single))
    r = fl_rotate(position.frame.orientation, local, single)
    o = position.frame.origin
    x = fl(o.x + r.x, single)
    y = fl(o.y + r.y, single)
    z = fl(o.z + r.z, single)
    if (cell_id >> 16) != (position.cell_id >> 16):
        block = get_block_offset(cell_id, position.cell_id)
        x = fl(block.x + x, single)
        y = fl(block.y + y, single)
        z = fl(block.z + z, single)
    return Vec3(x, y, z)
