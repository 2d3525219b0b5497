"""Engine settings: retail behaviour by default, the reference port's on request."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Final

from .constants import ACE_MAX_QUANTUM, ACE_MAX_STEPS, MAX_QUANTUM, MIN_QUANTUM, RETAIL_MAX_STEPS

__all__ = ["EngineSettings", "RETAIL", "ACE_COMPAT"]


@dataclass(frozen=True, slots=True)
class EngineSettings:
    """Knobs that change results. The defaults are the retail client's.

    - `max_steps`: sub-step cap of FindTransitionalPosition (retail 30, ACE 1000).
    - `ace_normals`: store collision/sliding normals un-normalised as ACE does.
    - `ace_outdoor_viewer`: ACE's terrain check for cameras, which only lets a
      camera clear the ground when its path began indoors (so an outdoor
      camera never moves). Retail lets it move.

    The physics step (PhysicsObj.update_object and what it calls; the
    evidence is in docs/divergences.md, "Retail against ACE: survey"):

    - `quantum_ladder`: `World.step(dt)` spends elapsed time as the client's
      update_object does: time shorter than the minimum quantum (1/30 s) is
      held until more comes, time longer than `max_quantum` is run in
      quanta of `max_quantum` (a remainder not above the minimum quantum is
      held), time longer than the huge quantum (2 s) is dropped. False: one
      integration of exactly `dt`, what the reference traces record.
    - `max_quantum`: the longest physics step of the ladder (client 0.2 s,
      ACE 0.1 s).
    - `sled_slope_friction`: a sledding object moving faster than 2.5 m/s
      gets the low sledding friction (0.2) on ground steeper than 10 degrees
      (normal z below cos 10 deg), as the client's calc_friction gives it.
      False: ACE's test, which gives it on ground flatter than normal z
      0.99999536 instead.
    - `sled_gravity`: a sledding object on walkable ground keeps gravity
      (the client's calc_acceleration). False: ACE's, which zeroes it.

    Speed against accuracy (the client's values by default; the benchmarks
    measure what the others cost in agreement with the reference):

    - `single_precision`: compute in single precision what the client
      computes there and decides on (docs/divergences.md), and keep what a
      move leaves behind in single precision. False: the same routines in
      double precision (each rounds through engine.geometry.single.fl, the
      one place this setting takes effect): positions, velocities, the
      physics step, sub-step offsets, slides, the spheres of the path and
      of obstacles, terrain triangle planes, the planes of cells and
      objects carried into the landblock, contact planes. Single precision
      either way: what the dat files hold as float32 (vertices, terrain
      heights, BSP splitting planes, sphere and cylinder sizes, object
      frames), and the planes of cell and object polygons, which the
      client's make_plane computes from those vertices in float32 once,
      when the data loads (loaded data serves Worlds of either setting,
      and a World's settings can change after it loads). Further from the
      client and about as fast: the same routines run, only the rounding
      is skipped.
    - `step_length`: the longest sub-step, in radii of the mover's foot
      sphere (client: 1.0). Longer sub-steps are fewer and cheaper and can
      pass through geometry thinner than the step.

    Skips of work that cannot change an answer (on by default; off only to
    measure what they save, see docs/performance.md):

    - `skip_far_cells`: a terrain cell's triangles are not tested for a
      point clearly outside its 24 m square.
    - `skip_repeat_spheres`: the outdoor cell search does not repeat itself
      for a sphere at the same x, y and radius as the one before (an upright
      mover's head sphere).
    - `skip_repeat_outside`: within one cell search, the outdoor cells under
      the spheres are added once. The client adds them again from every
      outdoor cell the search visits, with the same spheres, which adds
      nothing new.
    - `skip_far_movers`: a cell's object loop passes over a live mover
      whose shapes none of the path's spheres reaches at the check position
      (a box test; engine/cells/broad_phase.py says why its own test would
      answer OK and change nothing).
    """

    max_steps: int = RETAIL_MAX_STEPS
    ace_normals: bool = False
    ace_outdoor_viewer: bool = False
    quantum_ladder: bool = True
    max_quantum: float = MAX_QUANTUM
    sled_slope_friction: bool = True
    sled_gravity: bool = True
    single_precision: bool = True
    step_length: float = 1.0
    skip_far_cells: bool = True
    skip_repeat_spheres: bool = True
    skip_repeat_outside: bool = True
    skip_far_movers: bool = True

    def __post_init__(self) -> None:
        if not (math.isfinite(self.step_length) and self.step_length > 0.0):
            raise ValueError(f"step_length must be a positive number of radii, got {self.step_length!r}")
        if not (math.isfinite(self.max_quantum) and self.max_quantum >= MIN_QUANTUM):
            raise ValueError(f"max_quantum must be a number of seconds not below the minimum quantum {MIN_QUANTUM}, got {self.max_quantum!r}")
        if self.max_steps < 1:
            raise ValueError(f"max_steps must be at least 1, got {self.max_steps!r}")

    def with_ace_step_cap(self) -> EngineSettings:
        return replace(self, max_steps=ACE_MAX_STEPS)


RETAIL: Final = EngineSettings()
#: What replaying the reference traces needs (ACE's known departures from retail).
ACE_COMPAT: Final = EngineSettings(
    max_steps=ACE_MAX_STEPS,
    ace_normals=True,
    ace_outdoor_viewer=True,
    quantum_ladder=False,
    max_quantum=ACE_MAX_QUANTUM,
    sled_slope_friction=False,
    sled_gravity=False,
)
