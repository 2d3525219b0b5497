"""Planes `dot(normal, p) + d = 0` and the client's plane helpers."""

from __future__ import annotations

import math
from typing import Final

from ..constants import EPSILON
from .single import fl
from .vec3 import Vec3
from .._compat import mypyc_attr

__all__ = ["Plane", "Side"]


class Side:
    """Which side of a plane a point lies on (the client's `Sidedness`)."""

    FRONT: Final = 0
    BEHIND: Final = 1
    CLOSE: Final = 2  # within EPSILON: on the plane
    CROSSING: Final = 3


@mypyc_attr(acyclic=True)
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

    def snap_to_plane(self, offset: Vec3, single: bool) -> Vec3:
        """Replace offset.z so the offset runs along the plane (Plane.SnapToPlane).

        The client measures the xy part from the plane's own height at the
        origin: z = -(dot2d(offset, n) + d) / n.z + d / n.z. In single
        precision (`single`) the two large terms (d / nz is the plane's
        height at the origin, ~100 m) cancel with a rounding error of up to
        ~1e-5 m, and that error is part of the client's behaviour (it
        decides when a step leaves the EPSILON band); in double precision
        they cancel to within 1e-14 m.
        """
        nz = self.normal.z
        if abs(nz) <= EPSILON:
            return offset
        n = self.normal
        d = fl(self.d, single)
        dot2d = fl(fl(offset.x * fl(n.x, single), single) + fl(offset.y * fl(n.y, single), single), single)
        inv = fl(1.0 / fl(nz, single), single)
        z = fl(fl(-fl(dot2d + d, single) * inv, single) - fl(inv * -d, single), single)
        return Vec3(offset.x, offset.y, z)

    def height_at(self, x: float, y: float) -> float | None:
        """z of the plane above (x, y), or None for a (near-)vertical plane."""
        n = self.normal
        if abs(n.z) <= EPSILON:
            return None
        return -((y * n.y + x * n.x + self.d) / n.z)

    @staticmethod
    def from_points(vertices: list[Vec3], single: bool) -> Plane:
        """The client's Polygon.make_plane: fan-summed normal, mean-vertex d.

        With `single`, as the client computes it: every difference, product
        and sum of the fan's cross products, the length's square root, the
        normal's three divisions by it, and the mean of dot(n, v) are
        rounded to float32 in the client's order. That plane differs from
        the double-precision one in the last bits of the normal and by up to
        ~1e-5 m in d: enough to move a resting sphere across the EPSILON
        band of the terrain contact test. The reference's terrain contact
        planes are exactly the single-precision values.
        """
        s = single
        v0 = vertices[0]
        x0, y0, z0 = fl(v0.x, s), fl(v0.y, s), fl(v0.z, s)
        nx = ny = nz = 0.0
        for i in range(1, len(vertices) - 1):
            a = vertices[i]
            b = vertices[i + 1]
            ax, ay, az = fl(fl(a.x, s) - x0, s), fl(fl(a.y, s) - y0, s), fl(fl(a.z, s) - z0, s)
            bx, by, bz = fl(fl(b.x, s) - x0, s), fl(fl(b.y, s) - y0, s), fl(fl(b.z, s) - z0, s)
            nx = fl(nx + fl(fl(ay * bz, s) - fl(az * by, s), s), s)
            ny = fl(ny + fl(fl(az * bx, s) - fl(ax * bz, s), s), s)
            nz = fl(nz + fl(fl(ax * by, s) - fl(ay * bx, s), s), s)
        length = fl(math.sqrt(fl(fl(fl(nx * nx, s) + fl(ny * ny, s), s) + fl(nz * nz, s), s)), s)
        if length == 0.0:
            return Plane(Vec3(0.0, 0.0, 0.0), 0.0)
        nx, ny, nz = fl(nx / length, s), fl(ny / length, s), fl(nz / length, s)
        total = 0.0
        for v in vertices:
            total = fl(total + fl(fl(fl(nx * fl(v.x, s), s) + fl(ny * fl(v.y, s), s), s) + fl(nz * fl(v.z, s), s), s), s)
        return Plane(Vec3(nx, ny, nz), fl(-fl(total / len(vertices), s), s))
