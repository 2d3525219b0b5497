"""docs/client.md, the client library's guide: generated from the docstrings, and up to date.

`python3 -m clients.docgen` writes it; here the committed file must be exactly what the docstrings
give now, every public call of the library must have a docstring and a section of its own, and the
guide's own example must run against a service.
"""

from __future__ import annotations

import inspect
import re
from pathlib import Path

import pytest

import clients
from clients import AsyncClient, Client, docgen
from service.protocol.wire import ErrorKind
from service.bus.zconfig import DEFAULT_ENDPOINT
from support.service_harness import ServiceProcess, demo_world
from support.markdown_python import python_blocks, run_blocks

ROOT = Path(__file__).resolve().parents[2]
GUIDE = ROOT / "docs" / "client.md"


def _public_calls(cls: type) -> list[str]:
    """The names a user calls on `cls`: every public attribute that is a function or property (from
    `dir`, not from the generator's own walk)."""
    return [name for name in dir(cls) if not name.startswith("_")
            and (inspect.isfunction(getattr(cls, name)) or isinstance(inspect.getattr_static(cls, name), property)
                 or inspect.ismethod(getattr(cls, name)))]


def test_the_committed_guide_is_what_the_docstrings_give() -> None:
    assert GUIDE.read_text(encoding="utf-8") == docgen.render(), \
        "docs/client.md is out of date: run python3 -m clients.docgen"


@pytest.mark.parametrize("cls", [Client, AsyncClient, clients.Subscription, clients.MoverState, clients.Move,
                                 clients.InstanceInfo, clients.BatchResults, clients.QueryColumnResults],
                         ids=lambda c: c.__name__)
def test_every_public_call_has_a_docstring_and_a_section(cls: type) -> None:
    guide = GUIDE.read_text(encoding="utf-8")
    assert inspect.getdoc(cls) and f"\n### {cls.__name__}\n" in guide
    names = _public_calls(cls)
    assert names
    for name in names:
        doc = inspect.getdoc(getattr(cls, name))
        assert doc and doc != inspect.getdoc(object), f"{cls.__name__}.{name} has no docstring"
        assert f"\n#### {cls.__name__}.{name}\n" in guide, f"docs/client.md has no section for {cls.__name__}.{name}"


def test_the_guide_gives_each_call_its_signature() -> None:
    guide = GUIDE.read_text(encoding="utf-8")
    for cls in (Client, AsyncClient):
        for name in _public_calls(cls):
            section = guide.split(f"\n#### {cls.__name__}.{name}\n", 1)[1].split("\n#### ", 1)[0]
            params = [p for p in inspect.signature(getattr(cls, name)).parameters if p not in ("self", "cls")]
            code = section.split("```python\n", 1)[1].split("```", 1)[0]
            assert code.lstrip().startswith(("async def " if inspect.iscoroutinefunction(getattr(cls, name))
                                              else "") + f"{name}(")
            for p in params:
                assert re.search(rf"\b{p}\b", code), f"{cls.__name__}.{name}: parameter {p} not in the guide"


def test_every_async_call_runs_the_client_call_of_its_name() -> None:
    """AsyncClient's docstring says so; a coroutine without a Client counterpart would make it false."""
    for name in _public_calls(AsyncClient):
        assert inspect.iscoroutinefunction(getattr(AsyncClient, name))
        assert callable(getattr(Client, name, None)), f"AsyncClient.{name} has no Client.{name}"


def test_the_guide_lists_every_error_kind_of_the_service() -> None:
    guide = GUIDE.read_text(encoding="utf-8")
    for kind in ErrorKind.ALL:
        assert f"| `{kind}` |" in guide, kind


def test_error_kinds_table_refuses_a_protocol_that_differs_from_the_service(tmp_path: Path) -> None:
    text = (ROOT / "docs" / "protocol.md").read_text(encoding="utf-8")
    row = next(line for line in text.splitlines() if line.startswith("| `busy` |"))
    short = tmp_path / "protocol.md"
    short.write_text(text.replace(row + "\n", ""), encoding="utf-8")
    with pytest.raises(ValueError, match="busy"):
        docgen.error_kinds_table(short)


def test_check_mode_tells_a_stale_guide_from_a_fresh_one(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "client.md"
    assert docgen.main(["--out", str(out)]) == 0
    assert out.read_text(encoding="utf-8") == docgen.render()
    assert docgen.main(["--out", str(out), "--check"]) == 0
    out.write_text(docgen.render().replace("#### Client.step", "#### Client.stepp"), encoding="utf-8")
    assert docgen.main(["--out", str(out), "--check"]) == 1
    assert "out of date" in capsys.readouterr().err
    assert docgen.main(["--out", str(tmp_path / "missing.md"), "--check"]) == 1


def test_the_guides_example_runs_against_a_service() -> None:
    (example, *_) = python_blocks(GUIDE.read_text(encoding="utf-8"))
    assert DEFAULT_ENDPOINT in example
    with ServiceProcess() as svc:
        namespace = run_blocks([example], {DEFAULT_ENDPOINT: svc.endpoint})
        with Client([svc.endpoint]) as check:
            (health,) = check.health()
    st = namespace["st"]
    # moved down from 2 m above the ground at (40, 50): it stands on the terrain there, as the engine
    # alone gives its height (a player's lowest sphere touches the ground at the mover's origin)
    assert st.contact and st.on_walkable
    assert st.position.origin.z == pytest.approx(demo_world().terrain_height(0xA9B4000B, 40.0, 50.0), abs=0.05)
    assert health["movers"] == 0


def test_the_paths_example_runs_against_a_service() -> None:
    """The "Paths" section's example, on the demo world: the path is found, the mover that follows it
    (Client.follow: moves as the guarantee says) ends within 0.25 m of the goal, and the point it wanders
    to lies within the 20 m asked."""
    (example,) = [b for b in python_blocks(GUIDE.read_text(encoding="utf-8")) if "c.path(" in b]
    assert DEFAULT_ENDPOINT in example
    with ServiceProcess() as svc:
        namespace = run_blocks([example], {DEFAULT_ENDPOINT: svc.endpoint})
        with Client([svc.endpoint]) as check:
            (health,) = check.health()
    assert namespace["route"].found
    walked = namespace["walked"]
    assert walked.arrived(namespace["route"].waypoints)
    assert walked.state.position.get_offset(namespace["goal"]).length() <= 0.25
    wander = namespace["wander"]
    assert wander.found and wander.end is not None
    d = walked.state.position.get_offset(wander.end)
    assert (d.x * d.x + d.y * d.y) ** 0.5 <= 20.0 + 0.25
    assert health["movers"] == 0
