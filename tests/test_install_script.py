"""install.sh, the README's first step: pip runs once, then never again until something changes.

The virtual environment here is a stand-in (ACPHYS_VENV): its `bin/python` is a
script that records how it was called, so the test sees every pip run
without installing anything.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

from support.service_harness import ROOT

pytestmark = pytest.mark.skipif(shutil.which("sh") is None, reason="no POSIX shell")


def _venv(tmp_path: Path) -> tuple[Path, Path]:
    venv = tmp_path / "venv"
    (venv / "bin").mkdir(parents=True)
    log = tmp_path / "calls.log"
    python = venv / "bin" / "python"
    python.write_text(f'#!/bin/sh\necho "ACPHYS_COMPILE=$ACPHYS_COMPILE $*" >> "{log}"\nexit 0\n')
    python.chmod(0o755)
    return venv, log


def _install(venv: Path, compile_: str | None = None) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != "ACPHYS_COMPILE"}
    env["ACPHYS_VENV"] = str(venv)
    if compile_ is not None:
        env["ACPHYS_COMPILE"] = compile_
    return subprocess.run(["sh", str(ROOT / "install.sh")], env=env, capture_output=True, text=True, timeout=60)


def _pip_runs(log: Path) -> list[str]:
    if not log.exists():
        return []
    return [ln for ln in log.read_text().splitlines() if " -m pip install " in ln]


def test_pip_runs_once_then_the_command_goes_straight_on(tmp_path: Path) -> None:
    venv, log = _venv(tmp_path)
    first = _install(venv)
    assert first.returncode == 0, first.stderr
    (run,) = _pip_runs(log)
    assert run.endswith("-e .[test,demo,view]")
    compiled = run.startswith("ACPHYS_COMPILE=1 ")
    if compiled:  # says what takes the time before pip starts
        assert "compiling the engine's hot modules with mypyc" in first.stderr and "minutes" in first.stderr
    else:  # no compiler here: it says so
        assert "pure-Python engine" in first.stderr
    again = _install(venv)
    assert again.returncode == 0 and again.stderr == ""
    assert len(_pip_runs(log)) == 1  # nothing reinstalled


def test_switching_to_the_pure_engine_reinstalls_once_and_sticks(tmp_path: Path) -> None:
    venv, log = _venv(tmp_path)
    assert _install(venv, "0").returncode == 0
    assert _install(venv).returncode == 0  # no ACPHYS_COMPILE: keeps the pure engine, no reinstall
    runs = _pip_runs(log)
    assert len(runs) == 1 and runs[0].startswith("ACPHYS_COMPILE=0 ")
    assert _install(venv, "0").returncode == 0
    assert len(_pip_runs(log)) == 1


def test_a_failed_install_is_tried_again(tmp_path: Path) -> None:
    venv, log = _venv(tmp_path)
    python = venv / "bin" / "python"
    python.write_text(python.read_text().replace("exit 0", 'case "$*" in *pip*) exit 1;; esac\nexit 0'))
    assert _install(venv).returncode != 0
    python.write_text(python.read_text().replace('case "$*" in *pip*) exit 1;; esac\n', ""))
    assert _install(venv).returncode == 0
    assert len(_pip_runs(log)) == 2  # no stamp was left by the failed run
