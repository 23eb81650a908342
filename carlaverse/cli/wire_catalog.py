"""What the wire carries, read from the message Structs: the source of `carlaverse schema`.

Everything here is derived from `carlaverse.messages` and `carlaverse.keys` (types, defaults,
the pose's `struct` layout, the NPC row dtype, the light bits) so the generated JSON Schema and
the field tables of docs/protocol.md cannot drift from the code. The only hand-written facts
are the ones the code does not state in one place: who writes each key and how it is
delivered (`_KEY_FACTS`). An authority query `q` takes the Struct `<Q>Request` as its payload
if `messages` defines one (an empty payload otherwise) and answers with its codec in
`CHANNEL_CODECS`, else with `<Q>Reply`.
"""

from __future__ import annotations

import inspect
import re
import struct
import typing
from dataclasses import dataclass
from typing import Any

import msgspec
import msgspec.inspect as mi

from carlaverse import messages as m
from carlaverse.keys import (
    AUTHORITY_QUERIES,
    DIGEST_CHANNEL,
    EGO_CHANNELS,
    KEY_AREAS,
    STUDY_CHANNELS,
    TILED_EGO_CHANNELS,
    TILED_WORLD_CHANNELS,
    WORLD_CHANNELS,
)


@dataclass(frozen=True, slots=True)
class KeyDoc:
    """One key of the space (after `carlaverse/<session>/`), its writer and delivery."""

    key: str
    writer: str
    delivery: str
    payload: str = ""  # message name(s); derived from the codecs where the code has them
    request: str = ""  # authority queries: what the query payload carries


_KEY_FACTS: tuple[tuple[str, str, str], ...] = (
    ("node/<id>", "every node, and the authority as `node/authority`",
     "liveliness token: PUT when declared, DELETE on undeclare or lease loss"),
    ("ego/<id>/pose/<tile>", "the node; `<tile>` is the map tile it is in (t<ix>_<iy>)",
     "best effort, congestion DROP, priority real-time; 50-120 Hz"),
    ("ego/<id>/state", "the node", "reliable, congestion BLOCK; on change"),
    ("ego/<id>/skeleton", "walk nodes with a skeleton source (`body:`)", "best effort; ~30 Hz"),
    ("ego/<id>/override", "an ADAS program; the drive node applies it", "reliable"),
    ("world/npc", "authority", "best effort, congestion DROP; scenario `npc_rate_hz` (20 Hz)"),
    ("world/npc/<tile>", "authority: the NPCs of one map tile (an empty batch when it empties)",
     "best effort, congestion DROP; with every `world/npc` batch"),
    ("world/lights", "authority", "reliable, congestion BLOCK; on change and at `status_rate_hz`"),
    ("world/weather", "authority", "reliable, congestion BLOCK; on change and at `status_rate_hz`"),
    ("world/events", "authority", "reliable, congestion BLOCK, priority interactive-high"),
    ("world/@egos", "authority: every ego's pose as published, many to a message, for nodes "
     "that hear the whole session (`pose_digest`); verbatim, so `**` does not match it",
     "best effort, congestion DROP; every `--digest-ms` (2 ms) while anything subscribes"),
    ("impulse/<id>", "authority", "reliable, congestion BLOCK, priority interactive-high"),
    ("audio/<id>", "authority; read by node <id>, observers and recorders only",
     "best effort, congestion DROP; scenario `audio.rate_hz` (20 Hz)"),
    ("study/<id>/ask", "the study runner: a questionnaire for node <id>'s HMI",
     "reliable, congestion BLOCK; repeated until the final answers come"),
    ("study/<id>/answers", "the node: its participant's answers so far",
     "reliable, congestion BLOCK; on each change, and on submit (`final`)"),
    ("study/<id>/brief", "the study runner, under the study's name as session: the trial "
     "participant <id>'s agent takes part in now, or none", "reliable; every 0.5 s"),
)  # fmt: skip


def key_docs() -> list[KeyDoc]:
    """Every key of the space with its payload type, taken from `messages.CHANNEL_CODECS`."""
    out = []
    queries = [(f"authority/{q}", "authority (queryable)", "query / reply")
               for q in AUTHORITY_QUERIES]  # fmt: skip
    for key, writer, delivery in [*_KEY_FACTS, *queries]:
        area, _, rest = key.partition("/")
        named = rest.removesuffix("/<tile>")  # a tiled key carries its channel's payload
        channel = named.rpartition("/")[2] if area in ("ego", "world", "authority", "study") else ""
        codec = m.CHANNEL_CODECS.get((area, channel))
        payload = _type_names(codec.type) if codec is not None else ""
        request = ""
        if area == "authority":
            request = _query_struct(channel, "Request") or "empty"
            payload = payload or _query_struct(channel, "Reply")
        out.append(KeyDoc(key, writer, delivery, payload, request))
    return out


def _query_struct(query: str, suffix: str) -> str:
    """`JoinRequest` for ("join", "Request") if `messages` defines it, else ""."""
    name = f"{query.capitalize()}{suffix}"
    value = getattr(m, name, None)
    return name if isinstance(value, type) and issubclass(value, msgspec.Struct) else ""


def key_space_paths() -> set[str]:
    """Every key shape `carlaverse.keys` can build, for checking `keys()` is complete."""
    paths = {f"{area}/<id>" for area in ("node", "impulse", "audio")}
    paths |= {f"ego/<id>/{c}" for c in EGO_CHANNELS if c not in TILED_EGO_CHANNELS}
    paths |= {f"ego/<id>/{c}/<tile>" for c in TILED_EGO_CHANNELS}
    paths |= {f"world/{c}" for c in (*WORLD_CHANNELS, DIGEST_CHANNEL)}
    paths |= {f"world/{c}/<tile>" for c in TILED_WORLD_CHANNELS}
    paths |= {f"authority/{q}" for q in AUTHORITY_QUERIES}
    paths |= {f"study/<id>/{c}" for c in STUDY_CHANNELS}
    assert {p.split("/")[0] for p in paths} == set(KEY_AREAS)
    return paths


def _type_names(type_: Any) -> str:
    members = typing.get_args(type_) or (type_,)
    return ", ".join(t.__name__ for t in members)


# --------------------------------------------------------------------------- structs


def message_structs() -> list[type[msgspec.Struct]]:
    """Every Struct the `carlaverse.messages` package defines, in the order it lists them."""
    return [
        v
        for v in vars(m).values()
        if isinstance(v, type)
        and issubclass(v, msgspec.Struct)
        and v.__module__.startswith(f"{m.__name__}.")
    ]


def embedded(cls: type[msgspec.Struct]) -> list[str]:
    """Names of the message Structs that have a field of type `cls` (directly or optional)."""
    names = []
    for other in message_structs():
        info = mi.type_info(other)
        assert isinstance(info, mi.StructType)
        if any(_mentions(f.type, cls) for f in info.fields):
            names.append(other.__name__)
    return names


def _mentions(t: mi.Type, cls: type) -> bool:
    if isinstance(t, mi.StructType):
        return t.cls is cls
    if isinstance(t, mi.UnionType):
        return any(_mentions(u, cls) for u in t.types)
    item = getattr(t, "item_type", None)
    return item is not None and _mentions(item, cls)


def world_event_types() -> tuple[type[msgspec.Struct], ...]:
    return typing.get_args(m.WorldEvent)


def encoding(cls: type[msgspec.Struct]) -> str:
    """How a Struct travels: the pose's fixed layout, a MessagePack array or map."""
    info = mi.type_info(cls)
    assert isinstance(info, mi.StructType)
    if cls is m.Pose:
        inside = ", ".join(embedded(cls))
        fixed = f"on `ego/<id>/pose`: the fixed {m.POSE_SIZE}-byte layout (not MessagePack)"
        return fixed + (f"; inside {inside}: a MessagePack array of these fields" if inside else "")
    if info.array_like:
        return "MessagePack array, fields by position"
    if info.tag_field is not None:
        return f"MessagePack map, tagged `{info.tag_field}` = `{info.tag}`"
    return "MessagePack map, keyed by field name"


_FIELD_COMMENT = re.compile(r"^    (\w+)\s*:[^#]*#\s?(.*)$")


# Fields most messages share; their meaning is stated once in docs/protocol.md.
_COMMON_NOTES = {
    "seq": "sequence number (see Sequence numbers)",
    "t": "[s] session time",
    "schema": "the sender's SCHEMA_VERSION",
}


def field_notes(cls: type) -> dict[str, str]:
    """Each field's trailing comment in the class source: units and meaning live there."""
    notes = dict(_COMMON_NOTES)
    for line in inspect.getsource(cls).splitlines():
        match = _FIELD_COMMENT.match(line)
        if match:
            notes[match[1]] = match[2].strip()
    return notes


@dataclass(frozen=True, slots=True)
class FieldDoc:
    name: str
    type: str
    required: bool
    default: str
    note: str


def fields(cls: type[msgspec.Struct]) -> list[FieldDoc]:
    info = mi.type_info(cls)
    assert isinstance(info, mi.StructType)
    notes = field_notes(cls)
    return [
        # the wire name may differ from the attribute (`msgspec.field(name=...)`)
        FieldDoc(f.encode_name, wire_type(f.type), f.required, _default(f), notes.get(f.name, ""))
        for f in info.fields
    ]


def _default(f: mi.Field) -> str:
    if f.required:
        return ""
    value = f.default if f.default is not mi.NODEFAULT else f.default_factory()
    return "nil" if value is None else msgspec.json.encode(msgspec.to_builtins(value)).decode()


def wire_type(t: mi.Type) -> str:
    """A MessagePack-level name for a field type: int, float, str, bin, [float, float]..."""
    if isinstance(t, mi.UnionType):
        return " or ".join(wire_type(u) for u in t.types)
    if isinstance(t, mi.LiteralType):
        return " or ".join(f'"{v}"' if isinstance(v, str) else str(v) for v in t.values)
    if isinstance(t, mi.ListType | mi.SetType | mi.VarTupleType):
        return f"[{wire_type(t.item_type)}, …]"
    if isinstance(t, mi.TupleType):
        return "[" + ", ".join(wire_type(i) for i in t.item_types) + "]"
    if isinstance(t, mi.DictType):
        return f"{{{wire_type(t.key_type)}: {wire_type(t.value_type)}}}"
    if isinstance(t, mi.StructType):
        return t.cls.__name__
    alias = next((name for name, info in constrained_types() if info == t), None)
    return alias if alias is not None else scalar_type(t)


def constrained_types() -> list[tuple[str, mi.Type]]:
    """The named constrained scalars of `messages` (`Finite = Annotated[float, Meta(...)]`)."""
    return [(name, mi.type_info(value)) for name, value in vars(m).items()
            if typing.get_origin(value) is typing.Annotated]  # fmt: skip


def scalar_type(t: mi.Type) -> str:
    """A scalar with its bounds spelled out: `float in [-1e+15, 1e+15]`."""
    return _SCALARS.get(type(t), type(t).__name__.removesuffix("Type").lower()) + _bounds(t)


_SCALARS: dict[type, str] = {
    mi.IntType: "int", mi.FloatType: "float", mi.StrType: "str", mi.BoolType: "bool",
    mi.BytesType: "bin", mi.ByteArrayType: "bin", mi.NoneType: "nil", mi.AnyType: "any",
}  # fmt: skip

_ORDER = (("gt", ">"), ("ge", "≥"), ("lt", "<"), ("le", "≤"))
_LENGTHS = (("min_length", "len ≥"), ("max_length", "len ≤"))


def _bounds(t: mi.Type) -> str:
    """Constraints (msgspec `Meta`) as a suffix: `float in [-1e+15, 1e+15]`, `int > 0`."""
    ops = [(sym, getattr(t, a)) for a, sym in _ORDER if getattr(t, a, None) is not None]
    parts = [f"{sym} {_num(v)}" for sym, v in ops]
    if [sym for sym, _ in ops] == ["≥", "≤"]:
        parts = [f"in [{_num(ops[0][1])}, {_num(ops[1][1])}]"]
    parts += [f"{sym} {getattr(t, a)}" for a, sym in _LENGTHS if getattr(t, a, None) is not None]
    if getattr(t, "pattern", None):
        parts.append(f"matching `{t.pattern}`")  # type: ignore[attr-defined]
    return (" " + ", ".join(parts)) if parts else ""


def _num(value: float) -> str:
    """Bounds as people write them: 2^63−1 rather than 19 digits, 1e+15 rather than 15 zeros."""
    for power in (63, 64, 31, 32):
        if value == 2**power - 1:
            return f"2^{power}−1"
        if value == -(2**power):
            return f"−2^{power}"
    return f"{value:g}" if isinstance(value, float) else str(value)


# --------------------------------------------------------------------------- binary layouts


@dataclass(frozen=True, slots=True)
class ByteField:
    offset: int  # [byte]
    size: int  # [byte]
    type: str  # u8, u16, u32, f16, f32, f64
    name: str


_STRUCT_CODES = {"B": "u8", "H": "u16", "I": "u32", "e": "f16", "f": "f32", "d": "f64"}
_POSE_HEADER = ("version", "flags", "reserved")


def pose_layout() -> list[ByteField]:
    """The 64-byte pose, from `messages.POSE_LAYOUT`: header, then the Pose fields but flags."""
    fmt = m.POSE_LAYOUT.format
    assert fmt[0] == "<", "the pose layout must be little-endian"
    codes = [c for n, c in re.findall(r"(\d*)([A-Za-z])", fmt[1:]) for _ in range(int(n or 1))]
    names = [*_POSE_HEADER, *(f for f in m.Pose.__struct_fields__ if f != "flags")]
    assert len(codes) == len(names), "POSE_LAYOUT and Pose fields disagree"
    out, offset = [], 0
    for code, name in zip(codes, names, strict=True):
        size = struct.calcsize("<" + code)
        out.append(ByteField(offset, size, _STRUCT_CODES[code], name))
        offset += size
    return out


def npc_row_layout() -> list[ByteField]:
    """One NPC row, from the numpy dtype `messages.NPC_DTYPE`."""
    out = []
    for name in m.NPC_DTYPE.names or ():
        dtype, offset = m.NPC_DTYPE.fields[name][:2]  # type: ignore[index]
        out.append(ByteField(offset, dtype.itemsize, f"{dtype.kind}{dtype.itemsize * 8}", name))
    return out


def light_bits() -> list[tuple[int, str]]:
    """(bit value, name) of the `LIGHT_*` flags egos and NPC rows share."""
    return _constants("LIGHT_")


def pose_flags() -> list[tuple[int, str]]:
    """(bit value, name) of the `POSE_FLAG_*` flags in the pose header."""
    return _constants("POSE_FLAG_")


def _constants(prefix: str) -> list[tuple[int, str]]:
    return sorted((v, k.removeprefix(prefix).lower()) for k, v in vars(m).items()
                  if k.startswith(prefix))  # fmt: skip
