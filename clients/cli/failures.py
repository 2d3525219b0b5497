"""What a failed `acphys` command tells its user: one message on stderr and an exit status, never a traceback.

`failure_message` turns whatever stopped a command into that message: the service's refusal (its kind
and reason), no answer (with the endpoints and prefix tried and the likely reason, clients/cli/no_answer.py),
Zenoh's refusal to open a session (Zenoh's reason, without its build's source paths), a file that cannot
be read or written. Exit status 2 is a usage error (the command line itself is wrong), 1 a failure.

An exception nobody foresaw is a bug: it is reported in one line as one, and `ACPHYS_TRACEBACK=1` in the
environment shows where it came from.
"""

from __future__ import annotations

import argparse
import os
import re
import sys
import traceback

from service.bus.zconfig import zenoh_reason

from clients.cli.command_failed import FAILURE, USAGE, CommandFailed
from clients.errors import NoServiceError, RequestTimeout, ServiceError

__all__ = ["CommandFailed", "failure_message", "report_failure", "USAGE", "FAILURE", "TRACEBACK_ENV"]

#: set to 1 to see the traceback of an unforeseen error
TRACEBACK_ENV = "ACPHYS_TRACEBACK"

#: a Python exception's class name at the head of a message part ("OutOfRangeError: "), as older services
#: still put in their error messages
_CLASS_NAME = re.compile(r"\b[A-Z][A-Za-z0-9]*(Error|Exception): ")


def without_class_names(text: str) -> str:
    """`text` without Python exception class names (`OutOfRangeError: x` is `x`)."""
    return _CLASS_NAME.sub("", text)


def failure_message(exc: BaseException, args: argparse.Namespace) -> tuple[str, int]:
    """The message and exit status for an exception that ended a command."""
    import zenoh

    from clients.cli.no_answer import explain_no_answer, tried

    if isinstance(exc, CommandFailed):
        return str(exc), exc.status
    if isinstance(exc, argparse.ArgumentTypeError):
        return str(exc), USAGE
    if isinstance(exc, ServiceError):
        return f"{exc.kind}: {without_class_names(exc.message)}", FAILURE
    if isinstance(exc, NoServiceError):
        return explain_no_answer(args, str(exc)), FAILURE
    if isinstance(exc, RequestTimeout):
        return f"{exc} (tried {tried(args)}); the service may be overloaded: a longer --timeout waits longer", FAILURE
    if isinstance(exc, zenoh.ZError):
        return f"Zenoh refused: {zenoh_reason(exc)}", FAILURE
    if isinstance(exc, OSError):
        where = f"{exc.filename}: " if exc.filename else ""
        return f"{where}{exc.strerror or exc}", FAILURE
    text = without_class_names(str(exc)) or "no message"
    return (f"internal error: {text} (a bug: please report it with the command; "
            f"{TRACEBACK_ENV}=1 shows where it happened)"), FAILURE


def report_failure(command: str, exc: BaseException, args: argparse.Namespace) -> int:
    """Print `acphys COMMAND: message` on stderr (and the traceback when asked for); the exit status."""
    message, status = failure_message(exc, args)
    if os.environ.get(TRACEBACK_ENV) == "1":
        traceback.print_exception(exc, file=sys.stderr)
    print(f"acphys {command}: {message}", file=sys.stderr)
    return status
