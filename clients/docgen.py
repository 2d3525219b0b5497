"""Write docs/client.md, the client library's guide, from the library's own docstrings.

    python3 -m clients.docgen            # writes docs/client.md
    python3 -m clients.docgen --check    # exit 1 when docs/client.md is not what the docstrings give

The guide is the docstrings of the public classes (`clients.__all__` and the
engine's query results they return), every public method and property with
its signature, in the order the source defines them; only the few paragraphs
of `INTRODUCTION` and of `SECTION_TEXT` (a section's opening, such as the
paths' example) are written here. tests/clients/test_client_guide.py checks that
the committed guide is this module's output, so a docstring changed without
running this fails the tests.
"""

from __future__ import annotations

import argparse
import inspect
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import clients
import engine
from service.protocol.wire import ErrorKind

__all__ = ["GUIDE", "PROTOCOL", "SECTION_TEXT", "documented_members", "error_kinds_table", "main", "render", "signature_text"]

#: where the guide lives, beside the package in the repository
GUIDE = Path(__file__).resolve().parent.parent / "docs" / "client.md"

INTRODUCTION = """\
# The Python client library

`clients` is the Python client of the acphys service: it speaks the wire protocol
([protocol.md](protocol.md)) for you, finds which instance serves a mover, and follows it when it
is handed over. README.md's "The Python client" walks through it against `acphys serve`; this guide
lists every public class and call. It is generated from the library's docstrings by
`python3 -m clients.docgen` (a test checks it is up to date): edit the docstrings, not this file.

```python
from clients import Client
from engine import MoverSpec, SphereSpec, Position, Vec3

with Client(["tcp/127.0.0.1:7447"]) as c:            # the default endpoint and prefix ("acphys")
    player = MoverSpec(spheres=[SphereSpec((0, 0, 0.48), 0.48), SphereSpec((0, 0, 1.35), 0.48)],
                       state=["IsPlayer"])
    me = c.register(player, Position.at(0xA9B4000B, Vec3(40.0, 50.0, 45.0))).id  # 2 m above the hills
    st = c.move(me, offset=(0.0, 0.0, -3.0))          # one transition 3 m down: it lands on the way
    print(st.position, st.contact, st.on_walkable)
    c.remove(me)
```

Units, everywhere: a place is an `engine.Position`, a cell id written in hex (`0xXXYYIIII`:
landblock `XXYY`, cell index `IIII`) and an origin in landblock-local metres (x east and y north from
the landblock's south-west corner, 0 .. 192 m; z the absolute height), with an orientation quaternion
w x y z; a landblock on its own is the 16-bit `0xXXYY`. Offsets, motions, radii and distances are
metres, velocities metres per second, `dt` and every `timeout` seconds. A mover's shape is an
`engine.MoverSpec` of `engine.SphereSpec`s (centre in the mover's frame, radius, in metres) with its
flags (`state`: `IsPlayer`, `Contact`, `OnWalkable`, ...; docs/protocol.md, "MoverSpec").

Errors: every error the library raises is an `AcphysError`. A refusal by the service is a
`ServiceError` whose `kind` is one of the protocol's error kinds (below, and
[protocol.md, "Errors"](protocol.md#errors)); no instance answering is `NoServiceError`; an answer
that did not come in time is `RequestTimeout`. Batches report a failed item in its place instead.
"""

#: the protocol, whose table of error kinds the guide shows
PROTOCOL = GUIDE.parent / "protocol.md"

#: the sections of the guide: a title and the classes in it
SECTIONS: tuple[tuple[str, tuple[type, ...]], ...] = (
    ("Connecting, movers and moves", (clients.Client, clients.AsyncClient, clients.Subscription)),
    ("Values the calls take and return", (clients.MoverState, clients.Move, clients.InstanceInfo,
                                          clients.SightQuery)),
    ("Batches in the column form", (clients.BatchResults, clients.QueryColumnResults)),
    ("What the spatial queries answer (engine.queries)", (engine.SightResult, engine.RayHit, engine.Ground,
                                                           engine.PlacementResult, engine.Blocker)),
    ("Paths", (engine.PathResult,)),
    ("Errors", (clients.AcphysError, clients.ServiceError, clients.BusyError, clients.RequestTimeout,
                clients.NoServiceError)),
)

#: what a section says before its classes, by title
SECTION_TEXT = {
    "Paths": """\
`Client.path` and `Client.paths` ask the service for a path a walker can really walk: found on a
navigation graph whose every edge the client's own transition walked, and proven by walking it with
the walker's shape before it is answered ([protocol.md, "Paths"](protocol.md#paths)). The walker is a
shape (a `MoverSpec`, with its start) or a registered mover's id (it starts where it stands). The
answer is the engine's `PathResult`; nothing is moved. Walk its waypoints in turn with moves of at most
3 m straight toward the next one, until within 0.25 m of it, and the walker reaches each, the goal last:
`Client.follow` walks a registered mover so. `Client.random_point` finds a point to wander to, and the
path there. The first path to reach a landblock builds its graph there, in shares the service answers
`building` between (so that everyone's moves go on); the client asks again by itself. On the demo world
(`acphys serve`):

```python
from clients import Client
from engine import MoverSpec, SphereSpec, Position, Vec3

spheres = [SphereSpec((0, 0, 0.48), 0.48), SphereSpec((0, 0, 1.35), 0.48)]
player = MoverSpec(spheres=spheres, step_up_height=0.6, step_down_height=0.4, state=["IsPlayer"])
standing = MoverSpec(spheres=spheres, step_up_height=0.6, step_down_height=0.4,
                     state=["IsPlayer", "Contact", "OnWalkable"])
with Client(["tcp/127.0.0.1:7447"], timeout=30.0) as c:
    ground = c.ground(Position.at(0xA9B4000B, Vec3(40.0, 50.0, 60.0)))    # the land under (40, 50)
    start = Position.at(0xA9B4000B, Vec3(40.0, 50.0, ground.z))
    goal = Position.at(0xA9B40025, Vec3(100.0, 120.0, 42.0))
    route = c.path(player, start, goal)              # a shape walking from a start
    print(route.found, f"{route.length:.1f} m", len(route.waypoints), "waypoints")
    me = c.register(standing, start, contact_plane=ground.plane).id  # a mover standing there
    route = c.path(me, None, goal)                   # a registered mover, from where it stands
    walked = c.follow(me, route.waypoints)           # the walk the guarantee is about
    print(walked.arrived(route.waypoints), walked.moves, "moves:", walked.state.position)
    wander = c.random_point(me, None, 20.0, seed=7)  # somewhere within 20 m it can walk to
    print(wander.found, wander.end)
    c.remove(me)
```
""",
}

#: longest signature kept on one line
_WIDTH = 100
#: special methods a user calls by syntax, documented beside the named ones
_DUNDERS = ("__len__", "__getitem__")
#: wire plumbing of the error classes: the client builds them, a user never calls it
_SKIPPED = {(clients.ServiceError, "from_wire")}


def _annotation(a: Any) -> str:
    if a is inspect.Parameter.empty:
        return ""
    return a if isinstance(a, str) else inspect.formatannotation(a)


def signature_text(name: str, fn: Callable[..., Any], constructor: bool = False) -> str:
    """`name(params) -> return`, without `self`/`cls`, annotations as the source writes them; one
    parameter a line when that is longer than a line (`constructor`: no `-> None`)."""
    sig = inspect.signature(fn)
    parts: list[str] = []
    star_done = False
    params = list(sig.parameters.values())
    if params and params[0].name in ("self", "cls"):
        params = params[1:]
    for p in params:
        if p.kind is p.KEYWORD_ONLY and not star_done:
            parts.append("*")
            star_done = True
        text = p.name
        if p.kind is p.VAR_POSITIONAL:
            text, star_done = "*" + p.name, True
        elif p.kind is p.VAR_KEYWORD:
            text = "**" + p.name
        ann = _annotation(p.annotation)
        if ann:
            text += f": {ann}"
        if p.default is not p.empty:
            text += f" = {p.default!r}" if ann else f"={p.default!r}"
        parts.append(text)
    ret = _annotation(sig.return_annotation)
    tail = f" -> {ret}" if ret and not constructor else ""
    line = f"{name}({', '.join(parts)}){tail}"
    if len(line) <= _WIDTH or not parts:
        return line
    return f"{name}(\n" + "".join(f"    {part},\n" for part in parts) + f"){tail}"


def documented_members(cls: type) -> Iterator[tuple[str, str, Any]]:
    """The public methods and properties of `cls` (its own, then its bases' within the library), in
    source order: (name, "method" | "classmethod" | "property" | "coroutine", the function)."""
    seen: set[str] = set()
    for klass in cls.__mro__:
        # a base's calls are the class's own when the base is the library's (Client's spatial queries),
        # not when it is an exception class or Python's
        if klass is not cls and (not klass.__module__.startswith("clients.") or issubclass(klass, BaseException)):
            continue
        for name, value in vars(klass).items():
            if name in seen or (name.startswith("_") and name not in _DUNDERS) or (cls, name) in _SKIPPED:
                continue
            kind, fn = _kind(value)
            if fn is None:
                continue
            seen.add(name)
            yield name, kind, fn


def _kind(value: Any) -> tuple[str, Any]:
    if isinstance(value, property):
        return "property", value.fget
    if isinstance(value, classmethod):
        return "classmethod", value.__func__
    if isinstance(value, staticmethod):
        return "staticmethod", value.__func__
    if inspect.iscoroutinefunction(value):
        return "coroutine", value
    if inspect.isfunction(value):
        return "method", value
    return "", None


def _doc(obj: Any) -> str:
    return inspect.cleandoc(obj.__doc__) if obj.__doc__ else ""


def _indented_code(doc: str) -> str:
    """A docstring's indented examples as fenced Python blocks (Markdown would run them into the text)."""
    out: list[str] = []
    lines = doc.splitlines()
    i = 0
    while i < len(lines):
        line = lines[i]
        if line.startswith("    ") and (i == 0 or not lines[i - 1].strip()) and not line.lstrip().startswith("-"):
            block: list[str] = []
            while i < len(lines) and (lines[i].startswith("    ") or not lines[i].strip()):
                block.append(lines[i][4:])
                i += 1
            while block and not block[-1].strip():
                block.pop()
            out += ["```python", *block, "```", ""]
            continue
        out.append(line)
        i += 1
    return "\n".join(out).rstrip()


def error_kinds_table(protocol: Path = PROTOCOL) -> list[str]:
    """docs/protocol.md's table of error kinds, as the guide shows it (its links pointed into protocol.md).
    ValueError when the table does not name every kind the service answers (service.protocol.wire.ErrorKind)
    or names others: then the protocol and the service disagree."""
    text = protocol.read_text(encoding="utf-8")
    start = text.index("\n## Errors\n")
    end = text.index("\n## ", start + 1)
    rows = [line for line in text[start:end].splitlines() if line.startswith("|")]
    kinds = [row.split("|")[1].strip().strip("`") for row in rows[2:]]
    if sorted(kinds) != sorted(ErrorKind.ALL):
        raise ValueError(f"docs/protocol.md's error kinds {kinds} are not the service's {list(ErrorKind.ALL)}")
    return [row.replace("](#", "](protocol.md#") for row in rows]


def _class_section(cls: type) -> list[str]:
    qual = f"{cls.__module__}.{cls.__name__}"
    out = [f"### {cls.__name__}", ""]
    bases = [b.__name__ for b in cls.__bases__ if b is not object]
    init = vars(cls).get("__init__")
    if issubclass(cls, BaseException):
        out += ["```python", f"class {cls.__name__}({', '.join(bases)})", "```", ""]
    elif inspect.isfunction(init):
        out += ["```python", signature_text(cls.__name__, init, constructor=True), "```", ""]
    out += [f"`{qual}`" + (f" (a subclass of {', '.join(f'`{b}`' for b in bases)})" if bases else ""), ""]
    out += [_indented_code(_doc(cls)), ""]
    if inspect.isfunction(init) and init.__doc__:
        out += [_indented_code(_doc(init)), ""]
    if hasattr(cls, "__enter__") or hasattr(cls, "__aenter__"):
        word = "async with" if hasattr(cls, "__aenter__") else "with"
        out += [f"A context manager: `{word}` closes it at the end of the block.", ""]
    if cls is clients.ServiceError:
        out += ["Its `kind` is one of these (the table of [protocol.md, \"Errors\"](protocol.md#errors)):", "",
                *error_kinds_table(), ""]
    for name, kind, fn in documented_members(cls):
        label = {"property": "property", "classmethod": "class method", "coroutine": "coroutine",
                 "staticmethod": "static method"}.get(kind)
        title = f"{cls.__name__}.{name}"
        out += [f"#### {title}", "", "```python"]
        if kind == "property":
            ret = _annotation(inspect.signature(fn).return_annotation)
            out.append(f"{name}: {ret}" if ret else name)
        else:
            out.append(("async def " if kind == "coroutine" else "") + signature_text(name, fn))
        out += ["```", ""]
        if label:
            out += [f"*{label}*", ""]
        text = _doc(fn)
        out += [_indented_code(text) if text else "(no docstring)", ""]
    return out


def render() -> str:
    """The whole guide, as docs/client.md holds it."""
    out = [INTRODUCTION.rstrip(), "", "Contents:", ""]
    for title, classes in SECTIONS:
        out.append(f"- {title}: " + ", ".join(f"[{c.__name__}](#{c.__name__.lower()})" for c in classes))
    out.append("")
    for title, classes in SECTIONS:
        out += [f"## {title}", ""]
        if title in SECTION_TEXT:
            out += [SECTION_TEXT[title].rstrip(), ""]
        for cls in classes:
            out += _class_section(cls)
    text = "\n".join(out)
    while "\n\n\n" in text:
        text = text.replace("\n\n\n", "\n\n")
    return text.rstrip() + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python3 -m clients.docgen", description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=GUIDE, help="file to write (default: docs/client.md)")
    p.add_argument("--check", action="store_true", help="write nothing; exit 1 when the file differs")
    args = p.parse_args(argv)
    text = render()
    if args.check:
        try:
            current = args.out.read_text(encoding="utf-8")
        except OSError as e:
            print(f"clients.docgen: cannot read {args.out}: {e.strerror}", file=sys.stderr)
            return 1
        if current != text:
            print(f"clients.docgen: {args.out} is out of date: run python3 -m clients.docgen", file=sys.stderr)
            return 1
        return 0
    try:
        args.out.write_text(text, encoding="utf-8")
    except OSError as e:
        print(f"clients.docgen: cannot write {args.out}: {e.strerror}", file=sys.stderr)
        return 1
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
