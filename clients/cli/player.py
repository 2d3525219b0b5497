"""The mover the command line walks when none is given: a player's size and step heights."""

from __future__ import annotations

from engine import MoverSpec, SphereSpec

__all__ = ["player_mover"]


def player_mover() -> MoverSpec:
    """A player-sized mover: two spheres of 0.48 m stacked as the client's human setup has them, stepping up
    0.6 m and down 0.4 m."""
    return MoverSpec(
        spheres=[SphereSpec((0.0, 0.0, 0.48), 0.48), SphereSpec((0.0, 0.0, 1.35), 0.48)],
        step_up_height=0.6,
        step_down_height=0.4,
        state=["IsPlayer"],
    )
