"""Where the shared reference material lives, and what happens when it is not there.

The material (`shared/oracle`, `shared/dats`) sits beside the checkout as
`../shared`, or where $ACPHYS_SHARED says (then only there). Without it the
tests that read it are skipped, all with the one reason `MISSING_REASON`;
with ACPHYS_REQUIRE_SHARED=1 (CI sets it) the run stops at once with an
error instead, so CI can never pass by skipping them.
"""

from __future__ import annotations

import gzip
import json
import os
from pathlib import Path
from typing import Any

import pytest

__all__ = ["MISSING_REASON", "SHARED", "ORACLE", "TRACES", "SCENES", "DATS", "needs_shared", "require_shared",
           "require_shared_flag", "shared_available", "shared_root", "load_scene_json", "scene_names",
           "trace_path", "load_trace", "trace_names", "scene_path"]


def _locate() -> Path:
    env = os.environ.get("ACPHYS_SHARED")
    if env:
        return Path(env)
    beside = Path(__file__).resolve().parents[3] / "shared"
    if (beside / "oracle").is_dir() or not Path("/work/shared/oracle").is_dir():
        return beside
    return Path("/work/shared")  # where it lives on the project's machines, for clones made elsewhere


SHARED = _locate()
ORACLE = SHARED / "oracle"
#: the reference traces, `<name>.trace.json.gz`
TRACES = ORACLE / "traces"
#: the reference scenes, `<name>.json`
SCENES = ORACLE / "scenes"
#: three of the scenes as dat directories, `dats/<name>/client_{cell_1,portal}.dat`
DATS = SHARED / "dats"
TRACE_SUFFIX = ".trace.json.gz"
MISSING_REASON = (f"shared reference material not found at {SHARED} (expected ../shared beside the checkout, "
                  "with oracle/ and dats/; set ACPHYS_SHARED=/path/to/shared)")

#: a test that reads the shared material; skipped (one reason) when it is missing
needs_shared = pytest.mark.needs_shared


def shared_available() -> bool:
    return (SHARED / "oracle").is_dir() and (SHARED / "dats").is_dir()


def require_shared_flag() -> bool:
    """ACPHYS_REQUIRE_SHARED=1: a missing shared directory is an error, not a skip (CI)."""
    return os.environ.get("ACPHYS_REQUIRE_SHARED", "") not in ("", "0")


def require_shared() -> None:
    """For modules that read the material while being collected: skip the whole module when it is missing.

    (Under ACPHYS_REQUIRE_SHARED=1 conftest has stopped the run before any module is collected.)"""
    if not shared_available():
        pytest.skip(MISSING_REASON, allow_module_level=True)


def shared_root() -> Path:
    """The shared reference material's directory (it exists when a test gets this far)."""
    if not shared_available():
        pytest.skip(MISSING_REASON)
    return SHARED


def scene_path(name: str) -> Path:
    """`shared/oracle/scenes/<name>` (`name` with or without `.json`, as a trace's `scene` gives it)."""
    return SCENES / (name if name.endswith(".json") else f"{name}.json")


def load_scene_json(name: str) -> dict[str, Any]:
    """`shared/oracle/scenes/<name>.json`."""
    shared_root()
    with open(scene_path(name), encoding="utf-8") as f:
        return json.load(f)


def scene_names() -> list[str]:
    """Every reference scene's name."""
    shared_root()
    return sorted(p.stem for p in SCENES.glob("*.json"))


def trace_path(name: str) -> Path:
    """`shared/oracle/traces/<name>.trace.json.gz`."""
    return TRACES / f"{name}{TRACE_SUFFIX}"


def load_trace(name: str) -> dict[str, Any]:
    """The reference trace `name` (an `acphys-trace/1` document)."""
    shared_root()
    with gzip.open(trace_path(name), "rt", encoding="utf-8") as f:
        return json.load(f)


def trace_names() -> list[str]:
    """Every reference trace's name, found by listing the directory (a new trace is replayed at once)."""
    shared_root()
    return sorted(p.name[: -len(TRACE_SUFFIX)] for p in TRACES.glob(f"*{TRACE_SUFFIX}"))
