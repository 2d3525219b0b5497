"""World.place (engine.queries.placement) and add_mover's placement option,
against the shared placement traces: the reference's own placements of
players and items on steep terrain, cliffs, against walls, in rooms, on
stairs and among objects."""

from __future__ import annotations

import gzip
import json
from typing import Any

import pytest

import engine
from engine import MoverSpec, Position, SphereSpec, Vec3
from engine.errors import NonFiniteError, PlacementFailedError
from engine.geometry import Frame, Quat
from replay_check import NORMAL_TOL, POS_TOL
from support.mover_slots import mover_state_slot_names
from support.shared_data import ORACLE, require_shared

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
        with gzip.open(ORACLE / "traces" / f"{name}-placement.trace.json.gz", "rt") as f:
            trace = json.load(f)
        for case in trace["cases"]:
            first = case["moves"][0]
            if "placement" in first and first["to"].get("cell", "current") != "current" and "orientation" in first["to"]:
                params.append(pytest.param(trace["scene"], case, id=case["id"]))
    return params


CASES = _cases()
_worlds: dict[str, engine.World] = {}


def _world(scene: str) -> engine.World:
    if scene not in _worlds:
        _worlds[scene] = engine.load_scene(ORACLE / "scenes" / scene)
    return _worlds[scene]


def _close(a: Vec3, b: list[float], tol: float) -> bool:
    return abs(a.x - b[0]) <= tol and abs(a.y - b[1]) <= tol and abs(a.z - b[2]) <= tol


def test_most_placement_cases_are_tested() -> None:
    assert len(CASES) > 300


@pytest.mark.parametrize(("scene", "case"), CASES)
def test_place_puts_the_object_where_the_reference_placed_it(scene: str, case: dict[str, Any]) -> None:
    """The first move of every placement case, asked as a query: same outcome,
    position (to the traces' 1 mm) and contact state as the reference's."""
    move = case["moves"][0]
    expect = move["expect"]
    world = _world(scene)
    result = world.place(_spec(case["object"]), _target(move["to"]), move["placement"]["mode"], bool(move["placement"]["slide"]))
    assert result.placement_result == expect["placement_result"]
    assert result.ok == expect["ok"]
    if not result.ok:
        assert result.position is None
        return
    assert result.position is not None
    assert f"{result.position.cell_id:08X}" == expect["position"]["cell"]
    assert _close(result.position.frame.origin, expect["position"]["origin"], POS_TOL)
    assert result.contact == expect["contact"] and result.on_walkable == expect["on_walkable"]
    assert result.water_contact == expect["water_contact"]
    if expect["contact_plane"] is None or not result.contact:
        assert result.contact_plane is None or not expect["contact"]
    else:
        assert result.contact_plane is not None
        assert _close(result.contact_plane.normal, expect["contact_plane"]["normal"], NORMAL_TOL)
        assert abs(result.contact_plane.d - expect["contact_plane"]["d"]) <= NORMAL_TOL


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
    """The cases above include what the issue names: a player moved on a steep
    slope, and one moved out of a wall."""
    assert any("IsPlayer" in p.values[1]["object"]["state"] for p in _moved_cases("terrain") if "steep" in p.values[1]["id"])
    assert _moved_cases("wall-e") or _moved_cases("corner")


def test_place_changes_no_mover_and_add_mover_places_when_asked() -> None:
    case = next(p.values[1] for p in _moved_cases("terrain") if "steep" in p.values[1]["id"])
    move = case["moves"][0]
    world = engine.load_scene(ORACLE / "scenes" / "steep.json")
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
    world = engine.load_scene(ORACLE / "scenes" / f"{case['id'].split('-placement')[0]}.json")
    with pytest.raises(PlacementFailedError):
        world.add_mover(_spec(case["object"]), _target(move["to"]), placement=move["placement"]["mode"], slide=bool(move["placement"]["slide"]))
    assert world.movers == {}
    first = world.add_mover(MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.5), 0.5)]), _target(move["to"]))
    assert first == 1  # the refused mover used up no id


def test_place_refuses_bad_input() -> None:
    world = engine.load_scene(ORACLE / "scenes" / "steep.json")
    spec = MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.5), 0.5)])
    with pytest.raises(NonFiniteError):
        world.place(spec, Position.at(0xA9B40035, Vec3(float("nan"), 10.0, 10.0)))
    with pytest.raises(ValueError, match="placement mode"):
        world.place(spec, Position.at(0xA9B40035, Vec3(160.0, 110.0, 160.0)), mode="sideways")


def test_the_readme_queries_example_runs(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    """README.md's "Spatial queries" example, run as written from the repo root."""
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    text = (root / "README.md").read_text()
    section = text.split("### Spatial queries", 1)[1]
    code = section.split("```python\n", 1)[1].split("```", 1)[0]
    if not (root.parent / "shared" / "oracle").is_dir():
        code = code.replace("../shared/oracle", str(ORACLE))
    monkeypatch.chdir(root)
    exec(compile(code, "README.md", "exec"), {})
    printed = capsys.readouterr().out.split()
    assert printed[1] == "True"  # the ray ends 30 m under the terrain: it must hit the ground
