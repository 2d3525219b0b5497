"""Where a command's `--user` password comes from: never a command-line word, which every user of the
machine can read in the process list, but the first line of `--password-file`, else the `ACPHYS_PASSWORD`
environment variable.

Used by clients/cli/connection.py (to log in) and clients/cli/no_answer.py (to look again as the command did).
"""

from __future__ import annotations

import argparse
import os

from clients.cli.command_failed import USAGE, CommandFailed

__all__ = ["password_of", "PASSWORD_ENV"]

#: the environment variable a password is read from without --password-file
PASSWORD_ENV = "ACPHYS_PASSWORD"


def password_of(args: argparse.Namespace) -> str | None:
    """--user's password (None without --user); CommandFailed with the reason when there is none to be had."""
    if getattr(args, "user", None) is None:
        return None
    if getattr(args, "password_file", None):
        try:
            with open(args.password_file, encoding="utf-8") as f:
                return f.readline().rstrip("\r\n")
        except OSError as e:
            raise CommandFailed(f"--password-file {args.password_file}: {e.strerror or e}") from None
    password = os.environ.get(PASSWORD_ENV)
    if password is None:
        raise CommandFailed(f"--user needs a password: --password-file FILE or {PASSWORD_ENV}", USAGE)
    return password
