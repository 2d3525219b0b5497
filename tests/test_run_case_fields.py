"""`run_case` reports the fields of each move's `expect`, and every field for a move without one."""

from __future__ import annotations

import copy

import engine
from engine.formats.trace import EXPECT_FIELDS
from support.replay_tolerances import first_mismatch
from support.shared_data import load_trace, needs_shared, scene_path

pytestmark = needs_shared


def _case(trace: str, index: int = 0) -> dict:
    return load_trace(trace)["cases"][index]


def test_a_case_without_expect_reports_every_field_and_they_agree_with_the_reference() -> None:
    case = _case("house")
    bare = copy.deepcopy(case)
    for move in bare["moves"]:
        del move["expect"]
    got = engine.run_case(engine.load_scene(scene_path("house")), bare)
    assert len(got) == len(case["moves"])
    for result in got:
        assert set(result) == set(EXPECT_FIELDS)
    # what the reference recorded for these moves, field by field, is what the bare replay reports
    assert first_mismatch(case, [{k: r[k] for k in m["expect"]} for m, r in zip(case["moves"], got)]) is None
    assert any(set(m["expect"]) < set(EXPECT_FIELDS) for m in case["moves"])  # so the bare replay reported more


def test_a_case_with_expect_reports_exactly_its_fields() -> None:
    case = _case("flat")
    got = engine.run_case(engine.load_scene(scene_path("flat")), case)
    assert [set(r) for r in got] == [set(m["expect"]) for m in case["moves"]]
