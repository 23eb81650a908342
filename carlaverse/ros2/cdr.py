"""CDR, the bytes a ROS 2 message travels as: OMG XCDR1 little-endian, as rmw_zenoh sends it.

    encode(ODOMETRY, {"header": {"frame_id": "map"}, ...}) -> bytes
    decode(ODOMETRY, payload) -> {"header": {"stamp": {...}, "frame_id": "map"}, ...}

A payload starts with the 4-byte encapsulation header 00 01 00 00 (CDR_LE, no options); each
primitive then sits at an offset (counted after the header) that is a multiple of its size; a
string is a uint32 length counting its NUL, its UTF-8 bytes and the NUL; a sequence is a uint32
count and its elements; a fixed array is its elements alone.

Values are plain dicts keyed by field name (a missing field encodes as its .msg default --
zero, "" or empty but for a few, like a Quaternion's w = 1); sequences are lists, a `uint8[]`
is bytes. Encoding follows a plan made once per type: the primitives between two strings or
collections, nested messages flattened, are one `struct` pack.

`decode` takes network input: whatever is wrong with it raises `CdrError` (a ValueError)
naming the field, never anything else.
"""

from __future__ import annotations

import struct
from collections.abc import Mapping
from typing import Any

from carlaverse.ros2.types import PRIMITIVE_SIZES, Field, MsgDef

ENCAPSULATION_LE = b"\x00\x01\x00\x00"
MAX_PAYLOAD = 16 * 1024 * 1024  # [bytes] far above any message this package takes in

_FORMATS = {
    "bool": "?", "byte": "B", "int8": "b", "uint8": "B", "int16": "h", "uint16": "H",
    "int32": "i", "uint32": "I", "int64": "q", "uint64": "Q", "float32": "f", "float64": "d",
}  # fmt: skip
_PACKERS = {name: struct.Struct("<" + code) for name, code in _FORMATS.items()}
_U32 = _PACKERS["uint32"]


class CdrError(ValueError):
    """A payload that is not the expected message in CDR."""


# --------------------------------------------------------------------------- encoding


class _Writer:
    def __init__(self) -> None:
        self.buf = bytearray(ENCAPSULATION_LE)

    def align(self, size: int) -> None:
        pad = -(len(self.buf) - 4) % size
        if pad:
            self.buf += b"\x00" * pad

    def primitive(self, name: str, value: Any) -> None:
        size = PRIMITIVE_SIZES[name]
        self.align(size)
        self.buf += _PACKERS[name].pack(value)

    def string(self, value: str) -> None:
        raw = value.encode("utf-8")
        self.primitive("uint32", len(raw) + 1)
        self.buf += raw + b"\x00"


def encode(definition: MsgDef, value: Mapping[str, Any]) -> bytes:
    """The CDR payload (encapsulation header included) of `value`, a `definition` message."""
    writer = _Writer()
    try:
        _write_message(writer, definition, value)
    except (struct.error, TypeError, AttributeError) as exc:
        raise CdrError(f"{definition.name}: cannot encode: {exc}") from exc
    return bytes(writer.buf)


def _write_message(writer: _Writer, definition: MsgDef, value: Mapping[str, Any]) -> None:
    for op in _plan(definition):
        if isinstance(op, _Run):
            op.write(writer, value)
        else:
            path, field = op
            _write_field(writer, field, _get(value, path))


class _Run:
    """Consecutive primitives of a message, its nested single fields flattened (a Pose is
    7 doubles): packed in one call with the padding their offset needs, which depends only on
    where the run starts modulo 8 (the largest alignment), so each start gets one format."""

    def __init__(self) -> None:
        self.leaves: list[tuple[tuple[str, ...], str, float]] = []  # (path, primitive, default)
        self.tree: _Tree = []
        self._packers: dict[int, struct.Struct] = {}

    def packer(self, residue: int) -> struct.Struct:
        packer = self._packers.get(residue)
        if packer is None:
            parts, offset = ["<"], residue
            for _, name, _ in self.leaves:
                size = PRIMITIVE_SIZES[name]
                pad = -offset % size
                parts.append(f"{pad}x{_FORMATS[name]}" if pad else _FORMATS[name])
                offset += pad + size
            packer = self._packers[residue] = struct.Struct("".join(parts))
        return packer

    def add(self, path: tuple[str, ...], name: str, default: float) -> None:
        self.leaves.append((path, name, default))
        # the leaves as a tree of keys, so that each nested dict is looked up once
        level = self.tree
        for key in path[:-1]:
            if not level or level[-1][0] != key or level[-1][1] is None:
                level.append((key, [], 0))
            level = level[-1][1]  # type: ignore[assignment]
        level.append((path[-1], None, default))

    def write(self, writer: _Writer, value: Mapping[str, Any]) -> None:
        values: list[Any] = []
        _collect(value, self.tree, values)
        writer.buf += self.packer((len(writer.buf) - 4) % 8).pack(*values)


# (key, its subtree or None for a primitive, the primitive's default)
_Tree = list[tuple[str, "_Tree | None", float]]


def _collect(value: Any, tree: _Tree, out: list[Any]) -> None:
    """The primitives `tree` names in nested dicts `value`, in order; a default for each
    one the message leaves out."""
    for key, sub, default in tree:
        item = value.get(key) if value else None
        if sub is None:
            out.append(default if item is None else item)
        else:
            _collect(item, sub, out)


_Op = _Run | tuple[tuple[str, ...], Field]
_PLANS: dict[str, list[_Op]] = {}  # by type name: a definition's hash walks all it holds


def _plan(definition: MsgDef) -> list[_Op]:
    """How to write a message: runs of primitives, and each string or collection."""
    plan = _PLANS.get(definition.name)
    if plan is None:
        plan = _PLANS[definition.name] = []
        _flatten(definition, (), plan)
    return plan


def _flatten(definition: MsgDef, prefix: tuple[str, ...], plan: list[_Op]) -> None:
    for field in definition.fields:
        path = (*prefix, field.name)
        nested = field.nested
        if field.collection == "single" and nested is not None:
            _flatten(nested, path, plan)
        elif field.collection == "single" and field.type != "string":
            run = plan[-1] if plan else None
            if not isinstance(run, _Run):
                run = _Run()
                plan.append(run)
            run.add(path, str(field.type), field.default)
        else:
            plan.append((path, field))


def _or(value: Any, default: float) -> Any:
    """`value`, or the field's default where the message leaves it out."""
    return default if value is None else value


def _get(value: Any, path: tuple[str, ...]) -> Any:
    """The value at `path` in nested dicts; None where a level is missing."""
    for key in path:
        if not value:
            return None
        value = value.get(key)
    return value


def _write_field(writer: _Writer, field: Field, value: Any) -> None:
    if field.collection == "single":
        _write_one(writer, field, value)
        return
    items = [] if value is None else value
    if field.collection == "sequence":
        writer.primitive("uint32", len(items))
    elif len(items) not in (0, field.size):
        raise CdrError(f"{field.name}: a fixed array of {field.size}, got {len(items)}")
    if field.nested is None and field.type != "string":
        _write_primitives(writer, str(field.type), items, field.size)
        return
    for item in items or [None] * field.size:
        _write_one(writer, field, item)


def _write_primitives(writer: _Writer, name: str, items: Any, size: int) -> None:
    """A collection of primitives in one piece: aligned once, then packed together (a
    covariance's 36 doubles are one `pack`, an absent one 288 zero bytes)."""
    if name in ("uint8", "byte") and isinstance(items, bytes | bytearray):
        writer.buf += items  # one byte each, no alignment
        return
    count = len(items) or size
    if not count:
        return
    writer.align(PRIMITIVE_SIZES[name])
    if not len(items):  # an absent fixed array: zeros
        writer.buf += bytes(PRIMITIVE_SIZES[name] * count)
        return
    writer.buf += struct.pack(f"<{count}{_FORMATS[name]}", *items)


def _write_one(writer: _Writer, field: Field, value: Any) -> None:
    nested = field.nested
    if nested is not None:
        _write_message(writer, nested, value or {})
    elif field.type == "string":
        writer.string(value or "")
    else:
        writer.primitive(str(field.type), _or(value, field.default))


# --------------------------------------------------------------------------- decoding


class _Reader:
    def __init__(self, buf: bytes | bytearray | memoryview) -> None:
        self.buf = bytes(buf)
        self.pos = 4

    def align(self, size: int) -> None:
        self.pos += -(self.pos - 4) % size

    def primitive(self, name: str) -> Any:
        size = PRIMITIVE_SIZES[name]
        self.align(size)
        if self.pos + size > len(self.buf):
            raise CdrError("payload ends inside a value")
        (value,) = _PACKERS[name].unpack_from(self.buf, self.pos)
        self.pos += size
        return value

    def take(self, n: int) -> bytes:
        if n < 0 or self.pos + n > len(self.buf):
            raise CdrError(f"payload ends before its {n} announced bytes")
        out = self.buf[self.pos : self.pos + n]
        self.pos += n
        return out

    def string(self) -> str:
        length = self.primitive("uint32")
        raw = self.take(length)
        if length == 0 or raw[-1] != 0:
            raise CdrError("string without its terminating NUL")
        try:
            return raw[:-1].decode("utf-8")
        except UnicodeDecodeError as exc:
            raise CdrError(f"string is not UTF-8: {exc.reason}") from exc


def decode(definition: MsgDef, payload: bytes | bytearray | memoryview) -> dict[str, Any]:
    """The message in a CDR payload; CdrError naming the field when it is not one."""
    if len(payload) > MAX_PAYLOAD:
        raise CdrError(f"{definition.name}: {len(payload)} bytes is over {MAX_PAYLOAD}")
    if bytes(payload[:4]) != ENCAPSULATION_LE:
        head = bytes(payload[:4]).hex()
        raise CdrError(f"{definition.name}: encapsulation {head!r} is not CDR little-endian")
    reader = _Reader(payload)
    return _read_message(reader, definition, definition.name)


def _read_message(reader: _Reader, definition: MsgDef, path: str) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for field in definition.fields:
        where = f"{path}.{field.name}"
        try:
            out[field.name] = _read_field(reader, field, where)
        except CdrError as exc:
            if str(exc).startswith(path):  # named deeper already
                raise
            raise CdrError(f"{where}: {exc}") from exc
    return out


def _read_field(reader: _Reader, field: Field, path: str) -> Any:
    if field.collection == "single":
        return _read_one(reader, field, path)
    if field.collection == "array":
        count = field.size
    else:
        count = reader.primitive("uint32")
        if count > len(reader.buf) - reader.pos:  # every element takes a byte at least
            raise CdrError(f"sequence of {count} is longer than the payload")
    if field.type in ("uint8", "byte"):
        return reader.take(count)
    return [_read_one(reader, field, f"{path}[{k}]") for k in range(count)]


def _read_one(reader: _Reader, field: Field, path: str) -> Any:
    nested = field.nested
    if nested is not None:
        return _read_message(reader, nested, path)
    if field.type == "string":
        return reader.string()
    return reader.primitive(str(field.type))
