"""A terrain triangle: one half of a 24 m cell, with its plane."""

from __future__ import annotations

from ..geometry import Plane, Vec3

__all__ = ["TerrainTriangle"]


class TerrainTriangle:
    """Three landblock-local vertices, counter-clockwise seen from above.

    `plane` is computed in single precision as the client's LandblockStruct
    builds it (`Plane.from_points`); `plane_at(False)` is the same plane in
    double precision, computed when first asked for.
    """

    __slots__ = ("vertices", "plane", "_plane_double", "c0", "dx0", "dy0", "c1", "dx1", "dy1", "c2", "dx2", "dy2")

    def __init__(self, v0: Vec3, v1: Vec3, v2: Vec3) -> None:
        self.vertices = (v0, v1, v2)
        self.plane = Plane.from_points([v0, v1, v2], True)
        self._plane_double: Plane | None = None
        # The edges in the order point_in_poly_2d walks them (from the last
        # vertex back to the first), each as (c, dx, dy) with p on its left
        # when c + dx * p.y - dy * p.x <= 0. c is the part of that sum the
        # client's expression evaluates first, so the test rounds as before.
        self.dx0 = v2.x - v0.x
        self.dy0 = v2.y - v0.y
        self.c0 = self.dy0 * v2.x - self.dx0 * v2.y
        self.dx1 = v1.x - v2.x
        self.dy1 = v1.y - v2.y
        self.c1 = self.dy1 * v1.x - self.dx1 * v1.y
        self.dx2 = v0.x - v1.x
        self.dy2 = v0.y - v1.y
        self.c2 = self.dy2 * v0.x - self.dx2 * v0.y

    def point_in_poly_2d(self, p: Vec3) -> bool:
        """Is p inside (or on the edge of) the triangle seen from above?

        Polygon.point_in_poly2D with Sidedness.Positive: every edge, walked
        from the last vertex back to the first, must have p on its left.
        """
        px = p.x
        py = p.y
        if self.c0 + self.dx0 * py - self.dy0 * px > 0.0:
            return False
        if self.c1 + self.dx1 * py - self.dy1 * px > 0.0:
            return False
        return not self.c2 + self.dx2 * py - self.dy2 * px > 0.0

    def plane_at(self, single: bool) -> Plane:
        """The triangle's plane at the working precision (`single`: the
        client's float32 plane, else the double-precision plane of the same
        float32 vertices)."""
        if single:
            return self.plane
        p = self._plane_double
        if p is None:
            p = self._plane_double = Plane.from_points(list(self.vertices), False)
        return p

    def height_at(self, x: float, y: float) -> float:
        h = self.plane.height_at(x, y)
        assert h is not None  # terrain triangles are never vertical
        return h
