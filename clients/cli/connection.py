"""How a command reaches the service: the connection options every client command shares.

`--connect`/`--zenoh-config` say where, `--prefix` under which keys, and `--user` who logs in to a
service run with accounts (`acphys serve --users`, docs/protocol.md "Accounts"). The password never
comes as a command-line word, which every user of the machine can read in the process list: it is the
first line of `--password-file`, else the `ACPHYS_PASSWORD` environment variable.

Endpoints are checked as they are parsed (clients/cli/endpoints.py); a session Zenoh will not open is a
CommandFailed with Zenoh's reason and what was tried (clients/cli/command_failed.py).
The password's sources are clients/cli/password.py's.
"""

from __future__ import annotations

import argparse
from typing import Any

from service.protocol.wire import DEFAULT_PREFIX
from service.bus.zconfig import zenoh_reason

from clients.cli.password import password_of
from clients.cli.command_failed import USAGE, CommandFailed
from clients.cli.endpoints import connect_endpoint
from clients.cli.no_answer import tried

__all__ = ["add_connection_arguments", "password_of", "connect_client"]


def add_connection_arguments(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("connection")
    g.add_argument("--connect", metavar="ENDPOINT", action="append", type=connect_endpoint,
                   help="service endpoint (repeatable; default tcp/127.0.0.1:7447, shared by every user of the machine)")
    g.add_argument("--zenoh-config", metavar="FILE", help="zenoh JSON5 config file instead of --connect")
    g.add_argument("--prefix", default=DEFAULT_PREFIX,
                   help="key expression prefix (default %(default)s; a service's own prefix keeps it apart from others)")
    g.add_argument("--timeout", type=seconds, default=5.0, help="seconds to wait for each answer (default %(default)s)")
    g.add_argument("--user", metavar="NAME",
                   help="log in to a service run with --users as NAME (password: --password-file, else the "
                        "ACPHYS_PASSWORD environment variable)")
    g.add_argument("--password-file", metavar="FILE", help="file whose first line is --user's password")


def seconds(text: str) -> float:
    """argparse type of a wait: a number of seconds above 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of seconds") from None
    if not 0 < value < float("inf"):
        raise argparse.ArgumentTypeError(f"{text!r}: give a number of seconds above 0")
    return value


def connect_client(args: argparse.Namespace) -> Any:
    """A Client as the connection options say (logged in with --user); CommandFailed when there is none."""
    import zenoh

    from clients.client import Client

    user = getattr(args, "user", None)
    password = password_of(args)
    try:
        return Client(args.connect, config_file=args.zenoh_config, prefix=args.prefix, timeout=args.timeout,
                      user=user, password=password)
    except zenoh.ZError as e:
        raise CommandFailed(f"Zenoh cannot open a session (tried {tried(args)}): {zenoh_reason(e)}") from None
    except ValueError as e:  # a user name or prefix that cannot be one (service/protocol/wire.py)
        raise CommandFailed(f"--user or --prefix: {e}", USAGE) from None
