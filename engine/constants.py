"""Physics constants of the retail client (PhysicsGlobals and LandDefs).

Values are the client's; the names are the seed's / ACE's in upper snake case.
"""

from __future__ import annotations

#: General tolerance of the collision code (metres, and unitless for dots).
EPSILON = 0.0002
EPSILON_SQ = EPSILON * EPSILON

#: Minimum normal z of a surface a falling object may land on.
LANDING_Z = 0.0871557
#: Minimum normal z of a surface a grounded object may walk on (cos 48.4 deg).
FLOOR_Z = 0.66417414618662751

DEFAULT_STEP_HEIGHT = 0.01
#: Probe depth the client uses when it has no walkable to step from.
STEP_DOWN_PROBE = 0.039999999

GRAVITY = -9.8
DEFAULT_FRICTION = 0.95
MAX_VELOCITY = 50.0
MAX_VELOCITY_SQ = MAX_VELOCITY * MAX_VELOCITY
SMALL_VELOCITY = 0.25
SMALL_VELOCITY_SQ = SMALL_VELOCITY * SMALL_VELOCITY
MIN_QUANTUM = 1.0 / 30.0
MAX_QUANTUM = 0.1
HUGE_QUANTUM = 2.0
DUMMY_SPHERE_RADIUS = 0.1

#: Sub-step cap of FindTransitionalPosition: retail 30, ACE 1000.
RETAIL_MAX_STEPS = 30
ACE_MAX_STEPS = 1000

#: Iteration caps of the BSP placement routines.
PLACEMENT_ITERATIONS = 20
ADJUST_TO_PLANE_ITERATIONS = 15
#: Slack of the point-in-cell BSP tests.
CELL_BSP_EPSILON = 0.01

# -- LandDefs -------------------------------------------------------------
BLOCK_LENGTH = 192.0
CELL_LENGTH = 24.0
BLOCK_SIDE = 8  # cells per landblock edge
VERTEX_DIM = 9  # height vertices per landblock edge
LAND_LENGTH = 2040  # cells across the world
FIRST_LAND_CELL = 1
LAST_LAND_CELL = 64
FIRST_ENV_CELL = 0x100
LAST_ENV_CELL = 0xFFFD
BLOCK_CELL_ID = 0xFFFF
