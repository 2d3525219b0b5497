"""Planes `dot(normal, p) + d = 0` and the client's plane helpers."""

from __future__ import annotations

import math
from typing import Final

from ..constants import EPSILON
from .single import to_single as _f32
from .vec3 import Vec3

__all__ = ["Plane", "Side"]


class Side:
    """Which side of a plane a point lies on (the client's `Sidedness`)."""

    FRONT: Final = 0
    BEHIND: Final = 1
    CLOSE: Final = 2  # within EPSILON: on the plane
    CROSSING: Final = 3


class Plane:
    __slots__ = ("normal", "d")

    normal: Vec3
    d: float

    def __init__(self, normal: Vec3, d: float) -> None:
        self.normal = normal
        self.d = d

    def __repr__(self) -> str:
        return f"Plane({self.normal!r}, {self.d!r})"

    def __eq__(self, o: object) -> bool:
        return isinstance(o, Plane) and self.normal == o.normal and self.d == o.d

    def __hash__(self) -> int:
        return hash((self.normal, self.d))

    def distance(self, p: Vec3) -> float:
        """Signed distance of `p` (positive on the normal's side)."""
        n = self.normal
        return n.x * p.x + n.y * p.y + n.z * p.z + self.d

    def side(self, p: Vec3, bias: float = 0.0) -> int:
        dist = self.distance(p) + bias
        if dist > EPSILON:
            return Side.FRONT
        if dist < -EPSILON:
            return Side.BEHIND
        return Side.CLOSE

    def snap_to_plane(self, offset: Vec3) -> Vec3:
        """Replace offset.z so the offset runs along the plane (Plane.SnapToPlane).

        The client measures the xy part from the plane's own height at the
        origin, which cancels d: z = -dot2d(offset, n) / n.z.
        """
        nz = self.normal.z
        if abs(nz) <= EPSILON:
            return offset
        # In single precision, as the client computes it: the two large terms
        # (d / nz is the plane's height at the origin, ~100 m) cancel with a
        # rounding error of up to ~1e-5 m, and that error is part of the
        # client's behaviour (it decides when a step leaves the EPSILON band).
        n = self.normal
        d = _f32(self.d)
        dot2d = _f32(_f32(offset.x * _f32(n.x)) + _f32(offset.y * _f32(n.y)))
        inv = _f32(1.0 / _f32(nz))
        z = _f32(_f32(-_f32(dot2d + d) * inv) - _f32(inv * -d))
        return Vec3(offset.x, offset.y, z)

    def snap_to_plane_double(self, offset: Vec3) -> Vec3:
        """SnapToPlane in double precision, where d cancels: z = -dot2d(offset, n) / n.z."""
        n = self.normal
        if abs(n.z) <= EPSILON:
            return offset
        return Vec3(offset.x, offset.y, -(offset.x * n.x + offset.y * n.y) / n.z)

    def height_at(self, x: float, y: float) -> float | None:
        """z of the plane above (x, y), or None for a (near-)vertical plane."""
        n = self.normal
        if abs(n.z) <= EPSILON:
            return None
        return -((y * n.y + x * n.x + self.d) / n.z)

    @staticmethod
    def from_points_f32(vertices: list[Vec3]) -> Plane:
        """Polygon.make_plane in single precision, as the client computes it.

        Every difference, product and sum of the fan's cross products, the
        length's square root, the normal's three divisions by it, and the
        mean of dot(n, v) are rounded to float32 in the client's order. The
        result differs from `from_points` in the last bits of the normal and
        by up to ~1e-5 m in d: enough to move a resting sphere across the
        EPSILON band of the terrain contact test. The reference's terrain
        contact planes are exactly these values.
        """
        f = _f32
        v0 = vertices[0]
        x0, y0, z0 = f(v0.x), f(v0.y), f(v0.z)
        nx = ny = nz = 0.0
        for i in range(1, len(vertices) - 1):
            a = vertices[i]
            b = vertices[i + 1]
            ax, ay, az = f(f(a.x) - x0), f(f(a.y) - y0), f(f(a.z) - z0)
            bx, by, bz = f(f(b.x) - x0), f(f(b.y) - y0), f(f(b.z) - z0)
            nx = f(nx + f(f(ay * bz) - f(az * by)))
            ny = f(ny + f(f(az * bx) - f(ax * bz)))
            nz = f(nz + f(f(ax * by) - f(ay * bx)))
        length = f(math.sqrt(f(f(f(nx * nx) + f(ny * ny)) + f(nz * nz))))
        if length == 0.0:
            return Plane(Vec3(0.0, 0.0, 0.0), 0.0)
        nx, ny, nz = f(nx / length), f(ny / length), f(nz / length)
        total = 0.0
        for v in vertices:
            total = f(total + f(f(f(nx * f(v.x)) + f(ny * f(v.y))) + f(nz * f(v.z))))
        return Plane(Vec3(nx, ny, nz), f(-f(total / len(vertices))))

    @staticmethod
    def from_points(vertices: list[Vec3]) -> Plane:
        """The client's Polygon.make_plane: fan-summed normal, mean-vertex d."""
        v0 = vertices[0]
        nx = ny = nz = 0.0
        for i in range(1, len(vertices) - 1):
            a = vertices[i] - v0
            b = vertices[i + 1] - v0
            c = a.cross(b)
            nx += c.x
            ny += c.y
            nz += c.z
        normal = Vec3(nx, ny, nz).normalized_or_none() or Vec3(0.0, 0.0, 0.0)
        total = 0.0
        for v in vertices:
            total += normal.dot(v)
        return Plane(normal, -(total / len(vertices)))
