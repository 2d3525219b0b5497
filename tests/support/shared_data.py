"""Where the shared reference material lives, and what happens when it is not there.

The material (`shared/oracle`, `shared/dats`) sits beside the checkout as
`../shared`, or where $ACPHYS_SHARED says (then only there). Without it the
tests that read it are skipped, all with the one reason `MISSING_REASON`;
with ACPHYS_REQUIRE_SHARED=1 (CI sets it) the run stops at once with an
error instead, so CI can never pass by skipping them.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import pytest

__all__ = ["MISSING_REASON", "SHARED", "ORACLE", "needs_shared", "require_shared", "require_shared_flag",
           "shared_available", "shared_root", "load_scene_json", "scene_names"]


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


def load_scene_json(name: str) -> dict[str, Any]:
    """`shared/oracle/scenes/<name>.json`."""
    with open(shared_root() / "oracle" / "scenes" / f"{name}.json", encoding="utf-8") as f:
        return json.load(f)


def scene_names() -> list[str]:
    """Every reference scene's name."""
    return sorted(p.stem for p in (shared_root() / "oracle" / "scenes").glob("*.json"))
