"""The protocol's generated module files (service/protocol/generate.py) match their declarations.

A declaration changed without running `python3 -m service.protocol.generate` would leave the service
writing the old bytes: this test fails until the files are written again. What the packer writes is
checked against an independent hand writer in test_state_packing.py.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import msgpack
import pytest

from service.protocol import generate
from service.protocol.messages import STATE
from service.protocol.packing import packer_module
from service.protocol.schema import Field, Map
from service.protocol.schema_kinds import Packed, SourceGen, Str, UInt

ROOT = Path(__file__).resolve().parents[3]


@pytest.mark.parametrize("g", generate.GENERATED, ids=lambda g: g.path)
def test_each_generated_file_is_what_its_declaration_makes_now(g: generate.GeneratedPacker) -> None:
    assert (ROOT / g.path).read_text(encoding="utf-8") == generate.source_of(g)


def test_check_mode_reports_a_stale_file_and_writes_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                           capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "service" / "protocol").mkdir(parents=True)
    stale = tmp_path / generate.GENERATED[0].path
    stale.write_text("# an old version\n", encoding="utf-8")
    monkeypatch.setattr(generate, "_ROOT", tmp_path)
    assert generate.main(["--check"]) == 1
    assert stale.read_text(encoding="utf-8") == "# an old version\n"
    assert generate.GENERATED[0].path in capsys.readouterr().err
    assert generate.main([]) == 0  # written
    assert stale.read_text(encoding="utf-8") == generate.source_of(generate.GENERATED[0])
    assert generate.main(["--check"]) == 0


def test_a_field_added_to_a_map_appears_in_its_generated_packer() -> None:
    small = Map("Small", (Field("id", UInt(64), required=True, src="a"),
                          Field("name", Str(), required=True, src="b")))
    bigger = Map("Small", (*small.fields, Field("extra", UInt(32), required=True, src="c")))
    a, b = packer_module(small, "a, b", "bytes", (), "doc"), packer_module(bigger, "a, b, c", "bytes", (), "doc")
    assert "extra" not in a and "extra" in b
    for source, args, expected in ((a, (5, "x"), {"id": 5, "name": "x"}),
                                   (b, (5, "x", 7), {"id": 5, "name": "x", "extra": 7})):
        ns: dict[str, Any] = {}
        exec(compile(source, "<generated>", "exec"), ns)  # noqa: S102 - our own generated source
        assert msgpack.unpackb(ns["pack_Small"](*args)) == expected


def test_a_constant_without_a_source_form_is_refused() -> None:
    class Opaque(UInt):
        def pack(self, g: SourceGen, src: str, out: Packed) -> None:
            out.expr(f"{g.const(object(), 'opaque')}({src})")

    with pytest.raises(ValueError, match="no source form"):
        packer_module(Map("Odd", (Field("x", Opaque(32), required=True, src="a"),)), "a", "bytes", (), "doc")


def test_the_state_packer_module_declares_typed_arguments_for_mypyc() -> None:
    (state,) = [g for g in generate.GENERATED if g.map is STATE]
    text = generate.source_of(state)
    assert "def pack_State(mover_id: int, seq: int, r: MoveResult, collide_ids: list[int]," in text
    assert ") -> bytes:" in text
