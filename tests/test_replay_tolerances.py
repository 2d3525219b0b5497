"""support.replay_tolerances, the comparison every trace test goes through, notices what it should.

Each check starts from a move that agrees and changes one thing by a known
amount: just inside a tolerance it still agrees, just outside it does not;
what the reference gives exactly must match exactly.
"""

from __future__ import annotations

import copy
from typing import Any

import pytest

from support.replay_tolerances import NORMAL_TOL, PLANE_D_TOL, POS_TOL, case_mismatch, first_mismatch, move_mismatches

EXPECT: dict[str, Any] = {
    "ok": True,
    "position": {"cell": "A9B40001", "origin": [10.5, 10.2, 52.013]},
    "contact": True,
    "on_walkable": True,
    "contact_plane": {"normal": [0.0, 0.6, 0.8], "d": -52.1},
    "collision_normal": [1.0, 0.0, 0.0],
    "sliding_normal": None,
    "contact_plane_cell": "A9B40001",
    "water_contact": False,
    "frames_stationary_fall": 0,
    "transient_state": ["Contact", "OnWalkable"],
}


def _with(path: tuple[Any, ...], value: Any) -> dict[str, Any]:
    got = copy.deepcopy(EXPECT)
    target: Any = got
    for key in path[:-1]:
        target = target[key]
    target[path[-1]] = value
    return got


def test_tolerances_are_those_the_engine_achieves() -> None:
    # the worst differences over every shared trace are 2.34e-5 m, 1.6e-6 and 7.4e-6 m (module docstring)
    assert (POS_TOL, NORMAL_TOL, PLANE_D_TOL) == (1e-4, 1e-5, 1e-5)


def test_an_identical_move_agrees() -> None:
    assert move_mismatches(EXPECT, copy.deepcopy(EXPECT)) == []


@pytest.mark.parametrize(
    ("path", "base", "tol", "key"),
    [
        (("position", "origin", 2), 52.013, POS_TOL, "position"),
        (("contact_plane", "normal", 1), 0.6, NORMAL_TOL, "contact_plane"),
        (("contact_plane", "d"), -52.1, PLANE_D_TOL, "contact_plane"),
        (("collision_normal", 0), 1.0, NORMAL_TOL, "collision_normal"),
    ],
)
def test_each_tolerance_is_a_boundary(path: tuple[Any, ...], base: float, tol: float, key: str) -> None:
    assert move_mismatches(EXPECT, _with(path, base - 0.9 * tol)) == []
    assert move_mismatches(EXPECT, _with(path, base + 1.1 * tol)) == [key]


@pytest.mark.parametrize(
    ("path", "value", "key"),
    [
        (("position", "cell"), "A9B40002", "position"),
        (("ok",), 1, "ok"),  # True is not 1
        (("contact",), False, "contact"),
        (("frames_stationary_fall",), 1, "frames_stationary_fall"),
        (("frames_stationary_fall",), None, "frames_stationary_fall"),
        (("frames_stationary_fall",), 0.0, "frames_stationary_fall"),
        (("transient_state",), ["OnWalkable", "Contact"], "transient_state"),
        (("transient_state",), ["Contact"], "transient_state"),
        (("contact_plane_cell",), "a9b40001", "contact_plane_cell"),
        (("sliding_normal",), [0.0, 0.0, 0.0], "sliding_normal"),  # "not valid" is not a zero vector
        (("collision_normal",), None, "collision_normal"),
        (("contact_plane",), None, "contact_plane"),
        (("position", "origin"), [10.5, 10.2], "position"),
    ],
)
def test_exact_fields_are_exact(path: tuple[Any, ...], value: Any, key: str) -> None:
    assert move_mismatches(EXPECT, _with(path, value)) == [key]


def test_a_missing_field_disagrees_even_where_the_reference_has_null() -> None:
    got = copy.deepcopy(EXPECT)
    del got["sliding_normal"]
    assert move_mismatches(EXPECT, got) == ["sliding_normal"]


def _case(n: int, placement_fails_at: int | None = None) -> dict[str, Any]:
    moves = [{"expect": copy.deepcopy(EXPECT)} for _ in range(n)]
    if placement_fails_at is not None:
        moves[placement_fails_at]["placement"] = {"mode": "teleport", "slide": True}
        moves[placement_fails_at]["expect"]["placement_result"] = "NoValidPosition"
        moves[placement_fails_at]["expect"]["ok"] = False
    return {"moves": moves}


def test_fewer_results_than_moves_only_after_a_failed_placement() -> None:
    results = [copy.deepcopy(m["expect"]) for m in _case(3, placement_fails_at=1)["moves"]]
    assert first_mismatch(_case(3, placement_fails_at=1), results[:2]) is None
    assert first_mismatch(_case(3, placement_fails_at=1), results[:1]) == "1 results for 3 moves"
    assert first_mismatch(_case(3), results[:2]) == "2 results for 3 moves"
    assert first_mismatch(_case(3), []) == "0 results for 3 moves"


def test_a_movers_case_needs_every_mover() -> None:
    case = {"movers": [dict(_case(1), id="a"), dict(_case(1), id="b")]}
    one = [copy.deepcopy(EXPECT)]
    assert case_mismatch(case, {"a": one, "b": one}) is None
    assert case_mismatch(case, {"a": one}) is not None
    off = [_with(("position", "origin", 0), 11.0)]
    assert (case_mismatch(case, {"a": one, "b": off}) or "").startswith("mover b: move 0: position")
