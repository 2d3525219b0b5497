"""The `acphys` command line, run as a user would (a subprocess)."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import zlib
from collections.abc import Iterator
from pathlib import Path

import pytest

from service_support import ROOT, ServiceProcess, child_env, endpoint, free_port


def acphys(*args: str, timeout: float = 120.0) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "clients.cli", *args], cwd=ROOT, env=child_env(),
                          capture_output=True, text=True, timeout=timeout)


@pytest.fixture(scope="module")
def service() -> Iterator[ServiceProcess]:
    with ServiceProcess() as svc:
        yield svc


def _png_size(data: bytes) -> tuple[int, int]:
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    assert data[12:16] == b"IHDR"
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


def test_move_with_a_temporary_mover(service: ServiceProcess) -> None:
    r = acphys("move", "--connect", service.endpoint, "--start", "A9B40001", "20", "20", "60",
               "--motion", "0", "0", "0", "--dt", "0.2")
    assert r.returncode == 0, r.stderr
    assert "transition" in r.stdout and "A9B40001" in r.stdout
    r = acphys("move", "--connect", service.endpoint, "--start", "A9B40001", "20", "20", "60",
               "--offset", "1", "0", "0", "--json")
    assert r.returncode == 0, r.stderr
    state = json.loads(r.stdout)
    assert state["ok"] is True and state["position"]["origin"][0] == pytest.approx(21.0)


def test_move_reports_service_errors(service: ServiceProcess) -> None:
    r = acphys("move", "--connect", service.endpoint, "--start", "A9B40123", "20", "20", "60",
               "--offset", "1", "0", "0")
    assert r.returncode == 1
    assert "unknown_cell" in r.stderr


def test_stats(service: ServiceProcess) -> None:
    r = acphys("stats", "--connect", service.endpoint)
    assert r.returncode == 0, r.stderr
    assert "instance" in r.stdout and "latency (ms)" in r.stdout and "A9B4" in r.stdout
    r = acphys("stats", "--connect", service.endpoint, "--json")
    (stats,) = json.loads(r.stdout)
    assert stats["loaded_landblocks"] == [0xA9B4, 0xA9B5, 0xAAB4, 0xAAB5]


def test_stats_without_a_service_fails_clearly() -> None:
    r = acphys("stats", "--connect", endpoint(free_port()), "--timeout", "1")
    assert r.returncode == 1 and "no service" in r.stderr


def test_demo_against_a_running_service(service: ServiceProcess, tmp_path: Path) -> None:
    out = tmp_path / "walk.png"
    r = acphys("demo", "--connect", service.endpoint, "--out", str(out), "--quiet")
    assert r.returncode == 0, r.stderr
    assert "using the running service" in r.stderr
    assert _png_size(out.read_bytes()) == (768, 768)
    lines = r.stdout.splitlines()
    face = next(ln for ln in lines if ln.startswith("into the mesa's west face"))
    assert "blocked" in face  # the slope it cannot climb
    ramp = next(ln for ln in lines if ln.startswith("up the ramp onto the mesa"))
    assert "arrived" in ramp
    assert any("off the north ledge: left the ground" in ln for ln in lines)


def test_demo_embedded(tmp_path: Path) -> None:
    out = tmp_path / "walk.png"
    r = acphys("demo", "--embedded", "--out", str(out))
    assert r.returncode == 0, r.stderr
    assert "walking" in r.stderr  # progress
    data = out.read_bytes()
    assert _png_size(data) == (768, 768)
    # the image data inflates to 768 rows of 1 + 768 * 3 bytes
    idat = data[data.index(b"IDAT") + 4:data.index(b"IEND") - 8]
    assert len(zlib.decompress(idat)) == 768 * (1 + 768 * 3)


def test_serve_defaults_to_the_demo_world_and_stops_on_sigterm() -> None:
    ep = endpoint(free_port())
    proc = subprocess.Popen([sys.executable, "-m", "clients.cli", "serve", "--listen", ep, "--log-level", "WARNING"],
                            cwd=ROOT, env=child_env(), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()
        assert "acphys service ready" in line, line
        r = acphys("stats", "--connect", ep, "--json")
        assert json.loads(r.stdout)[0]["loaded_landblocks"] == [0xA9B4, 0xA9B5, 0xAAB4, 0xAAB5]
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(20) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(10)


def test_serve_with_a_missing_scene_fails() -> None:
    r = acphys("serve", "--scene", "/nonexistent/scene.json", "--listen", endpoint(free_port()))
    assert r.returncode == 2 and "cannot open the world" in r.stderr


def test_move_an_existing_mover_by_id(service: ServiceProcess) -> None:
    from clients import Client
    from clients.demo_world import global_to_cell
    from engine.geometry import Position, Vec3
    from service_support import human

    with Client([service.endpoint]) as c:
        cell, x, y = global_to_cell(100.0, 100.0)
        st = c.register(human(), Position.at(cell, Vec3(x, y, 60.0)))
        # no --landblock: the command finds the mover by asking every instance
        r = acphys("move", "--connect", service.endpoint, "--id", f"{st.id:X}", "--to", f"{x + 1}", f"{y}", "60",
                   "--json")
        assert r.returncode == 0, r.stderr
        state = json.loads(r.stdout)
        assert state["id"] == st.id and state["seq"] == 1 and state["position"]["cell"] == cell
        c.remove(st.id)
