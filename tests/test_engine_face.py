"""The engine's public face: the service, the clients and the benchmarks import only `engine` and
the modules it names public (engine.PUBLIC_MODULES), and from `engine` itself only the names in its
`__all__`. The tests may import anything; a few benchmarks that measure the engine's insides are
listed below, each with its reason.

The imports are read from the sources with `ast` (nothing is imported): module-level ones, those in
functions, and those under `if TYPE_CHECKING:` alike (an annotation names the face too).
"""

from __future__ import annotations

import ast
from pathlib import Path

import engine

ROOT = Path(__file__).resolve().parent.parent
#: the code outside the engine that uses it (benchmarks/out/ holds built copies of the engine: not ours)
USERS = ("service", "clients", "benchmarks")

#: benchmarks that measure the engine's insides, and why they must reach them
INSIDE_BENCHMARKS = {
    "benchmarks/bench_navigation.py": "times the A* search (engine.navigation.search) against rustworkx's on the "
                                      "navigation graph, and the walk probes the graph is built from",
    "benchmarks/stress_checks.py": "checks each stress move against the terrain's own water depth "
                                   "(engine.terrain.water)",
}


def _imports(tree: ast.AST) -> list[tuple[str, list[str], int]]:
    """(module, names imported from it, line) of every absolute import of the engine in a tree;
    `import engine.x` gives (engine.x, [], line)."""
    found: list[tuple[str, list[str], int]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(a.name, [], node.lineno) for a in node.names if a.name.split(".")[0] == "engine"]
        elif isinstance(node, ast.ImportFrom) and not node.level and (node.module or "").split(".")[0] == "engine":
            found.append((node.module or "", [a.name for a in node.names], node.lineno))
    return found


def _violations(tree: ast.AST, public: tuple[str, ...], exported: set[str]) -> list[str]:
    out = []
    for module, names, line in _imports(tree):
        if module not in public:
            out.append(f"line {line}: {module} is not public")
        elif module == "engine":
            # `from engine import limits` names a public module; anything else must be exported
            out += [f"line {line}: engine.{n} is not exported" for n in names
                    if n not in exported and f"engine.{n}" not in public]
    return out


def _sources() -> list[Path]:
    files = []
    for top in USERS:
        files += [p for p in sorted((ROOT / top).rglob("*.py")) if "out" not in p.relative_to(ROOT / top).parts[:1]]
    return files


def test_the_finder_sees_imports_at_every_level() -> None:
    code = (
        "import engine\nimport engine.world.mover as m\nfrom engine import Vec3, Secret\n"
        "from engine.navigation.search import astar\nfrom . import engine_errors\nimport enginex\n"
        "if TYPE_CHECKING:\n    from engine.world.world import World\n"
        "def f():\n    from engine.limits import MAX_DT\n    from engine import limits\n"
    )
    tree = ast.parse(code)
    assert [(m, line) for m, _, line in _imports(tree)] == [
        ("engine", 1), ("engine.world.mover", 2), ("engine", 3), ("engine.navigation.search", 4),
        ("engine.world.world", 8), ("engine.limits", 10), ("engine", 11)]
    assert _violations(tree, ("engine", "engine.limits"), {"Vec3"}) == [
        "line 2: engine.world.mover is not public", "line 3: engine.Secret is not exported",
        "line 4: engine.navigation.search is not public", "line 8: engine.world.world is not public"]


def test_the_public_face_is_real() -> None:
    """Every exported name and every public module exists (a lazy name included), and the list is short."""
    for name in engine.__all__:
        assert getattr(engine, name) is not None, name
    for module in engine.PUBLIC_MODULES:
        __import__(module)
    assert len(engine.PUBLIC_MODULES) <= 12
    # the machinery stays off the face
    assert not [m for m in engine.PUBLIC_MODULES if m.startswith(("engine.transition", "engine.navigation",
                                                                  "engine.terrain", "engine.bsp", "engine.cells"))]


def test_the_listed_benchmarks_exist_and_do_reach_inside() -> None:
    """A listed benchmark that no longer needs the engine's insides comes off the list."""
    for rel in INSIDE_BENCHMARKS:
        tree = ast.parse((ROOT / rel).read_text(encoding="utf-8"))
        assert _violations(tree, engine.PUBLIC_MODULES, set(engine.__all__)), rel


def test_service_clients_and_benchmarks_import_only_the_face() -> None:
    sources = _sources()
    assert ROOT / "service" / "core.py" in sources and ROOT / "clients" / "__main__.py" in sources
    bad = []
    for path in sources:
        rel = path.relative_to(ROOT).as_posix()
        if rel in INSIDE_BENCHMARKS:
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        bad += [f"{rel} {v}" for v in _violations(tree, engine.PUBLIC_MODULES, set(engine.__all__))]
    assert bad == []
