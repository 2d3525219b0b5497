"""The service's own layers, as tests/test_layers.py holds the engine's: the wire's vocabulary at the
bottom (service/protocol/ and the leaf modules it is built on), the core above it (the service's state
and operations, without the bus), the bus on top (zenoh sessions, queryables, workers). Each layer
imports only those below it, and the client library loads nothing of the service but the vocabulary.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SERVICE = ROOT / "service"

#: the wire's vocabulary: declarations, readers and writers, no I/O (docs/architecture.md, "Layers")
VOCABULARY = {"wire", "errors", "validate", "schema", "schema_kinds", "packing", "messages", "codec", "columns", "protocol"}
#: the core: what the service holds and does, run without a bus
CORE = ("service.core", "service.queries", "service.query_columns", "service.column_moves", "service.column_request",
        "service.requests", "service.stats", "service.capabilities")


def _service_imports(path: Path) -> set[str]:
    """The service modules a file imports (their first name under service/), and `zenoh` if it does."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = path.relative_to(ROOT).with_suffix("").parts[:-1]  # ("service",) or ("service", "protocol")
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = list(package[:len(package) - node.level + 1])
                parts = base + (node.module.split(".") if node.module else [])
                if parts == ["service"]:  # `from .. import codec` in service/protocol/: the names are modules
                    out.update(a.name for a in node.names)
                    continue
            else:
                parts = (node.module or "").split(".")
            if parts[0] == "service" and len(parts) > 1:
                out.add(parts[1])
            elif parts[0] == "zenoh":
                out.add("zenoh")
        elif isinstance(node, ast.Import):
            for a in node.names:
                parts = a.name.split(".")
                if parts[0] == "service" and len(parts) > 1:
                    out.add(parts[1])
                elif parts[0] == "zenoh":
                    out.add("zenoh")
    return out


def _vocabulary_files() -> list[Path]:
    files = [SERVICE / f"{name}.py" for name in VOCABULARY if (SERVICE / f"{name}.py").exists()]
    return files + sorted((SERVICE / "protocol").glob("*.py"))


@pytest.mark.parametrize("path", _vocabulary_files(), ids=lambda p: str(p.relative_to(ROOT)))
def test_the_vocabulary_imports_only_the_vocabulary_and_no_bus(path: Path) -> None:
    imports = _service_imports(path)
    assert "zenoh" not in imports
    assert imports <= VOCABULARY, f"{path.relative_to(ROOT)} reaches above the vocabulary: {sorted(imports - VOCABULARY)}"


def test_the_finder_sees_relative_imports() -> None:
    # the check above would pass on a finder that found nothing: it must see what these files plainly import
    assert {"codec", "errors", "validate", "wire"} <= _service_imports(SERVICE / "protocol" / "fields.py")
    assert "protocol" in _service_imports(SERVICE / "queries.py")
    assert "zenoh" in _service_imports(SERVICE / "node.py")


def _loaded(code: str) -> list[str]:
    out = subprocess.run([sys.executable, "-c", code + "\nprint('\\n'.join(sorted(sys.modules)))"], cwd=ROOT,
                         capture_output=True, text=True, timeout=120, check=True)
    return out.stdout.split()


def test_the_core_runs_without_the_bus() -> None:
    loaded = _loaded("import sys\n" + "\n".join(f"import {m}" for m in CORE))
    assert "zenoh" not in loaded
    assert not [m for m in loaded if m in ("service.node", "service.publication", "service.workers", "service.router")]


def test_the_client_library_loads_only_the_vocabulary_of_the_service() -> None:
    loaded = _loaded("import sys\nfrom clients import Client, Move")
    service = {m.split(".")[1] for m in loaded if m.startswith("service.")}
    assert "protocol" in service  # the queries' vocabulary is what the client writes and reads with
    assert service <= VOCABULARY | {"zconfig"}, sorted(service - VOCABULARY)
