"""The compiled engine (mypyc) gives exactly the answers of its pure-Python source.

The installed engine may have its hot modules compiled (see setup.py). This
test replays reference cases in this process and, in a subprocess, from a copy
of the same sources with no compiled modules, and requires identical results.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import engine
import engine.transition.transition as transition_module
from support.shared_data import ORACLE, load_trace, needs_shared, scene_path

ROOT = Path(__file__).resolve().parent.parent
COMPILED = not transition_module.__file__.endswith(".py")

# a few cases of every kind: terrain, indoor, objects, several movers
SAMPLE = {"rolling": 12, "cliff-edgeslide": 4, "house": 8, "objects": 8, "objects-movers": 3, "dungeon": 6}

REPLAY = r"""
import gzip, json, sys
import engine
import engine.transition.transition as t
assert t.__file__.endswith(".py"), t.__file__  # the pure source, not the compiled module
sample = json.loads(sys.argv[1])
out = {}
for name, n in sample.items():
    with gzip.open(f"{sys.argv[2]}/traces/{name}.trace.json.gz", "rt") as f:
        trace = json.load(f)
    world = engine.load_scene(f"{sys.argv[2]}/scenes/{trace['scene']}")
    out[name] = [engine.run_case(world, c) for c in trace["cases"][:n]]
print(json.dumps(out))
"""


def _replay_here() -> dict:
    out = {}
    for name, n in SAMPLE.items():
        trace = load_trace(name)
        world = engine.load_scene(scene_path(trace["scene"]))
        out[name] = [engine.run_case(world, c) for c in trace["cases"][:n]]
    return json.loads(json.dumps(out))


@needs_shared
@pytest.mark.skipif(not COMPILED, reason="this install runs the pure-Python engine (ACPHYS_COMPILE=0): nothing compiled to compare")
def test_compiled_engine_equals_pure_python(tmp_path: Path) -> None:
    pure = tmp_path / "pure"
    shutil.copytree(ROOT / "engine", pure / "engine", ignore=shutil.ignore_patterns("*.so", "__pycache__"))
    proc = subprocess.run(
        [sys.executable, "-c", REPLAY, json.dumps(SAMPLE), str(ORACLE)],
        cwd=pure,
        env={"PYTHONPATH": str(pure), "PATH": "/usr/bin:/bin"},
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert _replay_here() == json.loads(proc.stdout)
