"""Why no service instance answered a command: what the user is told instead of a bare "no answer".

A wrong port, a wrong prefix, a missing `--user` and a wrong password all look alike to a command: no
reply. Once that has happened, `explain_no_answer` looks where the command could not, with a short
Zenoh session of its own opened as the command's was:

- whether Zenoh reached anything at all (the session's peers and routers);
- when it did not, whether the endpoint takes a TCP connection: either nothing listens there, or
  something does and refused the Zenoh session, which is what a service run with `--users` does to a
  client without a valid login (Zenoh gives its API no reason for that refusal, only a generic close
  in its own log, so the login is named as the likely one);
- when it did, under which prefixes acphys instances answer there (`**/health`), so that a wrong
  `--prefix` is named with the right one.

The message names the endpoints and the prefix tried, and where Zenoh refused to open the session at
all, Zenoh's own reason.
"""

from __future__ import annotations

import argparse
import socket
import time
from typing import Any

from service.protocol.wire import DEFAULT_PREFIX, user_prefix
from service.bus.zconfig import DEFAULT_ENDPOINT, make_config, zenoh_reason

from clients.cli.password import password_of
from clients.cli.endpoints import host_port

__all__ = ["explain_no_answer", "tried", "tcp_reachable"]

#: protocols carried over one TCP connection, whose listener a plain TCP connect can find
_TCP_PROTOCOLS = ("tcp", "tls", "ws")
#: the longest the diagnosis waits for each thing it asks
_PROBE_SECONDS = 2.0
#: how long the diagnosis waits for its session to reach a peer
_PEER_SECONDS = 0.5
_LOGIN_HINT = "give --user NAME, its password in --password-file FILE or ACPHYS_PASSWORD"


def tried(args: argparse.Namespace) -> str:
    """`tcp/127.0.0.1:7447, prefix 'acphys'` (with the user when logged in): what a command asked."""
    config_file = getattr(args, "zenoh_config", None)
    connect = getattr(args, "connect", None)
    where = ", ".join(connect) if connect else f"the endpoints of {config_file}" if config_file else DEFAULT_ENDPOINT
    prefix = getattr(args, "prefix", DEFAULT_PREFIX)
    user = getattr(args, "user", None)
    as_user = f", user {user!r}" if user is not None else ""
    return f"{where}, prefix {prefix!r}{as_user}"


def tcp_reachable(endpoint: str, timeout: float = 1.0) -> tuple[bool | None, str]:
    """Whether something accepts a TCP connection at a tcp/tls/ws endpoint (None for other protocols),
    and the system's reason when nothing does."""
    protocol, _, rest = endpoint.partition("/")
    parts = host_port(rest.split("?")[0].split("#")[0])
    if protocol not in _TCP_PROTOCOLS or parts is None or not parts[1].isdigit():
        return None, ""
    host = parts[0].strip("[]")
    try:
        with socket.create_connection((host, int(parts[1])), timeout=timeout):
            return True, ""
    except OSError as e:
        return False, e.strerror or str(e)


def _endpoints(args: argparse.Namespace) -> list[str]:
    connect = getattr(args, "connect", None)
    if connect:
        return list(connect)
    return [] if getattr(args, "zenoh_config", None) else [DEFAULT_ENDPOINT]


def _instances_answering(session: Any, key: str, timeout: float) -> int:
    """How many instances reachable from `session` answer the health key `key` (wildcards allowed)."""
    return sum(1 for reply in session.get(key, timeout=timeout) if reply.ok is not None)


def _not_reached(args: argparse.Namespace) -> str:
    """Why a session reached nothing: each endpoint's TCP answer, and what a refused session means."""
    user = getattr(args, "user", None)
    reasons = []
    for ep in _endpoints(args):
        reachable, why = tcp_reachable(ep)
        if reachable is False:
            reasons.append(f"nothing accepts connections at {ep} ({why}): is the service running, "
                           f"and listening there (`acphys serve --listen {ep}`)?")
        elif reachable:
            refused = f"{ep} accepted the connection but refused the Zenoh session"
            if user is None:
                reasons.append(f"{refused}; a service run with --users refuses a client that does not log in: "
                               f"{_LOGIN_HINT}")
            else:
                reasons.append(f"{refused} for user {user!r}: a service run with --users refuses an unknown "
                               "user or a wrong password (--password-file or ACPHYS_PASSWORD)")
        else:
            reasons.append(f"Zenoh reached nothing at {ep}" + (f"; if the service has accounts, {_LOGIN_HINT}"
                                                               if user is None else ""))
    if not reasons:  # the endpoints are in a config file
        reasons.append("Zenoh reached nothing with that configuration" + (
            f"; if the service has accounts, {_LOGIN_HINT}" if user is None else ""))
    return "; ".join(reasons)


def _reached(args: argparse.Namespace, session: Any, key_prefix: str) -> str:
    """Why a session that reached Zenoh heard no instance: none under this prefix, or none at all.

    An instance answers a health query under the query's own key, so one found under `**` cannot be
    told by its prefix: the user is pointed at the service's start-up line, which names it."""
    timeout = min(getattr(args, "timeout", _PROBE_SECONDS), _PROBE_SECONDS)
    if _instances_answering(session, f"{key_prefix}/health", timeout):
        return (f"an instance answers under prefix {key_prefix!r} there, but none served that request "
                "(is its landblock owned by a running instance? `acphys stats` lists what each one serves)")
    if _instances_answering(session, "**/health", timeout):
        return (f"an acphys instance answers there, under another prefix than {key_prefix!r}: give the service's "
                "own with --prefix (its start-up log line ends 'under PREFIX/')")
    return (f"Zenoh is reached there, but no acphys instance answered within {timeout:g} s "
            "(a service still starting, or something else listening there?)")


def explain_no_answer(args: argparse.Namespace, what: str = "no service instance answered") -> str:
    """`what`, the endpoints and prefix tried, and the likely reason, as one message for the user."""
    import zenoh

    user = getattr(args, "user", None)
    prefix = getattr(args, "prefix", DEFAULT_PREFIX)
    key_prefix = user_prefix(prefix, user) if user is not None else prefix
    head = f"{what} (tried {tried(args)})"
    try:
        config = make_config(config_file=getattr(args, "zenoh_config", None), connect=_endpoints(args),
                             user=user, password=password_of(args))
        session = zenoh.open(config)
    except Exception as e:  # the command's own session opened, so this is rare: say Zenoh's reason
        return f"{head}: Zenoh cannot open the session: {zenoh_reason(e)}"
    try:
        deadline = time.monotonic() + _PEER_SECONDS  # a reachable peer is there when open() returns; be kind
        while not _peers(session) and time.monotonic() < deadline:
            time.sleep(0.05)
        return f"{head}: " + (_reached(args, session, key_prefix) if _peers(session) else _not_reached(args))
    finally:
        session.close()


def _peers(session: Any) -> list[Any]:
    return [*session.info.peers_zid(), *session.info.routers_zid()]
