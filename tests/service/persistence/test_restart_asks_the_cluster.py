"""A restarted cluster instance asks the others which of its saved movers they hold now, and must first be
able to reach them: service.persistence.lifecycle._await_cluster waits until some other instance answers Health
(the restarting instance has declared no key yet), for at most its timeout."""

from __future__ import annotations

from service.persistence.lifecycle import _await_cluster
from service.protocol.wire import Keys
from support.service_harness import ServiceProcess, free_port, raw_session


def test_waits_for_an_answer_and_returns_at_once_when_one_comes() -> None:
    with ServiceProcess() as svc:
        session = raw_session(svc.endpoint)
        try:
            assert _await_cluster(session, Keys(), timeout=30.0)  # True: an instance answered
        finally:
            session.close()


def test_gives_up_after_its_timeout_when_nobody_answers() -> None:
    # a session connected to nothing (an endpoint nobody listens on): no instance can answer
    session = raw_session(f"tcp/127.0.0.1:{free_port()}")
    try:
        assert not _await_cluster(session, Keys(), timeout=1.5)
    finally:
        session.close()
