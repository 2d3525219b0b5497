"""The failure vocabulary of `acphys` commands: `CommandFailed` and the exit statuses it carries.

A command that cannot do what it was asked raises `CommandFailed` with the message for the user and the
exit status: `USAGE` (2, argparse's own) when the command line itself is wrong, `FAILURE` (1) otherwise.
It lies below everything that raises or reports it (clients/cli/connection.py, clients/cli/password.py,
clients/cli/no_answer.py, clients/cli/failures.py) and imports none of them.
"""

from __future__ import annotations

__all__ = ["CommandFailed", "USAGE", "FAILURE"]

#: exit status of a command line that is wrong (argparse's own)
USAGE = 2
#: exit status of a command that could not do what it was asked
FAILURE = 1


class CommandFailed(Exception):
    """A command that cannot do what was asked: the message for the user and the exit status."""

    def __init__(self, message: str, status: int = FAILURE) -> None:
        super().__init__(message)
        self.status = status
