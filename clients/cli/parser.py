"""The `acphys` argument parser: argparse, with usage errors that name what the user mistyped.

argparse checks the required options of a command before it looks at the words it did not recognise,
so `acphys move --start ... --ofset 1 0 0` was told "one of the arguments --to --offset --motion is
required" and `--ofset` never named. `CommandParser` names an unknown option first, with the nearest
known one when there is a close match, and reports a subcommand's stray words with that subcommand's
usage. Every usage error exits with status 2, as argparse's do.

`walk_parsers` yields every parser of the tree (the program's and each subcommand's), for whatever must
treat every command alike: the endpoint checks (clients/__main__.py) and the tests that run every `--help`.
"""

from __future__ import annotations

import argparse
import difflib
import sys
from collections.abc import Iterator, Sequence
from typing import Any, NoReturn

__all__ = ["CommandParser", "walk_parsers", "unknown_options"]


def _is_number(word: str) -> bool:
    try:
        float(word)
    except ValueError:
        return False
    return True


def unknown_options(parser: argparse.ArgumentParser, words: Sequence[str]) -> list[str]:
    """The words of `words` that look like options `parser` does not have (a negative number is a value,
    nothing after `--` is an option, and for a parser with subcommands nothing after the command); an
    unambiguous abbreviation of a long option is known."""
    known = parser._option_string_actions  # argparse's own table of the parser's option strings
    commands = any(isinstance(a, argparse._SubParsersAction) for a in parser._actions)
    found = []
    for word in words:
        if word == "--" or commands and not word.startswith("-"):
            break  # the rest is positional, or a subcommand's words (its own parser looks at them)
        if not word.startswith("-") or word == "-" or _is_number(word):
            continue
        name = word.split("=", 1)[0]
        if name in known:
            continue
        if parser.allow_abbrev and name.startswith("--") and sum(o.startswith(name) for o in known) == 1:
            continue
        found.append(name)
    return found


class CommandParser(argparse.ArgumentParser):
    """An ArgumentParser whose usage errors name the unknown options among the words it was given, and
    which refuses stray words itself (a subcommand's with its own usage), never handing them back."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._words: list[str] = []

    def parse_known_args(  # type: ignore[override]  # the same call, without argparse's typing overloads
            self, args: Sequence[str] | None = None, namespace: argparse.Namespace | None = None,
    ) -> tuple[argparse.Namespace, list[str]]:
        self._words = list(sys.argv[1:] if args is None else args)
        ns, extras = super().parse_known_args(args, namespace)
        if extras:
            self.error(f"unrecognized arguments: {' '.join(extras)}")
        return ns, extras

    def error(self, message: str) -> NoReturn:
        unknown = unknown_options(self, self._words)
        if unknown:
            message = "; ".join(self._unknown_message(name) for name in unknown)
        super().error(message)

    def _unknown_message(self, name: str) -> str:
        long_options = [o for o in self._option_string_actions if o.startswith("--")]
        close = difflib.get_close_matches(name, long_options, n=1, cutoff=0.75)
        return f"unknown option {name}" + (f" (did you mean {close[0]}?)" if close else "")


def walk_parsers(parser: argparse.ArgumentParser, path: tuple[str, ...] = ()
                 ) -> Iterator[tuple[tuple[str, ...], argparse.ArgumentParser]]:
    """(the command words, the parser) of `parser` and of every subcommand below it, depth first."""
    yield path, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from walk_parsers(sub, (*path, name))
