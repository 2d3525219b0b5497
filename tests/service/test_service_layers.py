"""The service's and the client package's own layers, as tests/test_layers.py holds the engine's.

The service, bottom up (docs/architecture.md, "Layers"):
1. the vocabulary, service/protocol/: declarations, readers and writers, no zenoh, no I/O;
2. the state log's framing and records (persistence/journal.py, journal_records.py): the core writes them;
3. the core, service/*.py: what the service holds and does, run without a bus;
4. what sits on the core without being the bus: the start and the saves (the rest of persistence/), TLS,
   accounts and access control (security/);
5. the bus, service/bus/: zenoh sessions, queryables, publication;
6. scale-out, service/scaleout/: `--workers`, one face over several engine processes;
7. the entry, service/main.py and __main__.py.

The client package, bottom up: the library (clients/*.py), the command line's machinery and plain
commands (cli/), the demo (demo/), the live map (view/), the `acphys` entry (clients/__main__.py). Each
file imports only files of its own floor or below, and the library loads nothing of the service but the
vocabulary (the commands may run a service: `acphys serve`, or an embedded one for the demo).
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SERVICE = ROOT / "service"
CLIENTS = ROOT / "clients"

_LOG = {"service.persistence.journal", "service.persistence.journal_records"}
_ENTRY = {"service.main", "service.__main__"}
#: the floors that may open a zenoh session or read its configuration
_ZENOH_FLOORS = {4, 5, 6, 7}


def _module(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def service_floor(module: str) -> int:
    """The floor of a service module (the list in this file's docstring)."""
    parts = module.split(".")
    room = parts[1] if len(parts) > 2 else None
    if module in _ENTRY:
        return 7
    if module in _LOG:
        return 2
    if room is None:
        # service/protocol/__init__.py is the vocabulary's face; a plain service/*.py file is the core
        return {"service": 3, "service.protocol": 1, "service.persistence": 2, "service.security": 4,
                "service.bus": 5, "service.scaleout": 6}.get(module, 3)
    return {"protocol": 1, "persistence": 4, "security": 4, "bus": 5, "scaleout": 6}[room]


def clients_floor(module: str) -> int:
    parts = module.split(".")
    if module == "clients.__main__":
        return 5
    if len(parts) == 2 and parts[1] in ("cli", "demo", "view"):
        parts = parts + ["__init__"]
    return {"cli": 2, "demo": 3, "view": 4}.get(parts[1], 1) if len(parts) > 2 else 1


def imports_of(path: Path) -> set[str]:
    """The dotted modules a file imports (relative imports made absolute; `from P import m` counted as P.m
    when P.m is a file), including imports inside functions."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = _module(path).split(".")
    if path.name != "__init__.py":
        package = package[:-1]
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            base = package[:len(package) - node.level + 1] if node.level else []
            module = ".".join(base + ([node.module] if node.module else []))
            out.add(module)
            for alias in node.names:
                candidate = ROOT.joinpath(*f"{module}.{alias.name}".split("."))
                if candidate.with_suffix(".py").exists() or (candidate / "__init__.py").exists():
                    out.add(f"{module}.{alias.name}")
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
    return out


def _files(top: Path) -> list[Path]:
    return sorted(top.rglob("*.py"))


def _rel(p: Path) -> str:
    return str(p.relative_to(ROOT))


@pytest.mark.parametrize("path", _files(SERVICE), ids=_rel)
def test_each_service_file_imports_only_its_floor_and_below(path: Path) -> None:
    floor = service_floor(_module(path))
    imported = imports_of(path)
    above = sorted(m for m in imported if m.startswith("service.") and service_floor(m) > floor)
    assert not above, f"{_rel(path)} (floor {floor}) reaches up to {above}"
    assert not any(m.startswith("clients") for m in imported), f"{_rel(path)} imports the client package"
    if floor not in _ZENOH_FLOORS:
        assert "zenoh" not in imported, f"{_rel(path)} (floor {floor}) imports zenoh"


@pytest.mark.parametrize("path", _files(CLIENTS), ids=_rel)
def test_each_client_file_imports_only_its_floor_and_below(path: Path) -> None:
    floor = clients_floor(_module(path))
    imported = imports_of(path)
    above = sorted(m for m in imported if m.startswith("clients.") and clients_floor(m) > floor)
    assert not above, f"{_rel(path)} (floor {floor}) reaches up to {above}"
    if floor == 1:  # the library; the commands may start a service (`acphys serve`, an embedded one)
        beyond = sorted(m for m in imported if m.startswith("service.") and service_floor(m) != 1
                        and m != "service.bus.zconfig")
        assert not beyond, f"{_rel(path)} uses the service beyond its vocabulary: {beyond}"


def test_the_floors_are_what_the_rooms_say() -> None:
    # the checks above would pass if every module sat on one floor: these must not
    assert service_floor("service.protocol.wire") == 1 and service_floor("service.protocol") == 1
    assert service_floor("service.persistence.journal") == 2
    assert service_floor("service.core") == 3 and service_floor("service.column_moves") == 3
    assert service_floor("service.persistence.state_file") == 4 and service_floor("service.security.cluster") == 4
    assert service_floor("service.bus.node") == 5 and service_floor("service.scaleout.workers") == 6
    assert service_floor("service.main") == 7
    assert clients_floor("clients.client") == 1 and clients_floor("clients.cli.connection") == 2
    assert clients_floor("clients.demo.walk") == 3 and clients_floor("clients.view.server") == 4
    assert clients_floor("clients.__main__") == 5


def test_the_finder_sees_what_files_plainly_import() -> None:
    fields = imports_of(SERVICE / "protocol" / "fields.py")
    assert {"service.protocol.codec", "service.protocol.errors", "service.protocol.wire"} <= fields
    assert "service.protocol" in imports_of(SERVICE / "queries.py")
    assert "zenoh" in imports_of(SERVICE / "bus" / "node.py")
    # `from service import heap`: the module, not only the package
    assert "service.heap" in imports_of(SERVICE / "bus" / "node.py")


def _loaded(code: str) -> list[str]:
    out = subprocess.run([sys.executable, "-c", code + "\nprint('\\n'.join(sorted(sys.modules)))"], cwd=ROOT,
                         capture_output=True, text=True, timeout=120, check=True)
    return out.stdout.split()


def test_the_core_runs_without_the_bus() -> None:
    core = [_module(p) for p in _files(SERVICE) if service_floor(_module(p)) <= 3]
    assert "service.core" in core and "service.column_moves" in core
    loaded = _loaded("import sys\n" + "\n".join(f"import {m}" for m in core))
    assert "zenoh" not in loaded
    assert not [m for m in loaded if m.startswith("service.") and service_floor(m) > 3]


def test_the_client_library_loads_only_the_vocabulary_of_the_service() -> None:
    loaded = _loaded("import sys\nfrom clients import Client, Move")
    service = {m for m in loaded if m.startswith("service.")}
    assert "service.protocol" in service  # the queries' vocabulary is what the client writes and reads with
    assert {m for m in service if service_floor(m) != 1} <= {"service.bus", "service.bus.zconfig"}
    assert not [m for m in loaded if m.startswith(("clients.cli.", "clients.demo.", "clients.view."))]
