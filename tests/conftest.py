"""Shared test set-up: where the shared reference material lives, and skipping without it.

Tests that read `../shared` carry the `needs_shared` mark (or skip their whole
module with `require_shared()`); without the material they are skipped with
one reason, said once more at the end of the run. ACPHYS_REQUIRE_SHARED=1
(set by CI) turns a missing directory into an immediate failure.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from support.shared_data import MISSING_REASON, ORACLE, SHARED, require_shared_flag, shared_available

__all__ = ["ORACLE", "SHARED"]

ROOT = Path(__file__).resolve().parent.parent


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "needs_shared: reads the shared reference material (../shared)")
    if not shared_available() and require_shared_flag():
        raise pytest.UsageError(f"{MISSING_REASON}; ACPHYS_REQUIRE_SHARED is set, so this is an error, not a skip")


def pytest_report_header(config: pytest.Config) -> str:
    if shared_available():
        return f"shared reference material: {SHARED}"
    return f"shared reference material: MISSING: the tests that need it are skipped: {MISSING_REASON}"


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if shared_available():
        return
    skip = pytest.mark.skip(reason=MISSING_REASON)
    for item in items:
        if item.get_closest_marker("needs_shared") is not None:
            item.add_marker(skip)


@pytest.fixture(scope="session")
def shared_dir() -> Path:
    if not shared_available():
        pytest.skip(MISSING_REASON)
    return SHARED


def pytest_terminal_summary(terminalreporter: object, exitstatus: int, config: pytest.Config) -> None:
    if shared_available():
        return
    skipped = [r for r in getattr(terminalreporter, "stats", {}).get("skipped", [])
               if MISSING_REASON in str(getattr(r, "longrepr", ""))]
    tests = sum(1 for r in skipped if "::" in getattr(r, "nodeid", ""))
    modules = len(skipped) - tests  # skipped while being collected: every test in them
    write = terminalreporter.write_line
    write(f"skipped {tests} tests and {modules} whole test modules: {MISSING_REASON}", yellow=True)
