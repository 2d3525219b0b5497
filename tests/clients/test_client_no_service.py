"""A Client that reaches no service says where it looked: the endpoint, the prefix, and the login it
may need (the library's counterpart of the CLI's diagnosis, tests/clients/cli/test_cli_errors.py)."""

from __future__ import annotations

import pytest

from clients import Client, NoServiceError
from engine import Position, Vec3
from support.service_harness import endpoint, free_port

#: a point in landblock A9B4, asked of the landblock's key: some instance must answer it
POINT = Position.at(0xA9B4000B, Vec3(40.0, 50.0, 60.0))


def test_no_service_names_the_endpoint_the_prefix_and_the_login_hint() -> None:
    where = endpoint(free_port())  # nothing listens there
    with Client([where], prefix="nobody-here", timeout=0.3) as client:
        assert client.health() == []  # (asked of every instance: none is an answer, not an error)
        with pytest.raises(NoServiceError) as refused:
            client.ground(POINT)
    text = str(refused.value)
    assert where in text and "'nobody-here'" in text and "user=" in text, text


def test_a_logged_in_client_is_not_told_to_log_in() -> None:
    where = endpoint(free_port())
    with Client([where], prefix="nobody-here", timeout=0.3) as client:
        client.user = "alice"  # (as a login would set it; nothing answers anyway)
        with pytest.raises(NoServiceError) as refused:
            client.ground(POINT)
    assert "user=" not in str(refused.value)
