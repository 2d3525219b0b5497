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
"""

from __future__ import annotations

import json
import re

import zenoh

from .wire import DEFAULT_PORT

__all__ = ["DEFAULT_ENDPOINT", "make_config", "SHM_KEY", "zenoh_reason"]

DEFAULT_ENDPOINT = f"tcp/127.0.0.1:{DEFAULT_PORT}"
SHM_KEY = "transport/shared_memory/enabled"


def _file_sets_shm(config_file: str) -> bool:
    """Whether a config file mentions the shared-memory transport at all (then its choice stands)."""
    try:
        with open(config_file, encoding="utf-8") as f:
            return "shared_memory" in f.read()
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
    log the session in to a service run with accounts (Zenoh's usrpwd authentication, service/accounts.py)."""
    if config_file:
        cfg = zenoh.Config.from_file(config_file)
        if not _file_sets_shm(config_file):
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
