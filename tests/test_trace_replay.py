"""Every move of the shared reference traces, replayed and compared.

The reference is ACE's own physics (float32) on generated scenes. The test
covers every shared trace: terrain, indoor cells and buildings, static
objects, cameras, placement, missiles, edge slides, ethereal movers and
cases with several live movers.

Every case agrees today. A case found to disagree goes into KNOWN_DIVERGENT
as a strict expected failure, with what is known of why, so a fix shows up
at once.
"""

from __future__ import annotations

import gzip
import json

import pytest

import engine
from replay_check import case_mismatch, first_mismatch
from support.shared_data import ORACLE, require_shared

require_shared()  # the cases are read from the traces while collecting

TRACES = [
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
]

#: Cases that disagree with the reference today, with what we know of why.
KNOWN_DIVERGENT: dict[str, str] = {}


#: `ace-viewer-outdoor` cases record a bug of the reference (an outdoor camera
#: never moves). They are not targets (the engine's default is the retail
#: camera, see test_scenarios), but ACE_COMPAT reproduces the bug: every one
#: agrees with it. A case that stops agreeing goes here as a strict xfail.
KNOWN_DIVERGENT_ACE_VIEWER: dict[str, str] = {}


def _cases(ace_viewer_outdoor: bool = False) -> list:
    params = []
    known = KNOWN_DIVERGENT_ACE_VIEWER if ace_viewer_outdoor else KNOWN_DIVERGENT
    for name in TRACES:
        with gzip.open(ORACLE / "traces" / f"{name}.trace.json.gz", "rt") as f:
            trace = json.load(f)
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
        _worlds[scene_name] = engine.load_scene(ORACLE / "scenes" / scene_name)
    return _worlds[scene_name]


def test_the_traces_are_all_there() -> None:
    total = sum(
        sum(len(m["moves"]) for m in p.values[1]["movers"]) if "movers" in p.values[1] else len(p.values[1]["moves"])
        for p in CASES
    )
    assert total > 60000


@pytest.mark.parametrize(("scene", "case"), CASES)
def test_case_agrees_with_reference(scene: str, case: dict) -> None:
    problem = case_mismatch(case, engine.run_case(_world(scene), case))
    assert problem is None, problem


@pytest.mark.parametrize(("scene", "case"), ACE_VIEWER_CASES)
def test_the_reference_setting_reproduces_its_outdoor_camera(scene: str, case: dict) -> None:
    assert "IsViewer" in case["object"]["state"]
    problem = first_mismatch(case, engine.run_case(_world(scene), case, settings=engine.ACE_COMPAT))
    assert problem is None, problem
