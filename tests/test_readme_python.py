"""README.md's Python blocks, run as a reader pastes them: in order, in one Python session.

The blocks that read the shared reference material (`../shared/...`, the engine's own examples)
run against it wherever it is, and are skipped without it as every such test is. The others, the
client walk-through, run against a service this test starts itself on a free loopback port: the
README's endpoint (the default, `tcp/127.0.0.1:7447`) is rewritten to that service's, so the
test never talks to a service somebody else runs. A block that raises fails the test, naming it.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from clients import Client
from service.bus.zconfig import DEFAULT_ENDPOINT
from support.service_harness import ServiceProcess
from support.markdown_python import python_blocks, run_blocks
from support.shared_data import SHARED, needs_shared

README = Path(__file__).resolve().parent.parent / "README.md"
#: how the README's blocks name the shared material: relative to the repository
_SHARED_IN_README = "../shared/"


def reads_shared(block: str) -> bool:
    return _SHARED_IN_README in block


def _client_blocks() -> list[str]:
    return [b for b in python_blocks(README.read_text(encoding="utf-8")) if not reads_shared(b)]


def test_the_walkthrough_shows_every_part_of_the_client() -> None:
    """What the README promises a newcomer: connecting, a mover's life, a batch of each form, the queries,
    a subscription, removal, and the guide to every call."""
    text = README.read_text(encoding="utf-8")
    walkthrough = "\n".join(_client_blocks())
    for call in ("Client([", "wait_ready(", ".register(", ".move(", ".step(", ".move_many(", ".move_batch(",
                 "np.", ".sight(", ".ray(", ".ground(", ".place(", ".grounds(", "_columns(", ".subscribe(",
                 ".remove(", "except ServiceError", ".close()"):
        assert call in walkthrough, f"README's client walk-through does not show {call}"
    assert walkthrough.count(DEFAULT_ENDPOINT) >= 1, "the walk-through should name the endpoint it connects to"
    assert "](docs/client.md)" in text, "README.md should link the client guide"


def test_client_blocks_run_against_a_service_of_their_own() -> None:
    blocks = _client_blocks()
    assert blocks
    with ServiceProcess() as svc:
        rewritten = [b.replace(DEFAULT_ENDPOINT, svc.endpoint) for b in blocks]
        # every connection the blocks make must go to this test's service, never to a shared one
        assert not any(":7447" in b for b in rewritten)
        assert all("Client()" not in b for b in blocks), "a Client() without endpoints reaches the default one"
        namespace = run_blocks(blocks, {DEFAULT_ENDPOINT: svc.endpoint})
        with Client([svc.endpoint]) as check:
            (health,) = check.health()
    # the walk-through registered movers and removed them all again
    assert len(namespace["movers"]) == 3
    assert health["movers"] == 0


@needs_shared
def test_engine_blocks_run_on_the_shared_material() -> None:
    blocks = [b for b in python_blocks(README.read_text(encoding="utf-8")) if reads_shared(b)]
    assert blocks
    run_blocks(blocks, {_SHARED_IN_README: f"{SHARED.as_posix()}/"})


def test_a_block_that_raises_fails_the_run_and_is_named() -> None:
    with pytest.raises(AssertionError, match=r"python block 2 raised:(.|\n)*ZeroDivisionError"):
        run_blocks(["x = 1", "y = x / 0", "z = 2"], {})


def test_blocks_share_one_namespace_and_get_the_replacements() -> None:
    namespace = run_blocks(["x = 'tcp/127.0.0.1:7447'", "y = x + '!'"], {DEFAULT_ENDPOINT: "tcp/127.0.0.1:1"})
    assert namespace["y"] == "tcp/127.0.0.1:1!"


def test_python_blocks_are_found_in_order_and_only_python() -> None:
    text = "a\n```python\nx = 1\n```\n```sh\nls\n```\n```python\ny = 2\nz = 3\n```\n"
    assert python_blocks(text) == ["x = 1\n", "y = 2\nz = 3\n"]
