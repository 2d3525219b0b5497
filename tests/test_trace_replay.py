"""Every move of every shared reference trace, replayed and compared.

The reference is ACE's own physics (float32) on generated scenes. The traces
are found by listing `shared/oracle/traces`, so a trace added there is
replayed at once; `NAMED_TRACES` lists the ones there today, and a test
fails if any of them goes missing or holds fewer moves than it does today.
They cover terrain, indoor cells and buildings, static objects, cameras,
placement, missiles, edge slides, ethereal movers, cases with several live
movers, and the second set (`*-2`): doorway corners, long indoor walks, big
and tiny missiles, half-step step-downs, jumps into ceilings.

Every case agrees today (the tolerances of tests/support/replay_tolerances.py). A case found to
disagree goes into KNOWN_DIVERGENT as a strict expected failure, with what
is known of why, so a fix shows up at once.
"""

from __future__ import annotations

import pytest

import engine
from support.replay_tolerances import case_mismatch, first_mismatch
from support.shared_data import load_trace, require_shared, scene_path, trace_names

require_shared()  # the cases are read from the traces while collecting

#: The traces in the shared directory today, by kind. Each must stay there.
NAMED_TRACES = [
    # terrain
    "flat", "rolling", "steep", "cliff", "water",
    "cliff-viewer", "rolling-viewer", "steep-viewer",
    "cliff-longmove", "rolling-longmove", "steep-longmove",
    "cliff-missile", "rolling-missile", "steep-missile",
    "cliff-edgeslide",
    # indoor cells and buildings
    "house", "interior", "cellar",
    "house-viewer", "interior-viewer", "cellar-viewer",
    "house-missile", "house-ethereal", "interior-ethereal",
    "dungeon", "dungeon-viewer",
    # static objects: rocks, platform, roof box, pillar, sphere cluster
    "objects", "objects-missile", "objects-edgeslide", "objects-ethereal",
    # placement (entering the world, teleports)
    "rolling-placement", "steep-placement", "cliff-placement",
    "house-placement", "interior-placement", "cellar-placement",
    "dungeon-placement", "objects-placement",
    # several live movers in lockstep
    "house-movers", "interior-movers", "rolling-movers", "objects-movers",
    # the second set: doorway corners, long indoor walks, big and tiny missiles,
    # step-downs deeper than the spheres (the half-step split), jumps into a ceiling
    "dungeon-doorcorner-2", "house-doorcorner-2",
    "cellar-walk-2", "dungeon-walk-2", "house-walk-2", "interior-walk-2",
    "cliff-missile-2", "dungeon-missile-2", "house-missile-2", "rolling-missile-2",
    "cellar-halfstep-2", "cliff-halfstep-2", "interior-halfstep-2", "rolling-halfstep-2",
    "cellar-stepdown-2", "cliff-stepdown-2", "interior-stepdown-2",
    "dungeon-jump-2", "house-jump-2",
]

#: The moves the named traces hold today (every mover's, every case's): a
#: trace replaced by a shorter one fails test_the_named_traces_hold_their_moves.
NAMED_TRACES_MOVES = 100429

#: Every trace in the directory: the named ones and any added since.
TRACE_NAMES = trace_names()

#: Cases that disagree with the reference today, with what we know of why.
KNOWN_DIVERGENT: dict[str, str] = {}


#: `ace-viewer-outdoor` cases record a bug of the reference (an outdoor camera
#: never moves). They are not targets (the engine's default is the retail
#: camera, see test_scenarios), but ACE_COMPAT reproduces the bug: every one
#: agrees with it. A case that stops agreeing goes here as a strict xfail.
KNOWN_DIVERGENT_ACE_VIEWER: dict[str, str] = {}


def case_moves(case: dict) -> int:
    """The moves of one case: its own, or every mover's."""
    if "movers" in case:
        return sum(len(m["moves"]) for m in case["movers"])
    return len(case["moves"])


def _cases(ace_viewer_outdoor: bool = False) -> list:
    params = []
    known = KNOWN_DIVERGENT_ACE_VIEWER if ace_viewer_outdoor else KNOWN_DIVERGENT
    for name in TRACE_NAMES:
        trace = load_trace(name)
        for case in trace["cases"]:
            if ("ace-viewer-outdoor" in case.get("tags", [])) != ace_viewer_outdoor:
                continue
            marks = []
            if case["id"] in known:
                marks.append(pytest.mark.xfail(reason=known[case["id"]], strict=True))
            params.append(pytest.param(trace["scene"], case, id=case["id"], marks=marks))
    return params


CASES = _cases()
ACE_VIEWER_CASES = _cases(ace_viewer_outdoor=True)
_worlds: dict[str, engine.World] = {}


def _world(scene_name: str) -> engine.World:
    if scene_name not in _worlds:
        _worlds[scene_name] = engine.load_scene(scene_path(scene_name))
    return _worlds[scene_name]


def test_every_named_trace_is_there() -> None:
    assert len(NAMED_TRACES) == len(set(NAMED_TRACES)) == 61
    assert [n for n in NAMED_TRACES if n not in TRACE_NAMES] == []
    # the second set is named in full: every `*-2` trace in the directory is one of them
    assert sorted(n for n in TRACE_NAMES if n.endswith("-2")) == sorted(n for n in NAMED_TRACES if n.endswith("-2"))


def test_the_named_traces_hold_their_moves() -> None:
    assert sum(case_moves(c) for name in NAMED_TRACES for c in load_trace(name)["cases"]) == NAMED_TRACES_MOVES


def test_every_move_in_the_files_is_replayed() -> None:
    in_files = sum(case_moves(c) for name in TRACE_NAMES for c in load_trace(name)["cases"])
    replayed = sum(case_moves(p.values[1]) for p in CASES + ACE_VIEWER_CASES)
    assert replayed == in_files >= NAMED_TRACES_MOVES
    ids = [p.id for p in CASES + ACE_VIEWER_CASES]
    assert len(ids) == len(set(ids))  # one test per case: no two traces share a case id
    assert set(KNOWN_DIVERGENT) <= set(ids) and set(KNOWN_DIVERGENT_ACE_VIEWER) <= set(ids)


@pytest.mark.parametrize(("scene", "case"), CASES)
def test_case_agrees_with_reference(scene: str, case: dict) -> None:
    problem = case_mismatch(case, engine.run_case(_world(scene), case))
    assert problem is None, problem


@pytest.mark.parametrize(("scene", "case"), ACE_VIEWER_CASES)
def test_the_reference_setting_reproduces_its_outdoor_camera(scene: str, case: dict) -> None:
    assert "IsViewer" in case["object"]["state"]
    problem = first_mismatch(case, engine.run_case(_world(scene), case, settings=engine.ACE_COMPAT))
    assert problem is None, problem
