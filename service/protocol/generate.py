"""The protocol's generated modules, written from the declarations in service/protocol/messages.py.

Most of the wire code is generated when the protocol package is imported (service/protocol/schema.py,
packing.py, structs.py). A packer that runs once per move is generated into a module file instead, so
that the compiled install can compile it with mypyc like the engine's hot modules (setup.py): a packer
made at run time is interpreted, and reads each of the compiled engine's attributes through a
descriptor. The file holds the very code `make_packer` would make, with its constants spelled out and
its arguments typed.

    python3 -m service.protocol.generate           write the files
    python3 -m service.protocol.generate --check   exit 1 when a file differs from its declaration

tests/service/protocol/test_generated_modules.py checks that every file is current: a change to a
declaration fails the tests until the files are written again.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

from service.protocol.messages import STATE
from service.protocol.packing import packer_module
from service.protocol.schema import Map

__all__ = ["GeneratedPacker", "GENERATED", "source_of", "main"]

_ROOT = Path(__file__).resolve().parents[2]


@dataclass(frozen=True)
class GeneratedPacker:
    """A packer written to a module: its map, its arguments (typed as mypyc needs them), the imports
    those types need, and the module's place in the tree."""

    path: str
    map: Map
    args: str
    returns: str
    imports: tuple[str, ...]
    what: str


GENERATED: tuple[GeneratedPacker, ...] = (
    GeneratedPacker(
        "service/protocol/state_packer.py", STATE,
        "mover_id: int, seq: int, r: MoveResult, collide_ids: list[int], tag: int | str | None = None", "bytes",
        ("from engine import MoveResult",),
        "A move's State (docs/protocol.md, \"State\") as msgpack bytes, written from its MoveResult"),
)


def source_of(g: GeneratedPacker) -> str:
    """The file's text as the declaration makes it now."""
    doc = (f"{g.what}.\n\nGenerated from {g.map.name} in service/protocol/messages.py by "
           "`python3 -m service.protocol.generate`:\ndo not edit; change the declaration and run it again.\n")
    return packer_module(g.map, g.args, g.returns, g.imports, doc)


def main(argv: list[str]) -> int:
    check = argv == ["--check"]
    if argv and not check:
        print("usage: python3 -m service.protocol.generate [--check]", file=sys.stderr)
        return 2
    stale = []
    for g in GENERATED:
        path, text = _ROOT / g.path, source_of(g)
        current = path.read_text(encoding="utf-8") if path.exists() else None
        if current == text:
            continue
        stale.append(g.path)
        if not check:
            path.write_text(text, encoding="utf-8")
    verb = "differ from their declarations" if check else "written"
    for p in stale:
        print(f"{p}: {verb}", file=sys.stderr)
    return 1 if check and stale else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
