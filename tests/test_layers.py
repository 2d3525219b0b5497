"""The engine's layers: no import circle, and each layer imports only
the layers below it.

The import graph is read from the sources with `ast` (nothing is imported):
an edge is a module-level import of another engine module. Imports under
`if TYPE_CHECKING:` are left out (they exist for mypy and mypyc, which need the
concrete classes to compile native calls, and never run), and so is the edge
from a module to the packages that contain it (Python runs those first
anyway). Imports inside functions are not allowed in the engine at all: they
were the way circles were dodged.

The layers, bottom to top:

    leaf        constants, errors, _compat, _lazy, settings (EngineSettings:
                it imports only the constants), transition.state (the
                transition's enums)
    geometry    vectors, frames, planes, polygons, land definitions
    terrain     landblock heights and triangles
    bsp, objects, cells   what a transition collides with, in that order (an
                object's shape is BSP trees and spheres; a cell holds objects
                and culls them, engine.cells.broad_phase); they see the
                transition only through its typed interface (TYPE_CHECKING
                imports, engine.transition.interface), never its modules
                (the objects also call the slides of transition/slide.py)
    transition  the collision transition
    world       movers, landblocks, placement, the World facade
    queries     sight, rays, ground, placement queries (below the facade)
    navigation  paths, walked by the transition (below the facade too)
    formats     scene, dat and trace loaders, which build Worlds
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
ENGINE = ROOT / "engine"


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _targets(node: ast.Import | ast.ImportFrom, module: str, is_package: bool, known: set[str]) -> list[str]:
    """The engine modules an import statement loads (a package, or a module of it)."""
    if isinstance(node, ast.Import):
        names = [alias.name for alias in node.names]
    else:
        if node.level:
            package = module.split(".") if is_package else module.split(".")[:-1]
            base = package[: len(package) - (node.level - 1)]
            prefix = ".".join(base + ([node.module] if node.module else []))
        else:
            prefix = node.module or ""
        names = [f"{prefix}.{alias.name}" if f"{prefix}.{alias.name}" in known else prefix for alias in node.names]
    out = []
    for name in names:
        while name not in known and "." in name:
            name = name.rsplit(".", 1)[0]
        if name in known:
            out.append(name)
    return out


def _module_level_imports(tree: ast.Module) -> list[ast.Import | ast.ImportFrom]:
    """Import statements that run when the module is imported (TYPE_CHECKING blocks left out)."""
    found: list[ast.Import | ast.ImportFrom] = []

    def visit(body: list[ast.stmt]) -> None:
        for node in body:
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                found.append(node)
            elif isinstance(node, ast.If):
                if not _is_type_checking(node.test):
                    visit(node.body)
                visit(node.orelse)
            elif isinstance(node, ast.Try):
                visit(node.body)
                for handler in node.handlers:
                    visit(handler.body)
                visit(node.orelse)
                visit(node.finalbody)

    visit(tree.body)
    return found


def _engine_sources() -> dict[str, tuple[Path, ast.Module]]:
    return {_module_name(p): (p, ast.parse(p.read_text(encoding="utf-8"))) for p in sorted(ENGINE.rglob("*.py"))}


def _graph() -> dict[str, set[str]]:
    sources = _engine_sources()
    known = set(sources)
    graph: dict[str, set[str]] = {}
    for module, (path, tree) in sources.items():
        ancestors = {".".join(module.split(".")[:i]) for i in range(1, module.count(".") + 1)}
        edges: set[str] = set()
        for node in _module_level_imports(tree):
            edges.update(_targets(node, module, path.name == "__init__.py", known))
        graph[module] = edges - ancestors - {module}
    return graph


def _circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    circles = []
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, edges = work[-1]
            for nxt in edges:
                if nxt not in index:
                    index[nxt] = low[nxt] = len(index)
                    stack.append(nxt)
                    on_stack.add(nxt)
                    work.append((nxt, iter(sorted(graph[nxt]))))
                    break
                if nxt in on_stack:
                    low[node] = min(low[node], index[nxt])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.append(member)
                        if member == node:
                            break
                    if len(component) > 1:
                        circles.append(sorted(component))
    return circles


def _in(module: str, *packages: str) -> bool:
    return any(module == p or module.startswith(p + ".") for p in packages)


def test_the_circle_finder_finds_a_circle() -> None:
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert _circles(graph) == [["a", "b", "c"]]
    assert _circles({"a": {"b"}, "b": set()}) == []


def test_the_graph_sees_the_engines_imports() -> None:
    graph = _graph()
    # edges anyone can check by reading the files' first lines
    assert "engine.constants" in graph["engine.geometry.vec3"]
    assert "engine.transition.sphere_path" in graph["engine.transition.transition"]
    assert "engine.world.world" in graph["engine.formats.scene"]


def test_no_import_circle_in_the_engine() -> None:
    assert _circles(_graph()) == []


def test_no_import_inside_a_function_in_the_engine() -> None:
    """Imports in function bodies only ever dodged a circle; the layers make them unneeded."""
    inside = []
    for module, (_, tree) in _engine_sources().items():
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                for sub in ast.walk(node):
                    if isinstance(sub, (ast.Import, ast.ImportFrom)) and (
                        isinstance(sub, ast.ImportFrom) and (sub.level or (sub.module or "").startswith("engine"))
                    ):
                        inside.append(f"{module}.{node.name}")
    assert inside == []


LEAF = ("engine.constants", "engine.errors", "engine._compat", "engine._lazy", "engine.transition.state")
#: what the collision layer (bsp, cells, objects) may import from the transition package
TRANSITION_INTERFACE = ("engine.transition", "engine.transition.state", "engine.transition.interface")


def test_leaf_modules_import_nothing_of_the_engine() -> None:
    graph = _graph()
    for module in LEAF:
        assert graph[module] == set(), module
    # the settings sit beside the leaf: every layer reads them, and they read only the constants
    assert graph["engine.settings"] <= {"engine.constants"}
    assert "engine.transition.settings" not in graph  # one place for them, no second path


def test_geometry_imports_only_the_leaf_constants() -> None:
    # (and the leaf shim engine._compat: its mypyc_attr marks the value classes acyclic for the compiler)
    for module, edges in _graph().items():
        if _in(module, "engine.geometry"):
            assert {e for e in edges if not _in(e, "engine.geometry")} <= {"engine.constants", "engine._compat"}, module


def test_collision_layer_sees_the_transition_only_through_its_interface() -> None:
    for module, edges in _graph().items():
        if _in(module, "engine.bsp", "engine.cells"):
            assert {e for e in edges if _in(e, "engine.transition")} <= set(TRANSITION_INTERFACE), module
            assert not {e for e in edges if _in(e, "engine.world", "engine.queries", "engine.formats")}, module


def test_each_layer_imports_only_layers_below() -> None:
    order = ["engine.terrain", "engine.bsp", "engine.objects", "engine.cells", "engine.transition", "engine.world", "engine.queries",
             "engine.navigation", "engine.formats"]
    above = {p: order[i + 1:] for i, p in enumerate(order)}
    # the World facade sits on the queries and the navigation it answers (it is the top of engine.world)
    exceptions = {("engine.world.world", "engine.queries"), ("engine.world.world", "engine.navigation")}
    # the objects' sphere collisions call the transition's slides (slide.py: functions of a Transition
    # that import only the leaf and geometry below them); bsp and cells do not
    allowed = {("engine.objects", "engine.transition.slide")}
    for module, edges in _graph().items():
        for package, higher in above.items():
            if not _in(module, package):
                continue
            for e in edges:
                for h in higher:
                    if _in(e, h) and (module, h) not in exceptions and (package, e) not in allowed and not (
                        h == "engine.transition" and e in TRANSITION_INTERFACE
                    ):
                        raise AssertionError(f"{module} imports {e}, a layer above {package}")


def test_engine_never_imports_the_bus_or_its_users() -> None:
    for module, (_, tree) in _engine_sources().items():
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and not node.level:
                names = [node.module or ""]
            else:
                continue
            for name in names:
                top = name.split(".")[0]
                assert top not in {"zenoh", "msgpack", "service", "clients"}, f"{module} imports {name}"


#: the engine modules `import clients` may load: the value types a client sends
#: and receives (geometry, the World's types, the batch rows' layout and the
#: transient-state bits a column reply's flags carry, the queries' and paths'
#: answers, the limits it checks before sending) and the leaf modules under
#: them; none of the per-move machinery
CLIENT_ALLOWED = ("engine.geometry", "engine.world.types", "engine.world.rows", "engine.world.transient",
                  "engine.queries.results", "engine.navigation.results", "engine.navigation.settings", "engine.limits",
                  "engine.transition.state", "engine.settings")
CLIENT_FORBIDDEN = ("engine.transition.transition", "engine.bsp", "engine.cells", "engine.objects", "engine.terrain", "engine.formats", "engine.world.world", "engine.world.mover")


def test_the_client_library_loads_no_engine_machinery() -> None:
    code = (
        "import sys\n"
        "from clients import Client, Move\n"
        "print('\\n'.join(sorted(m for m in sys.modules if m == 'engine' or m.startswith('engine.'))))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120, check=True)
    loaded = out.stdout.split()
    assert "engine.geometry.vec3" in loaded  # what a client does need is there
    assert not [m for m in loaded if _in(m, *CLIENT_FORBIDDEN)]
    packages = {"engine", "engine.transition", "engine.world", "engine.queries", "engine.navigation"}
    extra = [m for m in loaded if m not in packages and not _in(m, *CLIENT_ALLOWED, *LEAF)]
    assert extra == []
