"""Vectors, quaternions, frames, planes, spheres, positions and LandDefs."""

from .frame import Frame
from .plane import Plane, Side
from .position import Position
from .quaternion import IDENTITY, Quat
from .single import to_single
from .sphere import Sphere
from .vec3 import UNIT_Z, ZERO, Vec3

__all__ = ["Frame", "Plane", "Side", "Position", "IDENTITY", "Quat", "Sphere", "UNIT_Z", "ZERO", "Vec3", "to_single"]
