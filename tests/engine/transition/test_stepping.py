"""engine/transition/stepping.py: StepDown, StepUp, CheckWalkable and CliffSlide, called directly.

Each test builds one Transition at a check position chosen by hand and calls one routine of the
module (not a whole move), then checks its answer and where it left the check position:

- StepDown probes down by a height for ground whose normal z is at least a walkable z. On terrain
  (engine/transition/walkable.py's rule, ObjectInfo.ValidateWalkable) a sphere rests when its low
  point, the mover's origin, is on the plane (not its nearest point: on a slope it sinks in), and
  is lifted straight up onto it when below. Slopes: 45 degrees (n.z = 0.7071, walkable: FloorZ is
  0.6642, cos 48.4 degrees) and a rise of 30 m over a 24 m cell (51.3 degrees, n.z = 24 / sqrt(24^2
  + 30^2) = 0.6247: not walkable, but above LandingZ 0.0872).
- StepUp probes down by the step-up height from where the foot sphere met a step, and the BSP's
  walk interpolation accepts a landing up to half a probe above its start (CPolygon's
  adjust_sphere_to_plane, down to -0.5): a step of height h is climbed when h <= 1.5 * step-up
  height. Off walkable ground the probe is STEP_DOWN_PROBE (4 cm), which no 25 cm step passes.
"""

from __future__ import annotations

import math

import pytest

import engine
from benchmarks.scenes import world_from_heights
from engine.constants import FLOOR_Z, LANDING_Z
from engine.geometry import Frame, Plane, Position, Sphere, Vec3
from engine.transition import stepping
from engine.transition.object_info import ObjectInfo
from engine.transition.state import OI, TransitionState as TS
from engine.transition.transition import Transition
from support.indoor_scenes import GROUND, SceneBuilder, box_solid, room_struct

UP = Vec3(0.0, 0.0, 1.0)
R = 0.5  # the foot sphere's radius on terrain
GROUNDED = OI.CONTACT | OI.ON_WALKABLE

# -- terrain: flat ground and two ramps rising east --------------------------------------------------
# Height byte b is b * 0.5 m. The ramps rise between landblock vertices 2 and 5 (x = 48 .. 120 m), the
# same rise per vertex whichever way a cell's triangles are split: one plane z = k (x - 48) there.
RAMP_CELL = 0xA9B40000 | (3 * 8 + 3 + 1)  # outdoor cell (3, 3): x, y in [72, 96), inside the ramp
AT_X, AT_Y = 84.0, 84.0


def _ramp(bytes_per_vertex: int) -> engine.World:
    return world_from_heights(lambda bx, by, x, y: bytes_per_vertex * min(max(x - 2, 0), 3))


FLAT = world_from_heights(lambda bx, by, x, y: 100)  # 50 m up everywhere
SLOPE_45 = _ramp(48)  # 24 m per 24 m cell: z = x - 48
SLOPE_51 = _ramp(60)  # 30 m per 24 m cell: z = 1.25 (x - 48)
N_Z_45 = math.sqrt(0.5)
N_Z_51 = 24.0 / math.hypot(24.0, 30.0)


def _ground_z(world: engine.World, x: float) -> float:
    return {id(FLAT): 50.0, id(SLOPE_45): x - 48.0, id(SLOPE_51): 1.25 * (x - 48.0)}[id(world)]


def _rest_z(world: engine.World) -> float:
    """The origin of a foot sphere resting on the terrain at (AT_X, AT_Y): its low point on the ground."""
    return _ground_z(world, AT_X)


def _transition(world: engine.World, cell_id: int, origin: Vec3, state: int = GROUNDED, *, radius: float = R,
                head: bool = False, step_up: float = 0.4, step_down: float = 0.4) -> Transition:
    """A transition whose check position is `origin`, in cell `cell_id` of `world`."""
    t = Transition(world.landscape)
    oi = ObjectInfo(state)
    oi.step_up_height, oi.step_down_height = step_up, step_down
    t.init_object(oi)
    spheres = [Sphere(Vec3(0.0, 0.0, radius), radius)]
    if head:
        spheres.append(Sphere(Vec3(0.0, 0.0, radius + 0.87), radius))
    t.init_sphere(spheres, 1.0)
    pos = Position(cell_id, Frame(origin))
    cell = world.get_landcell(cell_id)
    t.init_path(cell, pos, pos)
    t.sphere_path.set_check_pos(pos, cell)
    return t


def _origin(t: Transition) -> Vec3:
    return t.sphere_path.check_pos.frame.origin


# -- StepDown ----------------------------------------------------------------------------------------


def test_step_down_finds_flat_ground_within_its_height() -> None:
    """Transition.StepDown: feet 0.3 m up, a 0.4 m probe: lands on the ground, contact plane flat."""
    t = _transition(FLAT, RAMP_CELL, Vec3(AT_X, AT_Y, 50.3))
    assert stepping.step_down(t, 0.4, FLOOR_Z)
    assert _origin(t).z == pytest.approx(50.0, abs=1e-5)
    assert (_origin(t).x, _origin(t).y) == (AT_X, AT_Y)  # straight down
    ci = t.collision_info
    assert ci.contact_plane_valid and ci.contact_plane.normal == UP
    assert ci.contact_plane_cell_id == RAMP_CELL
    assert not t.sphere_path.step_down  # the flag is only up during the probe


def test_step_down_misses_ground_below_its_height() -> None:
    """Transition.StepDown: feet 0.5 m up, a 0.4 m probe ends 0.1 m short: no ground."""
    t = _transition(FLAT, RAMP_CELL, Vec3(AT_X, AT_Y, 50.5))
    assert not stepping.step_down(t, 0.4, FLOOR_Z)
    assert not t.collision_info.contact_plane_valid


def test_step_down_lands_on_a_45_degree_slope_at_floor_z() -> None:
    """Transition.StepDown on a walkable 45 degree ramp (z = x - 48): feet 0.2 m above the ground at
    x = 84, a 0.4 m probe: they land on it, at z = 36."""
    assert N_Z_45 > FLOOR_Z
    rest = _rest_z(SLOPE_45)
    assert rest == 36.0
    t = _transition(SLOPE_45, RAMP_CELL, Vec3(AT_X, AT_Y, rest + 0.2))
    assert stepping.step_down(t, 0.4, FLOOR_Z)
    assert _origin(t).z == pytest.approx(rest, abs=1e-4)
    assert t.collision_info.contact_plane.normal.z == pytest.approx(N_Z_45, abs=1e-6)


@pytest.mark.parametrize(("z_val", "lands"), [(FLOOR_Z, False), (LANDING_Z, True)], ids=["floor-z", "landing-z"])
def test_step_down_refuses_a_51_degree_slope_at_floor_z_but_not_at_landing_z(z_val: float, lands: bool) -> None:
    """Transition.StepDown: the ground is found either way; the step is accepted only when its
    normal z (0.6247) is at least the walkable z asked for."""
    assert LANDING_Z < N_Z_51 < FLOOR_Z
    rest = _rest_z(SLOPE_51)
    t = _transition(SLOPE_51, RAMP_CELL, Vec3(AT_X, AT_Y, rest + 0.2))
    assert stepping.step_down(t, 0.4, z_val) == lands
    ci = t.collision_info
    assert ci.contact_plane_valid and ci.contact_plane.normal.z == pytest.approx(N_Z_51, abs=1e-6)
    if lands:
        assert _origin(t).z == pytest.approx(rest, abs=1e-4)


# -- StepUp: a 0.25 m step in a closed room -------------------------------------------------------------

CX, CY = 108.0, 108.0  # the room's origin in the landblock
STEP_X, STEP_H = 0.5, 0.25  # the riser (room-local x) and the step's height
WALKER_R = 0.48


def _step_room() -> tuple[engine.World, int]:
    b = SceneBuilder()
    struct = room_struct((-4.0, -3.0, 0.0), (4.0, 3.0, 3.0), solids=[box_solid((STEP_X, -3.0, 0.0), (4.0, 3.0, STEP_H))])
    cell = b.add_env_cell(b.add_struct(struct), (CX, CY, GROUND))
    return b.world(), cell


STEP_WORLD, STEP_CELL = _step_room()


def _against_the_step(state: int, step_up: float) -> Transition:
    """A walker on the room's floor whose check position has its foot sphere's centre 0.1 m past
    the riser: the sphere overlaps the step's box by 0.25 m of height."""
    t = _transition(STEP_WORLD, STEP_CELL, Vec3(CX + STEP_X + 0.1, CY, GROUND), state,
                    radius=WALKER_R, head=True, step_up=step_up)
    t.init_contact_plane(STEP_CELL, Plane(UP, -GROUND), False)
    return t


@pytest.mark.parametrize("step_up", [0.4, 0.3, 0.2, 0.17, 0.16, 0.15])
def test_step_up_climbs_a_step_of_at_most_one_and_a_half_step_up_heights(step_up: float) -> None:
    """Transition.StepUp: onto the step (standing 0.25 m up, where it was across) when 0.25 <= 1.5 *
    step-up height (0.1667 m); else the check position is put back where it was."""
    climbs = STEP_H <= 1.5 * step_up
    t = _against_the_step(GROUNDED, step_up)
    before = _origin(t)
    normal = Vec3(-1.0, 0.0, 0.0)
    assert stepping.step_up(t, normal) == climbs
    path = t.sphere_path
    assert not path.step_up and path.walkable is None  # both cleared whatever the outcome
    assert path.step_up_normal == normal  # what a StepUpSlide slides along next
    if climbs:
        assert _origin(t).z == pytest.approx(GROUND + STEP_H, abs=1e-4)
        assert (_origin(t).x, _origin(t).y) == pytest.approx((before.x, before.y), abs=1e-5)
        assert t.collision_info.contact_plane.normal.z == pytest.approx(1.0)
    else:
        assert _origin(t) == before
        assert path.check_cell is STEP_WORLD.get_landcell(STEP_CELL)


def test_step_up_off_walkable_ground_probes_only_four_centimetres() -> None:
    """Transition.StepUp of a mover not on walkable ground: LandingZ and STEP_DOWN_PROBE (0.04 m),
    whatever its own step-up height; 1.5 * 0.04 = 0.06 m is short of a 0.25 m step."""
    t = _against_the_step(OI.CONTACT, 0.4)
    before = _origin(t)
    assert not stepping.step_up(t, Vec3(-1.0, 0.0, 0.0))
    assert _origin(t) == before
    assert t.sphere_path.walkable_allowance == LANDING_Z


# -- CheckWalkable --------------------------------------------------------------------------------------


@pytest.mark.parametrize("state", [OI.CONTACT, GROUNDED], ids=["not-on-walkable", "no-walkable-polygon"])
def test_check_walkable_is_true_without_a_walkable_to_lose(state: int) -> None:
    """Transition.CheckWalkable: true at once for a mover not on walkable ground, or with no
    remembered walkable polygon (SpherePath.CheckWalkables); no probe moves the check position."""
    t = _transition(FLAT, RAMP_CELL, Vec3(AT_X, AT_Y, 51.0), state)
    before = _origin(t)
    assert stepping.check_walkable(t, FLOOR_Z)
    assert _origin(t) == before and not t.sphere_path.check_walkable


# -- CliffSlide ------------------------------------------------------------------------------------------


def _cliff(step: Vec3) -> Transition:
    """A mover in FLAT's cell whose check position is `step` from its current one, last on flat ground."""
    start = Vec3(AT_X, AT_Y, 50.0)
    t = _transition(FLAT, RAMP_CELL, start + step)
    t.sphere_path.curr_pos = Position(RAMP_CELL, Frame(start))
    t.sphere_path.cache_global_curr_center()
    t.init_last_known_contact_plane(RAMP_CELL, Plane(UP, -50.0), False)
    return t


def test_cliff_slide_takes_back_the_step_across_the_crease() -> None:
    """Transition.CliffSlide: a cliff falling away east (normal (0.6, 0, 0.8)) meets the flat ground
    in a crease along y, whose horizontal normal is n = (1, 0, 0). A step east over it, (0.25, 0.125):
    n . step = 0.25 > 0, the check position moves by -0.25 n (the step along the edge is kept) and -n
    is the collision normal. A step west, (-0.25, 0.125): n . step = -0.25 <= 0, and the client adds
    n * -0.25, once more the step's own westward quarter metre, with n the collision normal."""
    slope = Plane(Vec3(0.6, 0.0, 0.8), 0.0)
    # the crease: (0.6, 0, 0.8) x (0, 0, 1) = (0, -0.6, 0); (-cy, cx, 0) = (0.6, 0, 0) -> n = (1, 0, 0)
    t = _cliff(Vec3(0.25, 0.125, 0.0))
    assert stepping.cliff_slide(t, slope) == TS.ADJUSTED
    assert _origin(t) == Vec3(AT_X, AT_Y + 0.125, 50.0)
    assert t.collision_info.collision_normal == Vec3(-1.0, 0.0, 0.0)

    t = _cliff(Vec3(-0.25, 0.125, 0.0))
    assert stepping.cliff_slide(t, slope) == TS.ADJUSTED
    # angle = -0.25: the offset n * angle = (-0.25, 0, 0) goes on top of the step's own -0.25
    assert _origin(t) == Vec3(AT_X - 0.5, AT_Y + 0.125, 50.0)
    assert t.collision_info.collision_normal == Vec3(1.0, 0.0, 0.0)


def test_cliff_slide_with_no_crease_does_nothing() -> None:
    """Transition.CliffSlide: a contact plane parallel to the last one has no crease (the cross
    product is zero, NormalizeCheckSmall fails): OK, the check position untouched."""
    t = _cliff(Vec3(0.25, 0.125, 0.0))
    before = _origin(t)
    assert stepping.cliff_slide(t, Plane(UP, -50.0)) == TS.OK
    assert _origin(t) == before and not t.collision_info.collision_normal_valid
