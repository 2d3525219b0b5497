"""The `acphys` command line, run as a user would (a subprocess)."""

from __future__ import annotations

import json
import re
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from clients.demo.walk import LEGS
from clients.demo.command import _estimated_steps
from support.service_harness import ROOT, ServiceProcess, child_env, endpoint, free_port


def acphys(*args: str, timeout: float = 120.0) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "clients", *args], cwd=ROOT, env=child_env(),
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
    assert state["position"]["origin"][2] == pytest.approx(60.0)  # --offset moves it where it was put


def _terrain(x: float, y: float) -> float:
    from clients.demo.world import demo_scene_path
    from engine import load_scene

    return load_scene(str(demo_scene_path())).terrain_height(0xA9B40001, x, y)


def test_move_start_with_motion_stands_the_mover_on_the_ground_and_the_step_moves_it(service: ServiceProcess) -> None:
    r = acphys("move", "--connect", service.endpoint, "--start", "A9B40001", "20", "20", "60",
               "--motion", "0", "4", "0", "--dt", "0.2", "--json")
    assert r.returncode == 0, r.stderr
    ground = _terrain(20.0, 20.0)
    placed = next(ln for ln in r.stderr.splitlines() if ln.startswith("placed on the ground at"))
    z_placed = float(placed.split("(")[1].split(")")[0].split(",")[2])
    assert z_placed == pytest.approx(ground, abs=0.05)  # on the terrain, 15 m below the start
    state = json.loads(r.stdout)  # --json prints the State map as before
    assert set(state) >= {"id", "seq", "ok", "position", "contact", "on_walkable", "contact_plane"}
    x, y, z = state["position"]["origin"]
    assert state["contact"] is True and state["on_walkable"] is True
    assert abs(x - 20.0) < 0.5 and y > 21.0  # it walked north (+y), as the motion said
    assert z == pytest.approx(_terrain(x, y), abs=0.05)  # and is still on the ground


def test_move_and_stats_say_which_service_answered(service: ServiceProcess) -> None:
    (health,) = json.loads(acphys("stats", "--connect", service.endpoint, "--json").stdout)
    for args in (["move", "--start", "A9B40001", "20", "20", "60", "--offset", "1", "0", "0"], ["stats"]):
        r = acphys(*args, "--connect", service.endpoint)
        assert r.returncode == 0, r.stderr
        assert f"service: instance {health['instance']} via {service.endpoint}, prefix 'acphys'" in r.stderr


def test_the_default_endpoint_is_called_shared() -> None:
    from clients.cli.which_service import describe_service

    line = describe_service(["abc"], None, "acphys")
    assert line.startswith("service: instance abc via tcp/127.0.0.1:7447, prefix 'acphys'")
    assert "shared by every user" in line and "--connect" in line and "--prefix" in line
    assert "shared" not in describe_service(["abc"], None, "mine")
    # no instance heard yet (the live map starts before the service): said so, not as an instance called "?"
    none = describe_service([], ["tcp/127.0.0.1:7500"], "mine")
    assert none == "service: no instance answered yet via tcp/127.0.0.1:7500, prefix 'mine'"
    assert describe_service(["a", "b"], None, "mine").startswith("service: instances a, b via")


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


def _service_line(stderr: str) -> str:
    return next(ln for ln in stderr.splitlines() if ln.startswith("service: "))


def test_demo_against_a_running_service(service: ServiceProcess, tmp_path: Path) -> None:
    out = tmp_path / "walk.png"
    r = acphys("demo", "--connect", service.endpoint, "--out", str(out), "--quiet")
    assert r.returncode == 0, r.stderr
    assert "using the running service" in r.stderr
    (health,) = json.loads(acphys("stats", "--connect", service.endpoint, "--json").stdout)
    line = _service_line(r.stderr)
    assert f"instance {health['instance']} via {service.endpoint}, prefix 'acphys'" in line
    assert "shared by every user" not in line  # an endpoint of its own was given
    assert _png_size(out.read_bytes()) == (2000, 1400)
    lines = r.stdout.splitlines()
    face = next(ln for ln in lines if "into the mesa's west face " in ln and ln[:2].strip().isdigit())
    assert "blocked" in face  # the slope it cannot climb
    ramp = next(ln for ln in lines if "up the ramp onto the mesa " in ln and ln[:2].strip().isdigit())
    assert "arrived" in ramp
    assert any("off the north ledge: left the ground" in ln for ln in lines)
    # the table's steps add up to its total, which is the summary's count
    rows = [ln for ln in lines if (ln[:2].strip() == "-" or ln[:2].strip().isdigit()) and ln[2] == " "]
    # the landing, then each of the demo's legs (13: the path into the house is one leg walked by moves)
    assert [ln[:2].strip() for ln in rows] == ["-", *(str(n) for n in range(1, len(LEGS) + 1))]
    total = int(next(ln for ln in lines if ln.startswith("total")).split()[1])
    assert sum(int(ln[30:37]) for ln in rows) == total
    # the summary counts the physics steps and the path leg's moves apart; together they are the total
    summary = next(ln for ln in lines if " physics steps of 0.2 s and " in ln)
    steps, moves = int(summary.split()[0]), int(summary.split(" and ")[1].split()[0])
    assert steps + moves == total and moves > 0


def test_demo_embedded(tmp_path: Path) -> None:
    out = tmp_path / "walk.png"
    r = acphys("demo", "--embedded", "--out", str(out))
    assert r.returncode == 0, r.stderr
    # the progress bar (tqdm, redrawn with \r): an estimate while walking, the real count at the end
    progress = [part for part in re.split(r"[\r\n]", r.stderr) if part.startswith("walking")]
    total = int(next(ln for ln in r.stdout.splitlines() if ln.startswith("total")).split()[1])
    assert f" 0/{_estimated_steps()} " in progress[0]  # the first draw's total is the estimate
    assert f" {total}/{total} " in progress[-1] and "100%" in progress[-1]
    line = _service_line(r.stderr)
    assert line.startswith("service: embedded instance ") and " on tcp/127.0.0.1:" in line
    assert _png_size(out.read_bytes()) == (2000, 1400)


def test_serve_defaults_to_the_demo_world_and_stops_on_sigterm() -> None:
    ep = endpoint(free_port())
    proc = subprocess.Popen([sys.executable, "-m", "clients", "serve", "--listen", ep, "--log-level", "WARNING"],
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
    from clients.demo.world import global_to_cell
    from engine.geometry import Position, Vec3
    from support.service_harness import human

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
