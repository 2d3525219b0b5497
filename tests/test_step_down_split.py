"""The step-down's half-step split (Transition.TransitionalInsert, in contact with nothing below).

A grounded mover whose step that leaves it with no contact plane looks for
ground below: one StepDown by its step-down height when its foot sphere's
diameter covers that height; otherwise two StepDowns of half the height, the
second from where the first left the check position (so that no single probe
moves a sphere further than its diameter and through a floor). A one-sphere
mover whose diameter is under its step-down height probes only a quarter of
its diameter. Off walkable ground the probe is STEP_DOWN_PROBE (4 cm) at
LANDING_Z.

The tests record every StepDown TransitionalInsert makes (height, walkable z,
the check position's z before it) over flat ground 50 m up, with the mover's
feet a known gap above it, and check the calls and where the mover ends.
The shared `*-halfstep-2` traces replay such moves against the reference.
"""

from __future__ import annotations

import pytest

import engine.transition.transition as transition_module
from engine.constants import FLOOR_Z, LANDING_Z, STEP_DOWN_PROBE
from engine.geometry import Frame, Position, Sphere, Vec3
from engine.transition.object_info import ObjectInfo
from engine.transition.state import OI, TransitionState
from engine.transition.transition import Transition
from support.replay_tolerances import case_mismatch
from benchmarks.scenes import world_from_heights
from support.shared_data import load_trace, needs_shared, scene_path

GROUND_Z = 50.0
WORLD = world_from_heights(lambda bx, by, x, y: 100)  # flat, 50 m up
CELL = 0xA9B40000 | (3 * 8 + 3 + 1)  # outdoor cell (3, 3), x and y in [72, 96)
COMPILED = not transition_module.__file__.endswith(".py")


class RecordingTransition(Transition):
    """A real transition that notes each StepDown TransitionalInsert asks for."""

    def __init__(self) -> None:
        super().__init__(WORLD.landscape)
        self.calls: list[tuple[float, float, float]] = []
        self.last_state = TransitionState.INVALID

    def step_down(self, step_down_height: float, z_val: float) -> bool:
        self.calls.append((step_down_height, z_val, self.sphere_path.check_pos.frame.origin.z))
        return super().step_down(step_down_height, z_val)


def _insert(gap: float, radius: float, spheres: int, step_down_height: float,
            on_walkable: bool = True) -> RecordingTransition:
    """One TransitionalInsert of a mover in contact whose feet are `gap` above the ground."""
    t = RecordingTransition()
    state = OI.CONTACT | (OI.ON_WALKABLE if on_walkable else 0)
    oi = ObjectInfo(state)
    oi.step_up_height, oi.step_down_height = 0.4, step_down_height
    t.init_object(oi)
    t.init_sphere([Sphere(Vec3(0.0, 0.0, radius + i * 1.0), radius) for i in range(spheres)], 1.0)
    pos = Position(CELL, Frame(Vec3(84.0, 84.0, GROUND_Z + gap)))
    cell = WORLD.get_landcell(CELL)
    t.init_path(cell, pos, pos)
    t.sphere_path.set_check_pos(pos, cell)
    t.sphere_path.walk_interp = 1.0
    t.last_state = t.transitional_insert(1)
    return t


def _heights(t: RecordingTransition) -> list[tuple[float, float]]:
    return [(h, z) for h, z, _ in t.calls]


def _landed(t: RecordingTransition) -> bool:
    ci = t.collision_info
    return (t.last_state == TransitionState.OK
            and ci.contact_plane_valid and ci.contact_plane.normal == Vec3(0.0, 0.0, 1.0)
            and abs(t.sphere_path.check_pos.frame.origin.z - GROUND_Z) < 1e-5)


# a two-sphere mover of radius 0.25 (diameter 0.5) with a step-down height of 0.8: split in two 0.4 probes


def test_ground_within_the_first_half_is_found_by_one_probe() -> None:
    t = _insert(0.3, 0.25, 2, 0.8)
    assert _heights(t) == [(0.4, FLOOR_Z)]
    assert _landed(t)


def test_ground_below_the_first_half_is_found_by_the_second_from_where_the_first_left_off() -> None:
    t = _insert(0.6, 0.25, 2, 0.8)
    assert _heights(t) == [(0.4, FLOOR_Z), (0.4, FLOOR_Z)]
    assert [z for _, _, z in t.calls] == pytest.approx([GROUND_Z + 0.6, GROUND_Z + 0.2], abs=1e-5)
    assert _landed(t)


def test_ground_beyond_both_halves_is_not_found() -> None:
    t = _insert(0.9, 0.25, 2, 0.8)
    assert _heights(t) == [(0.4, FLOOR_Z), (0.4, FLOOR_Z)]
    assert not t.collision_info.contact_plane_valid


@pytest.mark.parametrize(
    ("gap", "radius", "spheres", "height", "on_walkable", "probe", "lands"),
    [
        # the player's spheres: radius 0.48, diameter 0.96 over a step-down height of 0.4
        pytest.param(0.3, 0.48, 2, 0.4, True, (0.4, FLOOR_Z), True, id="diameter-over-height"),
        pytest.param(0.6, 0.48, 2, 0.4, True, (0.4, FLOOR_Z), False, id="diameter-over-height-too-deep"),
        pytest.param(0.45, 0.25, 2, 0.5, True, (0.5, FLOOR_Z), True, id="diameter-equal-to-height"),
        # one sphere whose diameter is under the height: a quarter of the diameter
        pytest.param(0.1, 0.25, 1, 0.8, True, (0.125, FLOOR_Z), True, id="one-sphere"),
        pytest.param(0.2, 0.25, 1, 0.8, True, (0.125, FLOOR_Z), False, id="one-sphere-too-deep"),
        # off walkable ground: four centimetres, landing slope
        pytest.param(0.03, 0.25, 2, 0.8, False, (STEP_DOWN_PROBE, LANDING_Z), True, id="off-walkable"),
    ],
)
def test_a_single_probe(gap: float, radius: float, spheres: int, height: float, on_walkable: bool,
                        probe: tuple[float, float], lands: bool) -> None:
    t = _insert(gap, radius, spheres, height, on_walkable)
    assert _heights(t) == [probe]
    assert _landed(t) == lands


# -- the reference's own half-step moves ------------------------------------------------

HALFSTEP_TRACES = ["cellar-halfstep-2", "cliff-halfstep-2", "interior-halfstep-2", "rolling-halfstep-2"]


@needs_shared
@pytest.mark.skipif(COMPILED, reason="counts StepDown calls by patching the pure-Python Transition")
def test_the_halfstep_traces_probe_in_halves_and_land_on_second_halves(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every halfstep trace's movers probe in half-steps (a probe longer than the foot sphere's
    radius is half of one too long for its diameter), some land only with the second half
    (interior-halfstep-2 today), and the engine agrees with the reference on every move: the
    replay exercises the split."""
    import engine

    real = Transition.step_down
    half_probes: dict[str, int] = dict.fromkeys(HALFSTEP_TRACES, 0)
    second_half_landings = 0
    #: by transition: where a failed first half left the check position (the second half starts there)
    failed_first_half: dict[int, object] = {}
    name = ""

    def counting(self: Transition, step_down_height: float, z_val: float) -> bool:
        nonlocal second_half_landings
        path = self.sphere_path
        is_half = step_down_height > path.global_sphere[0].radius
        is_second_half = is_half and failed_first_half.pop(id(self), None) is path.check_pos
        landed = real(self, step_down_height, z_val)
        half_probes[name] += is_half
        second_half_landings += landed and is_second_half
        if is_half and not landed and not is_second_half:
            failed_first_half[id(self)] = path.check_pos
        return landed

    monkeypatch.setattr(Transition, "step_down", counting)
    for name in HALFSTEP_TRACES:
        trace = load_trace(name)
        world = engine.load_scene(scene_path(trace["scene"]))
        for case in trace["cases"]:
            assert case_mismatch(case, engine.run_case(world, case)) is None, case["id"]
    assert all(n > 100 for n in half_probes.values()), half_probes
    assert second_half_landings > 0
