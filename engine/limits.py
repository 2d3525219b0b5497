"""The limits every number a caller gives the engine must respect (docs/protocol.md, "Limits").

The client computes in single precision and nothing in it is larger than a
landblock; a number outside these limits would overflow a float32, or make a
transition run away (a sphere bigger than the world, a target a million
landblocks off). The World checks its inputs here before it changes anything,
and refuses them with OutOfRangeError (or NonFiniteError), naming the field.
"""

from __future__ import annotations

import math
from typing import Final

from .constants import BLOCK_LENGTH, EPSILON
from .errors import NonFiniteError, OutOfRangeError
from .geometry import Plane, Position, Quat, Vec3
from .world.types import MoverSpec

__all__ = [
    "FLOAT32_MAX",
    "MAX_OBJECT_SIZE",
    "MIN_SPHERE_RADIUS",
    "MAX_RAY_RADIUS",
    "MAX_PATH_BUDGET",
    "MAX_PATH_DISTANCE",
    "MAX_WANDER_RADIUS",
    "MIN_SCALE",
    "MAX_SCALE",
    "TARGET_MARGIN",
    "MAX_HEIGHT",
    "MAX_SPEED",
    "MAX_MOTION",
    "MAX_DT",
    "MAX_PLANE_D",
    "UNIT_TOLERANCE",
    "check_number",
    "check_vector",
    "check_unit_vector",
    "check_sliding_normal",
    "check_orientation",
    "check_target_origin",
    "check_start",
    "start_slack",
    "check_plane",
    "check_velocity",
    "check_motion",
    "check_dt",
    "check_sphere",
    "check_scale",
    "check_step_height",
    "check_mover_spec",
]

#: the largest finite float32: the client's numbers cannot be larger
FLOAT32_MAX: Final = 3.4028234663852886e38
#: nothing in the client is larger than a landblock: sphere radii and centre
#: offsets (scaled), step heights, cylsphere sizes (metres)
MAX_OBJECT_SIZE: Final = BLOCK_LENGTH
#: the smallest scaled sphere radius, a mover's or a swept ray's: five times the
#: transition's distance tolerance (EPSILON, 0.2 mm). A transition takes sub-steps
#: of at most one radius and gives up on one shorter than EPSILON, so a sphere near
#: that size is lost in it: at 0.2 mm every move is Invalid and a ray stops at its
#: start, blocked by nothing; up to 0.5 mm a move ends after its first sub-step and
#: is answered as done, and two such spheres pass through each other; one that
#: single precision rounds to 0 divides by zero when the steps are counted
MIN_SPHERE_RADIUS: Final = 5 * EPSILON
#: a swept sphere's radius (ray and sight queries), at most: a mover's largest sphere is far smaller
MAX_RAY_RADIUS: Final = 10.0
#: the largest node budget a path query may ask for (engine.navigation)
MAX_PATH_BUDGET: Final = 5_000_000
#: the longest path a path query may ask for, metres (the width of the world)
MAX_PATH_DISTANCE: Final = 256 * 192.0
#: the widest circle a random-point query may ask for a point in, metres
MAX_WANDER_RADIUS: Final = 1000.0
MIN_SCALE: Final = 1e-3
MAX_SCALE: Final = BLOCK_LENGTH
#: how far past its landblock's edges a target origin may lie (x and y, in
#: that landblock's frame): one landblock, so a move may cross into a neighbour
TARGET_MARGIN: Final = BLOCK_LENGTH
#: the largest |z| of an origin (metres); the world's terrain is 0..~2000 m
MAX_HEIGHT: Final = 10000.0
#: the largest speed of a move's velocity (m/s). The client clamps every
#: object's own velocity to 50 m/s (PhysicsObj.set_velocity); a move's given
#: velocity may exceed that (the reference traces reach 50.3), up to this
MAX_SPEED: Final = 1000.0
#: the longest physics step the engine takes (seconds); the service allows only HUGE_QUANTUM (2 s),
#: the longest frame the client resolves. Longer ones would square into numbers beyond float32
MAX_DT: Final = 60.0
#: the largest component of a physics step's own motion (metres per step)
MAX_MOTION: Final = 2.0 * BLOCK_LENGTH
#: the largest |d| of a contact plane (metres): a plane through a point of the
#: addressed landblock or its neighbours, at any allowed height
MAX_PLANE_D: Final = 4.0 * BLOCK_LENGTH + MAX_HEIGHT
#: how far from 1 the length of a unit vector or quaternion may be
UNIT_TOLERANCE: Final = 1e-3


def check_number(value: float, field: str) -> float:
    """`value` if it is finite and fits a float32."""
    if not math.isfinite(value):
        raise NonFiniteError(f"{field}: {value!r} is not a finite number", field)
    if abs(value) > FLOAT32_MAX:
        raise OutOfRangeError(f"{field}: {value!r} does not fit single precision (|x| <= {FLOAT32_MAX:.8g})", field)
    return value


def check_vector(v: Vec3, field: str) -> Vec3:
    check_number(v.x, f"{field}[0]")
    check_number(v.y, f"{field}[1]")
    check_number(v.z, f"{field}[2]")
    return v


def check_unit_vector(v: Vec3, field: str) -> Vec3:
    check_vector(v, field)
    n = math.sqrt(v.x * v.x + v.y * v.y + v.z * v.z)
    if abs(n - 1.0) > UNIT_TOLERANCE:
        raise OutOfRangeError(f"{field}: length {n:.6g} is not 1 (within {UNIT_TOLERANCE})", field)
    return v


def check_sliding_normal(v: Vec3, field: str) -> Vec3:
    """A mover's sliding normal: a unit vector, or exactly zero.

    CollisionInfo::SetSlidingNormal keeps only the horizontal part of the
    normal it is given, and zero when that part is too small to normalise
    (a vertical normal: a mover settling on level ground), still marked
    valid. Such a mover is Sliding with a zero normal, and must start that
    way again when it is handed over or read back from a state file."""
    check_vector(v, field)
    if v.x == 0.0 and v.y == 0.0 and v.z == 0.0:
        return v
    return check_unit_vector(v, field)


def check_orientation(q: Quat, field: str) -> Quat:
    for i, c in enumerate((q.w, q.x, q.y, q.z)):
        check_number(c, f"{field}[{i}]")
    n = q.length()
    if abs(n - 1.0) > UNIT_TOLERANCE:
        raise OutOfRangeError(f"{field}: quaternion length {n:.6g} is not 1 (within {UNIT_TOLERANCE})", field)
    return q


def _check_in(value: float, low: float, high: float, field: str, what: str) -> None:
    check_number(value, field)
    if not low <= value <= high:
        raise OutOfRangeError(f"{field}: {value!r} is outside {what} ({low:g} .. {high:g})", field)


def check_target_origin(origin: Vec3, field: str) -> None:
    """A target origin: within the addressed landblock's frame, give or take TARGET_MARGIN."""
    what = "the addressed landblock and its neighbours"
    _check_in(origin.x, -TARGET_MARGIN, BLOCK_LENGTH + TARGET_MARGIN, f"{field}[0]", what)
    _check_in(origin.y, -TARGET_MARGIN, BLOCK_LENGTH + TARGET_MARGIN, f"{field}[1]", what)
    _check_in(origin.z, -MAX_HEIGHT, MAX_HEIGHT, f"{field}[2]", "the heights allowed")


#: the squared lengths a unit quaternion's may have (length within UNIT_TOLERANCE of 1)
_UNIT_SQ_LOW: Final = (1.0 - UNIT_TOLERANCE) ** 2
_UNIT_SQ_HIGH: Final = (1.0 + UNIT_TOLERANCE) ** 2
_XY_LOW: Final = -TARGET_MARGIN
_XY_HIGH: Final = BLOCK_LENGTH + TARGET_MARGIN


def check_position(position: Position, field: str) -> None:
    """A target position: orientation a unit quaternion, origin as check_target_origin.

    Every move passes here: the common case is a few comparisons (a NaN fails
    them all), and only a refusal takes the per-field checks that say why."""
    frame = position.frame
    o = frame.origin
    q = frame.orientation
    n2 = q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z
    if (_XY_LOW <= o.x <= _XY_HIGH and _XY_LOW <= o.y <= _XY_HIGH and -MAX_HEIGHT <= o.z <= MAX_HEIGHT
            and _UNIT_SQ_LOW <= n2 <= _UNIT_SQ_HIGH):
        return
    check_orientation(q, f"{field}.orientation")
    check_target_origin(o, f"{field}.origin")


def check_start(position: Position, field: str, slack: float = 0.0) -> None:
    """A start position: as a target, and an outdoor cell's origin inside that cell's
    landblock (0..192 m in x and y, give or take `slack`: the transition files a
    mover under the cell of its first sphere's centre, which may lie that far from
    its origin). An indoor cell's origin may lie anywhere a target's may."""
    check_position(position, field)
    if 1 <= position.cell_id & 0xFFFF <= 64:
        o = position.frame.origin
        low = -slack
        high = BLOCK_LENGTH + slack
        what = f"the landblock of outdoor cell {position.cell_id:08X}"
        _check_in(o.x, low, high, f"{field}.origin[0]", what)
        _check_in(o.y, low, high, f"{field}.origin[1]", what)


def start_slack(spec: MoverSpec) -> float:
    """How far a mover's origin may lie outside the landblock of the cell its spheres are in:
    its spheres' horizontal centre offsets (scaled), and a centimetre of rounding."""
    far = 0.0
    for s in spec.spheres:
        far = max(far, math.hypot(s.center[0], s.center[1]) * spec.scale)
    return far + 0.01


def check_plane(plane: Plane, field: str) -> None:
    check_unit_vector(plane.normal, f"{field}.normal")
    _check_in(plane.d, -MAX_PLANE_D, MAX_PLANE_D, f"{field}.d", "the planes of a landblock and its neighbours")


def check_velocity(v: Vec3, field: str) -> None:
    check_vector(v, field)
    speed = math.sqrt(v.x * v.x + v.y * v.y + v.z * v.z)
    if speed > MAX_SPEED:
        raise OutOfRangeError(f"{field}: speed {speed:.6g} m/s is over {MAX_SPEED:g} m/s", field)


def check_motion(v: Vec3, field: str) -> None:
    m = MAX_MOTION
    if -m <= v.x <= m and -m <= v.y <= m and -m <= v.z <= m:  # every physics step: a NaN fails these
        return
    for i, c in enumerate((v.x, v.y, v.z)):
        _check_in(c, -MAX_MOTION, MAX_MOTION, f"{field}[{i}]", "a physics step's motion")


def check_dt(dt: float, field: str) -> None:
    """A physics step's duration: 0 .. MAX_DT seconds (the service allows at most HUGE_QUANTUM)."""
    if not 0.0 <= dt <= MAX_DT:
        _check_in(dt, 0.0, MAX_DT, field, "the step durations allowed")


def check_scale(scale: float, field: str) -> None:
    _check_in(scale, MIN_SCALE, MAX_SCALE, field, "the scales allowed")


def check_sphere(center: tuple[float, ...], radius: float, scale: float, field: str, center_name: str = "center") -> None:
    """A sphere (or cylsphere) of the mover: scaled radius and centre offsets within the object sizes."""
    if len(center) != 3:
        raise OutOfRangeError(f"{field}: a centre has 3 coordinates, got {len(center)}", field)
    for i, c in enumerate(center):
        check_number(c, f"{field}.{center_name}[{i}]")
        _check_in(c * scale, -MAX_OBJECT_SIZE, MAX_OBJECT_SIZE, f"{field}.{center_name}[{i}]", "an object's size (scaled)")
    check_number(radius, f"{field}.radius")
    _check_in(radius * scale, MIN_SPHERE_RADIUS, MAX_OBJECT_SIZE, f"{field}.radius", "the sphere radii allowed (scaled)")


def check_step_height(value: float, field: str) -> None:
    _check_in(value, 0.0, MAX_OBJECT_SIZE, field, "the step heights allowed")


def check_mover_spec(spec: MoverSpec, field: str) -> None:
    """Every number of a MoverSpec: scale, spheres and cylspheres (scaled), step heights."""
    check_scale(spec.scale, f"{field}.scale")
    if not spec.spheres:
        raise OutOfRangeError(f"{field}.spheres: at least one sphere is needed", f"{field}.spheres")
    for i, s in enumerate(spec.spheres):
        check_sphere(s.center, s.radius, spec.scale, f"{field}.spheres[{i}]")
    for i, c in enumerate(spec.cyl_spheres):
        p = f"{field}.cyl_spheres[{i}]"
        check_sphere(c.origin, c.radius, spec.scale, p, "origin")
        _check_in(c.height * spec.scale, 0.0, MAX_OBJECT_SIZE, f"{p}.height", "an object's size (scaled)")
    check_step_height(spec.step_up_height, f"{field}.step_up_height")
    check_step_height(spec.step_down_height, f"{field}.step_down_height")
