"""Three-component vector: the value type every physics routine passes around.

`Vec3` is immutable and slotted: cheap to create, safe to share between the
path, the collision info and the caller. Bulk data (height grids) lives in
numpy arrays instead; a numpy array per 3-vector would cost far more on the
per-move path than it saves.
"""

from __future__ import annotations

import math
from typing import Final

from ..constants import EPSILON
from .._compat import mypyc_attr

__all__ = ["Vec3", "ZERO", "UNIT_Z"]


@mypyc_attr(acyclic=True, free_list_len=1)
class Vec3:
    """A 3-vector of float components (x east, y north, z up)."""

    __slots__ = ("x", "y", "z")

    x: float
    y: float
    z: float

    def __init__(self, x: float = 0.0, y: float = 0.0, z: float = 0.0) -> None:
        self.x = x
        self.y = y
        self.z = z

    # -- arithmetic -----------------------------------------------------
    def __add__(self, o: Vec3) -> Vec3:
        return Vec3(self.x + o.x, self.y + o.y, self.z + o.z)

    def __sub__(self, o: Vec3) -> Vec3:
        return Vec3(self.x - o.x, self.y - o.y, self.z - o.z)

    def __mul__(self, s: float) -> Vec3:
        return Vec3(self.x * s, self.y * s, self.z * s)

    def __rmul__(self, s: float) -> Vec3:
        return Vec3(self.x * s, self.y * s, self.z * s)

    def __neg__(self) -> Vec3:
        return Vec3(-self.x, -self.y, -self.z)

    def __eq__(self, o: object) -> bool:
        return isinstance(o, Vec3) and self.x == o.x and self.y == o.y and self.z == o.z

    def __hash__(self) -> int:
        return hash((self.x, self.y, self.z))

    def __iter__(self):  # type: ignore[no-untyped-def]
        yield self.x
        yield self.y
        yield self.z

    def __repr__(self) -> str:
        return f"Vec3({self.x!r}, {self.y!r}, {self.z!r})"

    # -- products and norms ----------------------------------------------
    def dot(self, o: Vec3) -> float:
        return self.x * o.x + self.y * o.y + self.z * o.z

    def dot2d(self, o: Vec3) -> float:
        return self.x * o.x + self.y * o.y

    def cross(self, o: Vec3) -> Vec3:
        return Vec3(
            self.y * o.z - self.z * o.y,
            self.z * o.x - self.x * o.z,
            self.x * o.y - self.y * o.x,
        )

    def length(self) -> float:
        return math.sqrt(self.x * self.x + self.y * self.y + self.z * self.z)

    def length_sq(self) -> float:
        return self.x * self.x + self.y * self.y + self.z * self.z

    def length2d(self) -> float:
        return math.sqrt(self.x * self.x + self.y * self.y)

    def normalized_or_none(self) -> Vec3 | None:
        """Unit vector along self, or None when shorter than EPSILON.

        The client's `Vec::normalize_check_small`: it reports "too small"
        instead of dividing by (nearly) zero.
        """
        dist = math.sqrt(self.x * self.x + self.y * self.y + self.z * self.z)
        if dist < EPSILON:
            return None
        inv = 1.0 / dist
        return Vec3(self.x * inv, self.y * inv, self.z * inv)

    def is_zero(self) -> bool:
        """True when every component is within EPSILON of zero (`Vec::is_zero`)."""
        return abs(self.x) < EPSILON and abs(self.y) < EPSILON and abs(self.z) < EPSILON

    def is_finite(self) -> bool:
        # x - x is 0 exactly for a finite x, NaN for an infinity or a NaN (compiled, math.isfinite
        # would be a call by name; this stays in registers)
        return self.x - self.x == 0.0 and self.y - self.y == 0.0 and self.z - self.z == 0.0

    def with_z(self, z: float) -> Vec3:
        return Vec3(self.x, self.y, z)

    def as_tuple(self) -> tuple[float, float, float]:
        return (self.x, self.y, self.z)


ZERO: Final = Vec3(0.0, 0.0, 0.0)
UNIT_Z: Final = Vec3(0.0, 0.0, 1.0)
