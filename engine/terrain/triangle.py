"""A terrain triangle: one half of a 24 m cell, with its plane."""

from __future__ import annotations

from ..geometry import Plane, Vec3

__all__ = ["TerrainTriangle"]


class TerrainTriangle:
    """Three landblock-local vertices, counter-clockwise seen from above.

    The plane is computed in single precision as the client's
    LandblockStruct builds it (`Plane.from_points_f32`).
    """

    __slots__ = ("vertices", "plane")

    def __init__(self, v0: Vec3, v1: Vec3, v2: Vec3) -> None:
        self.vertices = (v0, v1, v2)
        self.plane = Plane.from_points_f32([v0, v1, v2])

    def point_in_poly_2d(self, p: Vec3) -> bool:
        """Is p inside (or on the edge of) the triangle seen from above?

        Polygon.point_in_poly2D with Sidedness.Positive: every edge, walked
        from the last vertex back to the first, must have p on its left.
        """
        verts = self.vertices
        px, py = p.x, p.y
        prev = verts[0]
        for i in (2, 1, 0):
            v = verts[i]
            dx = v.x - prev.x
            dy = v.y - prev.y
            if dy * v.x - dx * v.y + dx * py - dy * px > 0.0:
                return False
            prev = v
        return True

    def height_at(self, x: float, y: float) -> float:
        h = self.plane.height_at(x, y)
        assert h is not None  # terrain triangles are never vertical
        return h
