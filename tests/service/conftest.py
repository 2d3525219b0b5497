"""What most service tests share: one service on the demo world per test module, and a raw Zenoh session
to it. A module that needs another service (other options, its own state file) defines its own `service`
fixture, which takes precedence over this one."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
import zenoh

from support.service_harness import ServiceProcess, raw_session


@pytest.fixture(scope="module")
def service() -> Iterator[ServiceProcess]:
    with ServiceProcess() as svc:
        yield svc


@pytest.fixture(scope="module")
def session(service: ServiceProcess) -> Iterator[zenoh.Session]:
    s = raw_session(service.endpoint)
    yield s
    s.close()
