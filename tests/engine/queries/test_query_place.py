"""World.place (engine.queries.placement) and add_mover's placement option,
against the shared placement traces: the reference's own placements of
players and items on steep terrain, cliffs, against walls, in rooms, on
stairs and among objects."""

from __future__ import annotations

from typing import Any

import pytest

import engine
from engine import MoverSpec, Position, SphereSpec, Vec3
from engine.errors import NonFiniteError, PlacementFailedError
from engine.geometry import Frame, Quat
from engine.queries.placement import PlacementResult
from support.replay_tolerances import move_mismatches
from support.mover_slots import mover_state_slot_names
from support.shared_data import ORACLE, load_trace, require_shared, scene_path

require_shared()  # the cases are read from the traces while collecting

SCENES = ["rolling", "steep", "cliff", "house", "interior", "cellar", "dungeon", "objects"]


def _spec(obj: dict[str, Any]) -> MoverSpec:
    return MoverSpec(
        spheres=[SphereSpec(tuple(s["center"]), s["radius"]) for s in obj["spheres"]],  # type: ignore[arg-type]
        step_up_height=obj["step_up_height"],
        step_down_height=obj["step_down_height"],
        state=list(obj["state"]),
        step_down=obj["step_down"],
        ethereal=obj["ethereal"],
        scale=obj["scale"],
        gravity=obj["gravity"],
    )


def _target(to: dict[str, Any]) -> Position:
    return Position(int(to["cell"], 16), Frame(Vec3(*to["origin"]), Quat(*to["orientation"])))


def _cases() -> list[Any]:
    params = []
    for name in SCENES:
        trace = load_trace(f"{name}-placement")
        for case in trace["cases"]:
            first = case["moves"][0]
            if "placement" in first and first["to"].get("cell", "current") != "current" and "orientation" in first["to"]:
                params.append(pytest.param(trace["scene"], case, id=case["id"]))
    return params


CASES = _cases()
_worlds: dict[str, engine.World] = {}


def _world(scene: str) -> engine.World:
    if scene not in _worlds:
        _worlds[scene] = engine.load_scene(scene_path(scene))
    return _worlds[scene]


def _as_expect(result: PlacementResult) -> dict[str, Any]:
    """A placement query's answer in the fields of a trace move's `expect`."""
    got: dict[str, Any] = {"ok": result.ok, "placement_result": result.placement_result}
    if not result.ok:
        return got
    assert result.position is not None
    plane = result.contact_plane
    got.update(
        position={"cell": f"{result.position.cell_id:08X}", "origin": list(result.position.frame.origin.as_tuple())},
        contact=result.contact,
        on_walkable=result.on_walkable,
        water_contact=result.water_contact,
        contact_plane=None if plane is None else {"normal": list(plane.normal.as_tuple()), "d": plane.d},
        contact_plane_cell=None if result.contact_plane_cell is None else f"{result.contact_plane_cell:08X}",
    )
    return got


def test_most_placement_cases_are_tested() -> None:
    assert len(CASES) > 300


@pytest.mark.parametrize(("scene", "case"), CASES)
def test_place_puts_the_object_where_the_reference_placed_it(scene: str, case: dict[str, Any]) -> None:
    """The first move of every placement case, asked as a query: same outcome,
    position and contact state as the reference's (the tolerances of tests/support/replay_tolerances.py)."""
    move = case["moves"][0]
    expect = move["expect"]
    world = _world(scene)
    result = world.place(_spec(case["object"]), _target(move["to"]), move["placement"]["mode"], bool(move["placement"]["slide"]))
    got = _as_expect(result)
    assert move_mismatches({k: expect[k] for k in got}, got) == [], (got, expect)
    if not result.ok:
        assert result.position is None


def _moved_cases(tag: str) -> list[Any]:
    """Placement cases where the reference moved the object by more than 5 cm."""
    out = []
    for p in CASES:
        case = p.values[1]
        move = case["moves"][0]
        if tag not in case["tags"] or not move["expect"]["ok"]:
            continue
        a, b = move["to"]["origin"], move["expect"]["position"]["origin"]
        if max(abs(x - y) for x, y in zip(a, b)) > 0.05:
            out.append(p)
    return out


def test_the_traces_hold_placements_that_move_the_object_off_steep_slopes_and_out_of_walls() -> None:
    """The cases above include a player moved on a steep slope, and a mover
    moved out of a wall."""
    assert any("IsPlayer" in p.values[1]["object"]["state"] for p in _moved_cases("terrain") if "steep" in p.values[1]["id"])
    assert _moved_cases("wall-e") or _moved_cases("corner")


def test_place_changes_no_mover_and_add_mover_places_when_asked() -> None:
    case = next(p.values[1] for p in _moved_cases("terrain") if "steep" in p.values[1]["id"])
    move = case["moves"][0]
    world = engine.load_scene(scene_path("steep"))
    spec = _spec(case["object"])
    target = _target(move["to"])
    other = world.add_mover(spec, target)  # an object standing right at the target, unplaced
    before = repr([(n, getattr(world.mover(other), n)) for n in mover_state_slot_names()])
    world.place(spec, target, move["placement"]["mode"], bool(move["placement"]["slide"]))
    after = repr([(n, getattr(world.mover(other), n)) for n in mover_state_slot_names()])
    assert before == after and list(world.movers) == [other]
    # registering with the placement option puts the mover where the query says
    world.remove_mover(other)
    asked = world.place(spec, target, move["placement"]["mode"], bool(move["placement"]["slide"]))
    mid = world.add_mover(spec, target, placement=move["placement"]["mode"], slide=bool(move["placement"]["slide"]))
    placed = world.mover_state(mid)
    assert asked.position is not None
    assert placed.position.cell_id == asked.position.cell_id and placed.position.frame.origin == asked.position.frame.origin
    assert placed.contact == asked.contact and placed.on_walkable == asked.on_walkable


def test_a_mover_with_no_place_is_not_registered() -> None:
    case = next(p.values[1] for p in CASES if not p.values[1]["moves"][0]["expect"]["ok"])
    move = case["moves"][0]
    world = engine.load_scene(scene_path(case['id'].split('-placement')[0]))
    with pytest.raises(PlacementFailedError):
        world.add_mover(_spec(case["object"]), _target(move["to"]), placement=move["placement"]["mode"], slide=bool(move["placement"]["slide"]))
    assert world.movers == {}
    first = world.add_mover(MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.5), 0.5)]), _target(move["to"]))
    assert first == 1  # the refused mover used up no id


def test_place_refuses_bad_input() -> None:
    world = engine.load_scene(scene_path("steep"))
    spec = MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.5), 0.5)])
    with pytest.raises(NonFiniteError):
        world.place(spec, Position.at(0xA9B40035, Vec3(float("nan"), 10.0, 10.0)))
    with pytest.raises(ValueError, match="placement mode"):
        world.place(spec, Position.at(0xA9B40035, Vec3(160.0, 110.0, 160.0)), mode="sideways")


def test_the_readme_queries_example_runs(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    """README.md's "Spatial queries" example, run as written from the repo root."""
    from pathlib import Path

    root = Path(__file__).resolve().parents[3]
    text = (root / "README.md").read_text()
    section = text.split("### Spatial queries", 1)[1]
    code = section.split("```python\n", 1)[1].split("```", 1)[0]
    assert "../shared/oracle/scenes/" in code  # the README names the material where it is beside a checkout
    code = code.replace("../shared/oracle", str(ORACLE))  # and here it is wherever shared_data found it
    monkeypatch.chdir(root)
    exec(compile(code, "README.md", "exec"), {})
    printed = capsys.readouterr().out.split()
    assert printed[1] == "True"  # the ray ends 30 m under the terrain: it must hit the ground
