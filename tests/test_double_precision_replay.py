"""Every move of the shared reference traces, replayed in double precision.

The reference is float32 (ACE's physics); with `single_precision=False` the
engine runs the same routines without rounding to float32
(EngineSettings.single_precision). The replay is held to
support.replay_tolerances.DOUBLE_PRECISION: cells, contact and walkable flags, the
transient state and the counters exactly, as in the default's replay;
origins within 1e-3 m, normals and planes within 1e-3 (the default setting
is held ten times closer: it computes as the reference does).

Why 1e-3 m holds away from knife edges: the two precisions differ by the
float32 rounding of what each move leaves behind and of the sums inside it,
at most half a float32 step per rounding, 2**-17 m (7.6e-6 m) at the traces'
coordinates (64 to 256 m: steps of 7.6e-6 to 1.5e-5 m). Rounding errors of
either sign add up like a random walk: over a case's sub-steps (up to a few
hundred) that is some 1e-4 m. Measured over every move of every trace (same
cell): median 3.7e-6 m, p90 2.1e-5 m, p99 1.7e-4 m (the error benchmark,
benchmarks/bench_error.py, found p99 1.6e-4 m), a sixth of the tolerance.

A knife edge is a decision whose inputs sit within that rounding of its
threshold: double and float32 then decide differently, and the paths part.
The cases below meet one, each at the move named; the test checks that the
case agrees with the reference up to that move and disagrees there (a
change of either shows up at once). What decides differently, where it was
traced: a movement parallel to a wall's edge (PrecipiceSlide: dot(edge
normal, movement) is -1.3e-7 in float32 and +-2e-15 in double, and its
sign picks which way the slide normal faces: objects-edgeslide-046). The
others are named by what disagrees first; every first disagreement is at a
move where the reference records a collision, except the long move of
cliff-longmove-016 (its 0.0012 m is rounding over the sub-steps of a 22 m
move).
"""

from __future__ import annotations

import dataclasses
import re

import pytest

import engine
from support.replay_tolerances import DOUBLE_PRECISION, case_mismatch
from support.shared_data import require_shared
from test_trace_replay import CASES, _world

require_shared()

DOUBLE = dataclasses.replace(engine.ACE_COMPAT, single_precision=False)

_WALL_SIDE = "a wall met edge-on: the collision normal's sign flips"
_BOUNCE = "a missile's collision: the flight after it parts by millimetres"
_TERRAIN = "a terrain contact within rounding of the EPSILON band"

#: case id -> (the first disagreeing move, what disagrees there)
KNIFE_EDGES: dict[str, tuple[str, str]] = {
    "steep-056-walk": ("move 30", "a sphere sunk into its contact plane (test_single_precision's AdjustOffset "
                       "example): lifted 1.7e-6 m higher, the next step is refused (collision normal +z, 0.3 m)"),
    "steep-156-steep": ("move 56", _TERRAIN + " (contact, 0.17 m)"),
    "cliff-130-steep": ("move 116", _TERRAIN + " (position, 0.84 m)"),
    "cliff-longmove-016-long": ("move 2", "a 22 m move's 37 sub-steps (position, 0.0012 m)"),
    "cliff-longmove-063-long": ("move 3", _TERRAIN + " (on_walkable and the cell)"),
    "cliff-missile-000-missile": ("move 30", _BOUNCE),
    "cliff-missile-026-missile": ("move 24", _BOUNCE),
    "rolling-missile-000-missile": ("move 11", _BOUNCE),
    "rolling-missile-013-missile": ("move 30", _BOUNCE + " (lands: contact)"),
    "rolling-missile-030-missile": ("move 13", _BOUNCE),
    "rolling-missile-033-missile": ("move 33", _BOUNCE + " (lands: contact)"),
    "steep-missile-020-missile": ("move 25", _BOUNCE),
    "steep-missile-023-missile": ("move 56", _BOUNCE),
    "objects-missile-033-missile": ("move 20", _BOUNCE),
    "cliff-missile-003": ("move 16", _BOUNCE + " (lands sliding or not)"),
    "interior-walk-003": ("move 8", _WALL_SIDE + " (a corner: which wall answers first)"),
    "interior-walk-020": ("move 15", _WALL_SIDE + " (a corner: which wall answers first)"),
    "interior-006-door-step": ("move 90", _WALL_SIDE),
    "interior-013-door-step": ("move 93", _WALL_SIDE),
    "interior-063-wander": ("move 8", _WALL_SIDE),
    "interior-066-wander": ("move 18", _WALL_SIDE),
    "interior-placement-103-place": ("move 7", _WALL_SIDE),
    "interior-movers-043-inner-door": ("mover a: move 34", _WALL_SIDE),
    "objects-edgeslide-046-edge-roof": ("move 25", _WALL_SIDE + " (traced: PrecipiceSlide)"),
    "interior-050-wall": ("move 10", "a grazing wall contact: collided or not"),
    "interior-placement-000-place": ("move 27", "a slide along a wall (position, 0.02 m)"),
    "dungeon-viewer-246-viewer-chase": ("move 62", "a camera's slide along a wall (position, 0.016 m)"),
    "objects-movers-053-step-onto": ("mover p: move 14", "a contact plane on a moving object (d, 0.002 m)"),
}


def test_the_knife_edges_are_cases_of_the_replay() -> None:
    ids = {p.values[1]["id"] for p in CASES}
    assert set(KNIFE_EDGES) <= ids
    assert len(KNIFE_EDGES) < len(CASES) / 50  # under 2 % of the cases


@pytest.mark.parametrize(("scene", "case"), CASES)
def test_case_agrees_in_double_precision(scene: str, case: dict) -> None:
    problem = case_mismatch(case, engine.run_case(_world(scene), case, settings=DOUBLE), DOUBLE_PRECISION)
    knife = KNIFE_EDGES.get(case["id"])
    if knife is None:
        assert problem is None, problem
        return
    at, why = knife
    assert problem is not None, f"agrees now; remove it from KNIFE_EDGES ({why})"
    first = re.match(r"(mover \w+: )?move \d+", problem)
    assert first is not None and first.group(0) == at, f"first disagrees at {problem[:200]} instead of {at} ({why})"
