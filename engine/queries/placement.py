"""place: where the client would put an object of a given shape if it entered
the world (or teleported) at a position, without putting it there.

The client's placement (PhysicsObj.SetPosition with a placement insert:
AdjustPosition to find the cell, a placement transition that pushes the
object out of what it overlaps and, when sliding is allowed, searches
around the target for a free spot, then lands it with a LandingZ step-down;
CTransition::find_placement_position) run on an object that no cell knows
about: engine.world.placement.run_placement, the same code a registered
mover's placement runs. Its outcome is applied to that throwaway object
only (SetPositionInternal, for the contact state the client would leave),
so the query changes no mover.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .. import limits
from ..geometry import Position
from ..world.placement import PLACEMENT_MODES, mover_from_spec, run_placement
from ..world.transient import TS
from ..world.types import MoverSpec
from .results import PlacementResult

if TYPE_CHECKING:
    from ..world.world import World

__all__ = ["PlacementResult", "place"]


def place(world: World, spec: MoverSpec, position: Position, mode: str = "enter_world", slide: bool = True) -> PlacementResult:
    """Place an object of shape `spec` at `position` as the client does on spawn
    (`mode` "enter_world", a placement ending in another landblock refused)
    or on teleport ("teleport"); `slide` lets it search for a free spot
    nearby (without it only a shift under 5 cm is accepted)."""
    if mode not in PLACEMENT_MODES:
        raise ValueError(f"placement mode must be one of {PLACEMENT_MODES}, got {mode!r}")
    limits.check_mover_spec(spec, "spec")
    limits.check_start(position, "position", limits.start_slack(spec))
    world._check_position(position)
    probe = mover_from_spec(-1, spec)
    probe.position = position
    outcome, t, _ = run_placement(world, probe, position, mode, slide)
    if outcome != "OK":
        return PlacementResult(False, outcome, None)
    probe.set_position_internal(t)
    contact = bool(probe.transient & TS.CONTACT)
    return PlacementResult(
        True,
        outcome,
        probe.position,
        contact,
        bool(probe.transient & TS.ON_WALKABLE),
        probe.contact_plane if contact else None,
        probe.contact_plane_cell_id if contact else None,
        bool(probe.transient & TS.WATER_CONTACT),
    )
