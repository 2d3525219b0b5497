"""Walkers: who a path is for, as the probe that walks it and the class whose graph it uses.

A walker is named by a MoverSpec (a shape that is not in the world yet) or
by a registered mover's id. Either way the path is proven by a probe of
that exact shape and state (engine.navigation.walk). The graph the search
runs on is shared by a walker *class*: sizes rounded so that close shapes
share one graph (radius and height up, step heights down: the class's
representative is never more able than its members), built with that
representative. The graph only guides the search; the proof walk of the
walker itself decides what is answered.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Final

from ..errors import UnknownMoverError
from ..geometry import Sphere, Vec3
from ..transition.state import OI
from ..world.mover import Mover
from ..world.placement import mover_from_spec
from ..world.types import MoverSpec

if TYPE_CHECKING:
    from ..world.world import World

__all__ = ["WalkerClass", "walker_class", "probe_for_spec", "probe_like", "Walker"]

#: a walker's radius is rounded up to this, metres
RADIUS_QUANTUM: Final = 0.02
#: its height is rounded up to this
HEIGHT_QUANTUM: Final = 0.1
#: its step-up and step-down heights are rounded down to this
STEP_QUANTUM: Final = 0.05

#: a MoverSpec, or a registered mover's id
Walker = MoverSpec | int


@dataclass(frozen=True, slots=True)
class WalkerClass:
    """The quantised size of a walker: the key of a navigation graph."""

    radius: float
    height: float
    step_up_height: float
    step_down_height: float
    edge_slide: bool

    def representative(self) -> Mover:
        """A probe of this class's shape: spheres of the class radius stacked up to its height, each
        touching or overlapping the next (no gap a ledge could slip through), the class's step heights."""
        r = self.radius
        top = max(r, self.height - r)
        count = max(1, math.ceil((top - r) / (2.0 * r)) + 1)
        spheres = [Sphere(Vec3(0.0, 0.0, r + (top - r) * i / max(1, count - 1)), r) for i in range(count)]
        flags = OI.EDGE_SLIDE if self.edge_slide else 0
        probe = Mover(-1, spheres, oi_flags=flags, step_up_height=self.step_up_height,
                      step_down_height=self.step_down_height, creature=True)
        probe.ignore_movers = True
        return probe


def _quantise_up(value: float, quantum: float) -> float:
    return round(math.ceil(value / quantum - 1e-9) * quantum, 6)


def _quantise_down(value: float, quantum: float) -> float:
    return round(math.floor(value / quantum + 1e-9) * quantum, 6)


def walker_class(probe: Mover) -> WalkerClass:
    """The class of a probe's shape: its widest sphere (or cylsphere) radius and its top, scaled."""
    scale = probe.scale
    radius = 0.0
    height = 0.0
    for s in probe.spheres:
        radius = max(radius, s.radius * scale)
        height = max(height, (s.center.z + s.radius) * scale)
    for c in probe.cyl_spheres:
        radius = max(radius, float(c.radius) * scale)
        height = max(height, (float(c.origin[2]) + float(c.height)) * scale)
    return WalkerClass(
        _quantise_up(radius, RADIUS_QUANTUM),
        _quantise_up(max(height, 2.0 * radius), HEIGHT_QUANTUM),
        _quantise_down(probe.step_up_height, STEP_QUANTUM),
        _quantise_down(probe.step_down_height, STEP_QUANTUM),
        bool(probe.oi_flags & OI.EDGE_SLIDE),
    )


def probe_for_spec(spec: MoverSpec) -> Mover:
    """A probe of shape `spec` that no cell knows about (checked against engine.limits)."""
    return mover_from_spec(-1, spec)


def probe_like(world: World, mover_id: int) -> Mover:
    """The registered mover itself, as its own probe: walks on it run with cast_shadows off and its
    state is put back afterwards (engine.navigation.walk.ProbeState), so it collides with exactly what
    it would collide with when it walks, and never with its own shadow."""
    mover = world.movers.get(mover_id)
    if mover is None:
        raise UnknownMoverError(f"no mover with id {mover_id}")
    return mover
