"""A collision sphere (center, radius): the shape movers are made of."""

from __future__ import annotations

from .vec3 import Vec3
from .._compat import mypyc_attr

__all__ = ["Sphere"]


@mypyc_attr(acyclic=True)
class Sphere:
    """Mutable on purpose: the path moves its cached global spheres in place."""

    __slots__ = ("center", "radius")

    center: Vec3
    radius: float

    def __init__(self, center: Vec3, radius: float) -> None:
        self.center = center
        self.radius = radius

    def __repr__(self) -> str:
        return f"Sphere({self.center!r}, {self.radius!r})"

    def copy(self) -> Sphere:
        return Sphere(self.center, self.radius)

    def intersects(self, other: Sphere) -> bool:
        """Overlap test of two spheres (Sphere.Intersects)."""
        d = self.center - other.center
        r = self.radius + other.radius
        return d.length_sq() < r * r
