"""How one Zenoh sample becomes one MCAP message, and back (docs/architecture.md §11).

Every recorded message is a JSON object, described by a JSON Schema, so Foxglove opens a
recording without plugins:

    {"msg": {...the decoded message, fields by name...}, "raw": "<base64 of the payload>"}

`raw` keeps the payload exactly as it travelled (MessagePack or the fixed pose layout), so
`carlaverse replay` republishes byte-identical samples whatever the decoder thinks of them.
`msg` is a readable view: array-like Structs become objects with named fields, and bulk
byte fields with a known layout (NPC rows, skeleton angles) are expanded into numbers.
Keys without a known message type — added after this recorder was written — are still
recorded, with `raw` only; a payload that fails to decode keeps `raw` plus an `error`.

Types are looked up with `carlaverse.keys.parse` and `carlaverse.messages.CHANNEL_CODECS`,
so a new message type registered there is picked up without touching this module.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import msgspec
import numpy as np

from carlaverse import messages
from carlaverse.keys import KeySpaceError, parse

MESSAGE_ENCODING = "json"
SCHEMA_ENCODING = "jsonschema"
RAW_SCHEMA_NAME = "carlaverse.Raw"

_RAW_PROPERTY = {
    "type": "string",
    "contentEncoding": "base64",
    "description": "the payload exactly as published on the fabric",
}
_ERROR_PROPERTY = {"type": "string", "description": "why the payload did not decode"}

# What decoding or viewing a hostile payload can raise besides MessageError: bad UTF-8
# (a ValueError), deep nesting (RecursionError), integers no JSON encoder takes
# (OverflowError, msgspec.EncodeError). Any of them means "keep it raw", never "stop".
UNDECODABLE = (ValueError, ArithmeticError, RecursionError, TypeError, msgspec.MsgspecError)


class _Envelope(msgspec.Struct):
    """What replay needs of a recorded message; `msg` is skipped without being built."""

    raw: bytes = b""
    kind: str = "put"


_ENVELOPE_DECODER = msgspec.json.Decoder(_Envelope)


def payload_of(data: bytes) -> tuple[bytes, str]:
    """The original payload and sample kind ('put'/'delete') of a recorded JSON message."""
    try:
        env = _ENVELOPE_DECODER.decode(data)
    except (msgspec.DecodeError, msgspec.ValidationError) as exc:
        raise messages.MessageError(
            f"recorded message is not a carlaverse envelope: {exc}"
        ) from exc
    return env.raw, env.kind


# --------------------------------------------------------------------------- bulk byte views


def _dtype_schema(dtype: np.dtype) -> dict[str, Any]:
    props = {
        name: {"type": "integer" if dtype[name].kind in "iu" else "number"}
        for name in dtype.names or ()
    }
    return {"type": "array", "items": {"type": "object", "properties": props}}


def _npc_rows(value: bytes) -> list[dict[str, Any]]:
    names = messages.NPC_DTYPE.names or ()
    rows = np.frombuffer(value, dtype=messages.NPC_DTYPE).tolist()
    return [dict(zip(names, row, strict=True)) for row in rows]


def _float32s(value: bytes) -> list[float]:
    return np.frombuffer(value, dtype="<f4").tolist()


# (Struct, field) -> (view function, JSON Schema of the view). A field not listed here that
# holds bytes is shown as base64, which is always correct if less readable.
_BYTE_VIEWS: dict[tuple[type, str], tuple[Callable[[bytes], Any], dict[str, Any]]] = {
    (messages.NpcBatch, "rows"): (_npc_rows, _dtype_schema(messages.NPC_DTYPE)),
    (messages.Skeleton, "angles"): (
        _float32s,
        {"type": "array", "items": {"type": "number"}, "description": "[rad] roll, pitch, yaw"},
    ),
}


# --------------------------------------------------------------------------- JSON views


def to_view(obj: Any) -> Any:
    """A JSON-ready view of a decoded message: Structs as objects with named fields."""
    if isinstance(obj, msgspec.Struct):
        return _struct_view(obj)
    if isinstance(obj, list | tuple):
        return [to_view(v) for v in obj]
    if isinstance(obj, dict):
        return {k: to_view(v) for k, v in obj.items()}
    return obj  # scalars and bytes (msgspec writes bytes as base64)


def _struct_view(obj: msgspec.Struct) -> dict[str, Any]:
    cls = type(obj)
    config = cls.__struct_config__
    out: dict[str, Any] = {}
    if config.tag is not None:
        out[config.tag_field or "type"] = config.tag
    for name in cls.__struct_fields__:
        value = getattr(obj, name)
        view = _BYTE_VIEWS.get((cls, name))
        out[name] = _bytes_view(view[0], value) if view else to_view(value)
    return out


def _bytes_view(fn: Callable[[bytes], Any], value: bytes) -> Any:
    try:
        return fn(value)
    except ValueError:  # a length that is not a whole number of rows: show it as it is
        return value


# --------------------------------------------------------------------------- JSON Schemas


def message_schema(type_: Any) -> dict[str, Any]:
    """JSON Schema of the envelope for messages of `type_`, with every `$ref` inlined."""
    generated = msgspec.json.schema(type_)
    defs = generated.pop("$defs", {})
    classes = {cls.__name__: cls for cls in _struct_classes(type_)}
    for name, definition in defs.items():
        if name in classes:
            _as_object(definition, classes[name])
    return {
        "title": f"carlaverse.{_type_name(type_)}",
        "type": "object",
        "properties": {
            "msg": _inline(generated, defs),
            "raw": _RAW_PROPERTY,
            "error": _ERROR_PROPERTY,
        },
        "required": ["raw"],
    }


def raw_schema() -> dict[str, Any]:
    """JSON Schema of the envelope for keys whose message type this build does not know."""
    return {
        "title": RAW_SCHEMA_NAME,
        "type": "object",
        "properties": {"raw": _RAW_PROPERTY, "error": _ERROR_PROPERTY},
        "required": ["raw"],
    }


def _as_object(definition: dict[str, Any], cls: type[msgspec.Struct]) -> None:
    """Rewrite an array-like Struct's tuple schema as the object our views produce."""
    fields = cls.__struct_fields__
    if "prefixItems" in definition:
        items = definition.pop("prefixItems")
        for key in ("minItems", "maxItems", "items"):
            definition.pop(key, None)
        definition["type"] = "object"
        definition["properties"] = dict(zip(fields, items, strict=False))
    for name in fields:
        view = _BYTE_VIEWS.get((cls, name))
        if view and name in definition.get("properties", {}):
            definition["properties"][name] = view[1]


def _inline(node: Any, defs: dict[str, Any]) -> Any:
    """Replace `{"$ref": "#/$defs/X"}` by X itself; our message types are not recursive."""
    if isinstance(node, dict):
        ref = node.get("$ref")
        if isinstance(ref, str) and ref.startswith("#/$defs/"):
            return _inline(defs[ref.removeprefix("#/$defs/")], defs)
        return {k: _inline(v, defs) for k, v in node.items()}
    if isinstance(node, list):
        return [_inline(v, defs) for v in node]
    return node


def _struct_classes(type_: Any) -> list[type]:
    """Every Struct class reachable from `type_` (fields, lists, unions, ...)."""
    found: dict[type, None] = {}
    _walk(msgspec.inspect.type_info(type_), found)
    return list(found)


def _walk(info: Any, found: dict[type, None]) -> None:
    if isinstance(info, msgspec.inspect.StructType):
        if info.cls in found:
            return
        found[info.cls] = None
        for field in info.fields:
            _walk(field.type, found)
        return
    for attr in ("item_type", "key_type", "value_type"):
        if hasattr(info, attr):
            _walk(getattr(info, attr), found)
    for attr in ("item_types", "types"):
        for sub in getattr(info, attr, ()):
            _walk(sub, found)


def _type_name(type_: Any) -> str:
    name = getattr(type_, "__name__", None)
    if name:
        return name
    # A union has no name of its own; use the alias the messages package gives it (WorldEvent).
    aliases = [alias for alias, value in vars(messages).items() if value is type_]
    return aliases[0] if aliases else "Message"


# --------------------------------------------------------------------------- per key


@dataclass(frozen=True, slots=True)
class EncodedMessage:
    """One sample ready for MCAP."""

    data: bytes  # the JSON envelope
    t: float | None  # [s] session time the message carries, if any
    seq: int | None
    error: str = ""  # why the payload did not decode, "" if it did (or has no known type)


class KeyFormat:
    """How samples of one key are written: schema name + schema, and the encoder."""

    def __init__(self, key: str) -> None:
        self.key = key
        self.codec = _codec_for(key)
        self._encoder = msgspec.json.Encoder()
        if self.codec is None:
            self.schema_name = RAW_SCHEMA_NAME
        else:
            self.schema_name = f"carlaverse.{_type_name(self.codec.type)}"

    def schema_bytes(self) -> bytes:
        schema = raw_schema() if self.codec is None else message_schema(self.codec.type)
        return json.dumps(schema, separators=(",", ":")).encode()

    def encode(self, payload: bytes, kind: str = "put") -> EncodedMessage:
        """The JSON envelope of one payload; never raises on bad payloads (it records them)."""
        envelope: dict[str, Any] = {"raw": payload}
        if kind != "put":
            envelope["kind"] = kind
        if self.codec is None or kind != "put":
            return EncodedMessage(self._encoder.encode(envelope), None, None)
        try:
            msg = self.codec.decode(payload)
            envelope["msg"] = to_view(msg)
            data = self._encoder.encode(envelope)
        except UNDECODABLE as exc:
            reason = _reason(exc)
            raw_only = {k: v for k, v in envelope.items() if k != "msg"} | {"error": reason}
            return EncodedMessage(self._encoder.encode(raw_only), None, None, reason)
        return EncodedMessage(data, _time_of(msg), _seq_of(msg))


def _reason(exc: BaseException) -> str:
    # Bounded: a hostile payload must not make every error string megabytes long.
    return f"{type(exc).__name__}: {exc}"[:500]


def _seq_of(msg: Any) -> int | None:
    seq = getattr(msg, "seq", None)
    return seq if isinstance(seq, int) and not isinstance(seq, bool) else None


def _time_of(msg: Any) -> float | None:
    """The session time a message carries [s], if it is a finite number."""
    t = getattr(msg, "t", None)
    if isinstance(t, bool) or not isinstance(t, int | float):
        return None
    t = float(t) if -1e300 < t < 1e300 else math.nan  # ints beyond float range: not a time
    return t if math.isfinite(t) else None


def _codec_for(key: str) -> messages.Codec[Any] | None:
    try:
        parsed = parse(key)
    except KeySpaceError:
        return None
    return messages.CHANNEL_CODECS.get((parsed.area, parsed.channel))
