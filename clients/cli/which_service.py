"""Which service a command talked to: one line on stderr, so that a user can tell.

The default endpoint (tcp/127.0.0.1:7447) and prefix (`acphys`) are shared by
every user and process of the machine: a command may well talk to a service
somebody else started. `acphys demo`, `move` and `stats` say which instance
answered, where, and how to pick another.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from typing import Any, TextIO

from service.protocol.wire import DEFAULT_PREFIX
from service.bus.zconfig import DEFAULT_ENDPOINT

__all__ = ["describe_service", "owner_of", "print_service"]

_SHARED_HINT = ("the default endpoint and prefix are shared by every user of this machine; "
                "pick your own with --listen/--connect and --prefix")


def describe_service(instances: Sequence[str], connect: Sequence[str] | None, prefix: str,
                     config_file: str | None = None) -> str:
    """`service: instance <zid> via tcp/... prefix ...`, plus a hint when the defaults were used."""
    where = f"config {config_file}" if config_file else ", ".join(connect or [DEFAULT_ENDPOINT])
    if not instances:
        line = f"service: no instance answered yet via {where}, prefix {prefix!r}"
    else:
        noun = "instance" if len(instances) == 1 else "instances"
        line = f"service: {noun} {', '.join(instances)} via {where}, prefix {prefix!r}"
    if not config_file and not connect and prefix == DEFAULT_PREFIX:
        line += f" ({_SHARED_HINT})"
    return line


def owner_of(landblocks: Sequence[Any], lb: int) -> list[str]:
    """The instances whose landblock list (a `P/landblocks` reply each) says they own `lb`."""
    out = []
    for info in landblocks:
        owned = info.get("owned")
        if owned == "*" or (isinstance(owned, list) and lb in owned):
            out.append(info.instance)
    return out


def print_service(instances: Sequence[str], connect: Sequence[str] | None, prefix: str,
                  config_file: str | None = None, stream: TextIO | None = None) -> None:
    print(describe_service(instances, connect, prefix, config_file), file=stream or sys.stderr)
