"""How a command reaches the service: the connection options every client command shares.

`--connect`/`--zenoh-config` say where, `--prefix` under which keys, and `--user` who logs in to a
service run with accounts (`acphys serve --users`, docs/protocol.md "Accounts"). The password never
comes as a command-line word, which every user of the machine can read in the process list: it is the
first line of `--password-file`, else the `ACPHYS_PASSWORD` environment variable.
"""

from __future__ import annotations

import argparse
import os
from typing import Any

from service.wire import DEFAULT_PREFIX

__all__ = ["add_connection_arguments", "password_of", "connect_client"]


def add_connection_arguments(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("connection")
    g.add_argument("--connect", metavar="ENDPOINT", action="append",
                   help="service endpoint (repeatable; default tcp/127.0.0.1:7447, shared by every user of the machine)")
    g.add_argument("--zenoh-config", metavar="FILE", help="zenoh JSON5 config file instead of --connect")
    g.add_argument("--prefix", default=DEFAULT_PREFIX,
                   help="key expression prefix (default %(default)s; a service's own prefix keeps it apart from others)")
    g.add_argument("--timeout", type=float, default=5.0, help="seconds to wait for each answer (default %(default)s)")
    g.add_argument("--user", metavar="NAME",
                   help="log in to a service run with --users as NAME (password: --password-file, else the "
                        "ACPHYS_PASSWORD environment variable)")
    g.add_argument("--password-file", metavar="FILE", help="file whose first line is --user's password")


def password_of(args: argparse.Namespace) -> str | None:
    """--user's password (None without --user); SystemExit with the reason when there is none to be had."""
    if getattr(args, "user", None) is None:
        return None
    if getattr(args, "password_file", None):
        try:
            with open(args.password_file, encoding="utf-8") as f:
                return f.readline().rstrip("\r\n")
        except OSError as e:
            raise SystemExit(f"acphys: --password-file: {e}") from None
    password = os.environ.get("ACPHYS_PASSWORD")
    if password is None:
        raise SystemExit("acphys: --user needs a password: --password-file FILE or ACPHYS_PASSWORD")
    return password


def connect_client(args: argparse.Namespace) -> Any:
    """A Client as the connection options say (logged in with --user)."""
    from .client import Client

    user = getattr(args, "user", None)
    try:
        return Client(args.connect, config_file=args.zenoh_config, prefix=args.prefix, timeout=args.timeout,
                      user=user, password=password_of(args))
    except ValueError as e:  # a user name that cannot be one (service/wire.py, check_user_name)
        raise SystemExit(f"acphys: --user: {e}") from None
