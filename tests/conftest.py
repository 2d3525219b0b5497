"""Shared test helpers: where the shared reference material lives."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SHARED = Path(os.environ.get("ACPHYS_SHARED", ROOT.parent / "shared"))
ORACLE = SHARED / "oracle"


@pytest.fixture(scope="session")
def shared_dir() -> Path:
    if not SHARED.is_dir():
        pytest.fail(f"shared reference material not found at {SHARED} (set ACPHYS_SHARED)")
    return SHARED
