"""Zenoh session configuration shared by the service and the clients.

Default: peer mode on loopback, multicast scouting off, so nothing leaves
the machine and no router is needed. A config file replaces the defaults;
explicit endpoints are applied on top of either.
"""

from __future__ import annotations

import json

import zenoh

from .wire import DEFAULT_PORT

__all__ = ["DEFAULT_ENDPOINT", "make_config"]

DEFAULT_ENDPOINT = f"tcp/127.0.0.1:{DEFAULT_PORT}"


def make_config(
    *,
    config_file: str | None = None,
    listen: list[str] | None = None,
    connect: list[str] | None = None,
    mode: str | None = None,
    multicast: bool | None = None,
) -> zenoh.Config:
    """A zenoh.Config; arguments left None keep the file's (or our default) value."""
    if config_file:
        cfg = zenoh.Config.from_file(config_file)
    else:
        cfg = zenoh.Config()
        cfg.insert_json5("mode", json.dumps(mode or "peer"))
        # zenoh's own peer default listens on every interface; ours stays on loopback unless told
        cfg.insert_json5("listen/endpoints", json.dumps(listen or []))
        cfg.insert_json5("scouting/multicast/enabled", json.dumps(bool(multicast)))
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
    return cfg
