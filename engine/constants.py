"""Physics constants of the retail client (PhysicsGlobals and LandDefs).

Values are the client's; the names are the seed's / ACE's in upper snake case.
"""

from __future__ import annotations

from typing import Final

#: General tolerance of the collision code (metres, and unitless for dots).
EPSILON: Final = 0.0002
EPSILON_SQ: Final = EPSILON * EPSILON

#: Minimum normal z of a surface a falling object may land on.
LANDING_Z: Final = 0.0871557
#: Minimum normal z of a surface a grounded object may walk on (cos 48.4 deg).
FLOOR_Z: Final = 0.66417414618662751

DEFAULT_STEP_HEIGHT: Final = 0.01
#: Probe depth the client uses when it has no walkable to step from.
STEP_DOWN_PROBE: Final = 0.039999999

GRAVITY: Final = -9.8
DEFAULT_FRICTION: Final = 0.95
MAX_VELOCITY: Final = 50.0
MAX_VELOCITY_SQ: Final = MAX_VELOCITY * MAX_VELOCITY
SMALL_VELOCITY: Final = 0.25
SMALL_VELOCITY_SQ: Final = SMALL_VELOCITY * SMALL_VELOCITY
#: The physics step ladder of PhysicsObj.update_object (seconds): shorter
#: elapsed time waits, longer is split into MAX_QUANTUM steps, beyond
#: HUGE_QUANTUM it is dropped. The client's MAX_QUANTUM is 0.2 (1 / 5 fps);
#: ACE uses 0.1 (its own comment keeps the 0.2 it replaced).
MIN_QUANTUM: Final = 1.0 / 30.0
MAX_QUANTUM: Final = 0.2
ACE_MAX_QUANTUM: Final = 0.1
HUGE_QUANTUM: Final = 2.0

# -- calc_friction's sledding branch (PhysicsState.Sledding) ------------------
#: below this squared speed a sled on the ground stops (friction 1)
SLED_STOP_SPEED_SQ: Final = 1.5625
#: at or above this squared speed a sled may get the low slope friction
SLED_FAST_SPEED_SQ: Final = 6.25
SLED_SLOPE_FRICTION: Final = 0.2
#: the client: low friction where the ground's normal z is below cos(10 deg)
SLED_SLOPE_NORMAL_Z: Final = 0.98480775301220802
#: ACE: low friction where the ground's normal z is above this (nearly flat)
ACE_SLED_FLAT_NORMAL_Z: Final = 0.99999536
DUMMY_SPHERE_RADIUS: Final = 0.1

#: Sub-step cap of FindTransitionalPosition: retail 30, ACE 1000.
RETAIL_MAX_STEPS: Final = 30
ACE_MAX_STEPS: Final = 1000

#: Iteration caps of the BSP placement routines.
PLACEMENT_ITERATIONS: Final = 20
ADJUST_TO_PLANE_ITERATIONS: Final = 15
#: Slack of the point-in-cell BSP tests.
CELL_BSP_EPSILON: Final = 0.01

# -- LandDefs -------------------------------------------------------------
BLOCK_LENGTH: Final = 192.0
CELL_LENGTH: Final = 24.0
BLOCK_SIDE: Final = 8  # cells per landblock edge
VERTEX_DIM: Final = 9  # height vertices per landblock edge
LAND_LENGTH: Final = 2040  # cells across the world
FIRST_LAND_CELL: Final = 1
LAST_LAND_CELL: Final = 64
FIRST_ENV_CELL: Final = 0x100
LAST_ENV_CELL: Final = 0xFFFD
BLOCK_CELL_ID: Final = 0xFFFF
