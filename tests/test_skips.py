"""The engine's skips of needless work leave every answer unchanged."""

from __future__ import annotations

import dataclasses

import pytest

import engine
from support.shared_data import load_trace, needs_shared, scene_path

SKIPS = [f.name for f in dataclasses.fields(engine.EngineSettings) if f.name.startswith("skip_")]


def test_there_are_skips_to_check() -> None:
    assert set(SKIPS) >= {"skip_far_cells", "skip_repeat_spheres"}


@needs_shared
@pytest.mark.parametrize("name", ["rolling", "cliff-edgeslide", "water", "house", "objects-movers"])
def test_switching_every_skip_off_changes_no_answer(name: str) -> None:
    trace = load_trace(name)
    world = engine.load_scene(scene_path(trace["scene"]))
    all_off = dataclasses.replace(engine.ACE_COMPAT, **{s: False for s in SKIPS})
    assert all_off != engine.ACE_COMPAT
    for case in trace["cases"][:12]:
        assert engine.run_case(world, case, settings=all_off) == engine.run_case(world, case), case["id"]
