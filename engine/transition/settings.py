"""Engine settings: retail behaviour by default, the reference port's on request."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Final

from ..constants import ACE_MAX_STEPS, RETAIL_MAX_STEPS

__all__ = ["EngineSettings", "RETAIL", "ACE_COMPAT"]


@dataclass(frozen=True, slots=True)
class EngineSettings:
    """Knobs that change results. The defaults are the retail client's.

    - `max_steps`: sub-step cap of FindTransitionalPosition (retail 30, ACE 1000).
    - `ace_normals`: store collision/sliding normals un-normalised as ACE does.
    - `ace_outdoor_viewer`: ACE's terrain check for cameras, which only lets a
      camera clear the ground when its path began indoors (so an outdoor
      camera never moves). Retail lets it move.

    Speed against accuracy (the client's values by default; the benchmarks
    measure what the others cost in agreement with the reference):

    - `single_precision`: compute in single precision what the client
      computes there and decides on (docs/divergences.md), and keep what a
      move leaves behind in single precision. False: everything in double
      precision, a little faster and further from the client.
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
    """

    max_steps: int = RETAIL_MAX_STEPS
    ace_normals: bool = False
    ace_outdoor_viewer: bool = False
    single_precision: bool = True
    step_length: float = 1.0
    skip_far_cells: bool = True
    skip_repeat_spheres: bool = True
    skip_repeat_outside: bool = True

    def __post_init__(self) -> None:
        if not (math.isfinite(self.step_length) and self.step_length > 0.0):
            raise ValueError(f"step_length must be a positive number of radii, got {self.step_length!r}")
        if self.max_steps < 1:
            raise ValueError(f"max_steps must be at least 1, got {self.max_steps!r}")

    def with_ace_step_cap(self) -> EngineSettings:
        return replace(self, max_steps=ACE_MAX_STEPS)


RETAIL: Final = EngineSettings()
#: What replaying the reference traces needs (ACE's known departures from retail).
ACE_COMPAT: Final = EngineSettings(max_steps=ACE_MAX_STEPS, ace_normals=True, ace_outdoor_viewer=True)
