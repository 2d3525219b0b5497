"""A move's State (docs/protocol.md, "State") as msgpack bytes, written from its MoveResult.

Generated from State in service/protocol/messages.py by `python3 -m service.protocol.generate`:
do not edit; change the declaration and run it again.
"""

from __future__ import annotations

from struct import Struct
from typing import Any, Final

from engine import MoveResult
from service.protocol.schema_kinds import packb as _packb, packed_new

__all__ = ['pack_State']

_cache4: Final[dict[Any, bytes]] = {}
_new5: Final = packed_new
_pack6: Final = Struct('>1sH4sQ5sQ3sB16sI9sd1sd1sd14sd1sd1sd1sd11sH').pack
_pack8: Final = Struct('>24sd1sd1sd3sd').pack
_pack10: Final = Struct('>20sI').pack
_pack12: Final = Struct('>19sd1sd1sd').pack
_pack14: Final = Struct('>17sd1sd1sd').pack
_small16: Final = tuple(b'\xb6frames_stationary_fall' + _packb(i) for i in range(128))
_cache17: Final[dict[Any, bytes]] = {}
_new18: Final = packed_new


def pack_State(mover_id: int, seq: int, r: MoveResult, collide_ids: list[int], tag: int | str | None = None) -> bytes:
    o1 = r.position
    o2 = o1.frame.origin
    o3 = o1.frame.orientation
    o7 = r.contact_plane
    o9 = r.contact_plane_cell
    o11 = r.collision_normal
    o13 = r.sliding_normal
    o15 = r.frames_stationary_fall
    return b''.join((_pack6(b'\xde', 16 + (tag is not None), b'\xa2id\xcf', mover_id, b'\xa3seq\xcf', seq, b'\xa2ok', (0xC3 if r.ok else 0xC2), b'\xa8position\x83\xa4cell\xce', o1.cell_id, b'\xa6origin\x93\xcb', o2.x, b'\xcb', o2.y, b'\xcb', o2.z, b'\xaborientation\x94\xcb', o3.w, b'\xcb', o3.x, b'\xcb', o3.y, b'\xcb', o3.z, b'\xa9landblock\xcd', (r.position.cell_id >> 16) & 0xFFFF), (_cache4.get(r.transition_state) or _new5(_cache4, r.transition_state, r.transition_state, b'\xb0transition_state', 64)), ((b'\xa7contact\xc3\xabon_walkable\xc3' if r.on_walkable else b'\xa7contact\xc3\xabon_walkable\xc2') if r.contact else (b'\xa7contact\xc2\xabon_walkable\xc3' if r.on_walkable else b'\xa7contact\xc2\xabon_walkable\xc2')), (b'\xadcontact_plane\xc0' if o7 is None else _pack8(b'\xadcontact_plane\x82\xa6normal\x93\xcb', o7.normal.x, b'\xcb', o7.normal.y, b'\xcb', o7.normal.z, b'\xa1d\xcb', o7.d)), (b'\xb2contact_plane_cell\xc0' if o9 is None else _pack10(b'\xb2contact_plane_cell\xce', o9)), (b'\xb0collision_normal\xc0' if o11 is None else _pack12(b'\xb0collision_normal\x93\xcb', o11.x, b'\xcb', o11.y, b'\xcb', o11.z)), (b'\xaesliding_normal\xc0' if o13 is None else _pack14(b'\xaesliding_normal\x93\xcb', o13.x, b'\xcb', o13.y, b'\xcb', o13.z)), (b'\xadwater_contact\xc3' if r.water_contact else b'\xadwater_contact\xc2'), (b'\xb6frames_stationary_fall\xc0' if o15 is None else (_small16[o15] if 0 <= o15 < 128 else b'\xb6frames_stationary_fall' + _packb(o15))), (_cache17.get(tuple(r.transient_state)) or _new18(_cache17, tuple(r.transient_state), r.transient_state, b'\xaftransient_state', 256)), (b'\xafcollide_objects' + _packb(collide_ids) if collide_ids else b'\xafcollide_objects\x90'), (b'' if tag is None else b'\xa3tag' + _packb(tag)),))
