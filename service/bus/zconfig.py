"""Zenoh session configuration shared by the service and the clients.

Default: peer mode on loopback, multicast scouting off, so nothing leaves
the machine and no router is needed. A config file replaces the defaults;
explicit endpoints are applied on top of either.

Zenoh's shared-memory transport is switched off (unless a config file sets
`transport/shared_memory` itself): with it on, zenoh 1.10 moves every
message over 3 KiB between two processes of one machine through a 16 MiB
shared-memory pool of the sender's, and the receiver keeps that pool mapped
after the sender's session has closed. A service answering many short-lived
bulk clients then grew by about 20 MB of RSS per client session, for good
(docs/performance.md, "Memory"). Loopback TCP costs these message sizes
nothing measurable.

A serving instance's session also assembles no message over
`SERVICE_MAX_MESSAGE` (`bound_messages`): Zenoh's default limit is 1 GiB,
and a flood of 20-60 MB requests, each refused `too_large`, left the
service's RSS 10-25 MB higher for good even when the payloads were never
copied out of Zenoh (its reassembly buffers stay with the allocator). Past
this limit Zenoh drops the message while reassembling it, before it is
whole (docs/protocol.md, "Limits and known gaps").
"""

from __future__ import annotations

import json
import re

import zenoh

from service.protocol.wire import DEFAULT_PORT, MAX_PAYLOAD

__all__ = ["DEFAULT_ENDPOINT", "make_config", "bound_messages", "SHM_KEY", "MAX_MESSAGE_KEY", "SERVICE_MAX_MESSAGE",
           "zenoh_reason"]

DEFAULT_ENDPOINT = f"tcp/127.0.0.1:{DEFAULT_PORT}"
SHM_KEY = "transport/shared_memory/enabled"
MAX_MESSAGE_KEY = "transport/link/rx/max_message_size"
#: The largest message a serving instance's Zenoh session assembles: the largest request (MAX_PAYLOAD) and
#: 1 MiB more, so a payload a little over the limit (a client's honest mistake) still reaches the service
#: and is answered `too_large`. Measured (a 20-60 MB flood, tests/service/test_service_oversized.py): RSS 8 % above
#: its start with this limit, 13-21 % with 8 MiB, 40 % with 16 MiB, 250 % with Zenoh's 1 GiB.
SERVICE_MAX_MESSAGE = MAX_PAYLOAD + (1 << 20)


def _file_mentions(config_file: str, word: str) -> bool:
    """Whether a config file mentions `word` (a setting) at all: then its choice stands, not ours."""
    try:
        with open(config_file, encoding="utf-8") as f:
            return word in f.read()
    except OSError:  # zenoh.Config.from_file has already read it; be conservative
        return True


def make_config(
    *,
    config_file: str | None = None,
    listen: list[str] | None = None,
    connect: list[str] | None = None,
    mode: str | None = None,
    multicast: bool | None = None,
    user: str | None = None,
    password: str | None = None,
) -> zenoh.Config:
    """A zenoh.Config; arguments left None keep the file's (or our default) value. `user` and `password`
    log the session in to a service run with accounts (Zenoh's usrpwd authentication, service/security/accounts.py)."""
    if config_file:
        cfg = zenoh.Config.from_file(config_file)
        if not _file_mentions(config_file, "shared_memory"):
            cfg.insert_json5(SHM_KEY, "false")
    else:
        cfg = zenoh.Config()
        cfg.insert_json5("mode", json.dumps(mode or "peer"))
        # zenoh's own peer default listens on every interface; ours stays on loopback unless told
        cfg.insert_json5("listen/endpoints", json.dumps(listen or []))
        cfg.insert_json5("scouting/multicast/enabled", json.dumps(bool(multicast)))
        cfg.insert_json5(SHM_KEY, "false")
        listen = None
        multicast = None
        mode = None
    if mode is not None:
        cfg.insert_json5("mode", json.dumps(mode))
    if listen is not None:
        cfg.insert_json5("listen/endpoints", json.dumps(listen))
    if connect:
        cfg.insert_json5("connect/endpoints", json.dumps(connect))
    if multicast is not None:
        cfg.insert_json5("scouting/multicast/enabled", json.dumps(multicast))
    if user is not None:
        if password is None:
            raise ValueError(f"user {user!r} needs a password")
        cfg.insert_json5("transport/auth/usrpwd", json.dumps({"user": user, "password": password}))
    return cfg


def bound_messages(cfg: zenoh.Config, config_file: str | None = None) -> None:
    """Give a serving instance's config the receive limit `SERVICE_MAX_MESSAGE`, unless its config file
    sets `max_message_size` itself (then that choice stands). Not for clients, nor for a router, which
    forwards replies whose size the service does not bound."""
    if config_file and _file_mentions(config_file, "max_message_size"):
        return
    cfg.insert_json5(MAX_MESSAGE_KEY, json.dumps(SERVICE_MAX_MESSAGE))


#: where Zenoh's messages say which of its own source lines raised them (" at /.../endpoint.rs:615.")
_RUST_LOCATION = re.compile(r"\s*\bat \S+?\.rs:\d+\.?")
_JSON5_MESSAGE = re.compile(r'Json5Err\(Message \{ msg: "(.*?)", location')
_PARSE_AT = re.compile(r"-->\s*(\d+):(\d+)")


def zenoh_reason(exc: BaseException) -> str:
    """Zenoh's own reason for a refusal (a zenoh.ZError), as one line for a user: without the source
    locations of Zenoh's build and the wrappers of its config parser."""
    text = str(exc)
    found = _JSON5_MESSAGE.search(text)
    if found:
        text = found.group(1)
    text = _RUST_LOCATION.sub("", text)
    at = _PARSE_AT.search(text)
    if at and "\n" in text:  # a config parser's picture of the bad line: its position and its "= reason" line
        lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
        reason = next((ln[1:].strip() for ln in lines if ln.startswith("=")), "; ".join(lines[1:]))
        text = f"line {at.group(1)}, column {at.group(2)}: {reason}"
    return text.strip() or type(exc).__name__
