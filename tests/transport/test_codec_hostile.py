"""Hostile payloads against every codec: whatever arrives, decoding raises only MessageError.

Each example message is decoded to plain MessagePack values, one value somewhere inside it is
replaced (or an unknown field added) with something hostile — deep nesting, bad UTF-8,
NaN and infinities, integers at the int64/uint64 edges — and re-encoded byte-exact with
`msgspec.Raw`. The codec must either return its message type or raise `MessageError`.
"""

from __future__ import annotations

import math
import struct
from typing import Any

import msgspec
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from carlaverse import messages as m
from tests.transport.test_messages import POSE, examples

STRUCT_EXAMPLES = [(c, msg) for c, msg in examples() if c is not m.POSE]
IDS = [type(msg).__name__ for _, msg in STRUCT_EXAMPLES]
DEPTH = 200_000  # far past msgspec's recursion limit


def raw_str(data: bytes) -> bytes:
    """A MessagePack str header + `data` as is (a str the encoder would never write)."""
    if len(data) < 32:
        return bytes([0xA0 | len(data)]) + data
    return b"\xda" + struct.pack(">H", len(data)) + data


def deep_array(depth: int) -> bytes:
    return b"\x91" * depth + b"\xc0"


def deep_map(depth: int) -> bytes:
    return b"\x81\xa1k" * depth + b"\xc0"


BAD_UTF8 = [
    raw_str(b"\xff\xfe\xfd"),
    raw_str(b"ok\xc3("),  # a truncated two-byte sequence
    raw_str(b"\xed\xa0\x80"),  # an encoded surrogate
]
NON_FINITE = [
    b"\xcb" + struct.pack(">d", math.nan),
    b"\xcb" + struct.pack(">d", math.inf),
    b"\xcb" + struct.pack(">d", -math.inf),
    b"\xca" + struct.pack(">f", math.nan),
]
HOSTILE_RAW = [
    deep_array(DEPTH),
    deep_map(DEPTH),
    *BAD_UTF8,
    *NON_FINITE,
    b"\xcf" + struct.pack(">Q", 2**64 - 1),
    b"\xd3" + struct.pack(">q", -(2**63)),
    b"\xc1",  # never-used byte
    b"\xdd\xff\xff\xff\xff",  # an array header claiming 4 G elements, then nothing
    b"\xc6\xff\xff\xff\xf0",  # a bin claiming 4 GB
]


def plain(codec: m.Codec, msg: object) -> Any:
    return msgspec.msgpack.decode(codec.encode(msg))


def leaves(value: Any, path: tuple = ()) -> list[tuple[tuple, Any]]:
    """Every (path, leaf) in a plain MessagePack value; keys of maps are not leaves."""
    if isinstance(value, dict):
        return [p for k, v in value.items() for p in leaves(v, (*path, k))]
    if isinstance(value, list):
        return [p for i, v in enumerate(value) for p in leaves(v, (*path, i))]
    return [(path, value)]


def replaced(value: Any, path: tuple, new: Any) -> Any:
    if not path:
        return new
    head, rest = path[0], path[1:]
    if isinstance(value, dict):
        return {**value, head: replaced(value[head], rest, new)}
    return [replaced(v, rest, new) if i == head else v for i, v in enumerate(value)]


def with_unknown_field(value: Any, raw: bytes) -> Any:
    """An extra field a newer version might send: a new key in a map, a trailing element."""
    if isinstance(value, dict):
        return {**value, "from_the_future": msgspec.Raw(raw)}
    return [*value, msgspec.Raw(raw)]


def decodes_or_refuses(codec: m.Codec, payload: bytes) -> object | None:
    try:
        return codec.decode(payload)
    except m.MessageError:
        return None


@pytest.mark.parametrize("codec,msg", STRUCT_EXAMPLES, ids=IDS)
@pytest.mark.parametrize("raw", HOSTILE_RAW, ids=range(len(HOSTILE_RAW)))
def test_hostile_value_in_an_unknown_field_is_only_a_message_error(
    codec: m.Codec, msg: object, raw: bytes
) -> None:
    decodes_or_refuses(codec, msgspec.msgpack.encode(with_unknown_field(plain(codec, msg), raw)))


@pytest.mark.parametrize("codec,msg", STRUCT_EXAMPLES, ids=IDS)
def test_hostile_value_in_every_known_field_is_refused(codec: m.Codec, msg: object) -> None:
    base = plain(codec, msg)
    for path, _ in leaves(base):
        for raw in HOSTILE_RAW:
            payload = msgspec.msgpack.encode(replaced(base, path, msgspec.Raw(raw)))
            out = decodes_or_refuses(codec, payload)
            # a value of another kind may fit an optional field (an int64 edge in an int
            # field); a non-finite number, bad text or deep nesting never does
            assert out is None or raw not in [*NON_FINITE, *BAD_UTF8, *HOSTILE_RAW[:2]], path


@pytest.mark.parametrize("codec,msg", STRUCT_EXAMPLES, ids=IDS)
def test_non_finite_and_int64_overflow_are_refused_in_every_numeric_field(
    codec: m.Codec, msg: object
) -> None:
    base = plain(codec, msg)
    numeric = [(p, v) for p, v in leaves(base) if type(v) in (int, float)]
    for path, leaf in numeric:
        bad = [math.nan, math.inf, -math.inf] if isinstance(leaf, float) else [2**64 - 1]
        for value in bad:
            with pytest.raises(m.MessageError):
                codec.decode(msgspec.msgpack.encode(replaced(base, path, value)))


def test_a_whole_payload_of_deep_nesting_is_a_message_error() -> None:
    for codec in {id(c): c for c, _ in examples()}.values():
        for raw in (deep_array(DEPTH), deep_map(DEPTH)):
            with pytest.raises(m.MessageError):
                codec.decode(raw)


hostile_scalars = st.one_of(
    st.sampled_from([math.nan, math.inf, -math.inf, 2**64 - 1, -(2**63), 2**63, 0, -1]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(2**63), max_value=2**64 - 1),
    st.binary(max_size=40).map(lambda b: msgspec.Raw(raw_str(b))),  # arbitrary bytes as str
    st.text(max_size=20),
    st.binary(max_size=40),
    st.none(),
    st.booleans(),
    st.integers(min_value=1, max_value=DEPTH).map(lambda d: msgspec.Raw(deep_array(d))),
)
hostile_values = st.recursive(
    hostile_scalars,
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner),
    max_leaves=8,
)


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_any_hostile_value_anywhere_is_decoded_or_refused(data: st.DataObject) -> None:
    codec, msg = data.draw(st.sampled_from(STRUCT_EXAMPLES))
    base = plain(codec, msg)
    value = data.draw(hostile_values)
    targets = [path for path, _ in leaves(base)]
    path = data.draw(st.sampled_from([None, *targets]))
    if path is None:
        mutated = with_unknown_field(base, msgspec.msgpack.encode(value))
    else:
        mutated = replaced(base, path, value)
    out = decodes_or_refuses(codec, msgspec.msgpack.encode(mutated))
    if out is not None:
        # whatever was accepted re-encodes: nothing unencodable slipped through
        codec.decode(codec.encode(out))


@given(st.binary(min_size=m.POSE_SIZE, max_size=m.POSE_SIZE))
def test_any_64_bytes_are_a_pose_or_a_message_error(data: bytes) -> None:
    pose = decodes_or_refuses(m.POSE, data)
    if pose is not None:
        assert all(math.isfinite(v) for v in msgspec.structs.astuple(pose))


@pytest.mark.parametrize(
    "codec,msg",
    [
        (m.POSE, msgspec.structs.replace(POSE, flags=300)),  # flags is one byte
        (m.POSE, msgspec.structs.replace(POSE, t=None)),  # type: ignore[arg-type]
        (m.EGO_STATE, m.EgoState(2**70, 1.0)),
        (m.OVERRIDE, m.Override(1, 1.0, "\udcff")),  # a lone surrogate is not UTF-8
        (m.WORLD_EVENT, m.Spawned(1, 1.0, "n", object())),  # type: ignore[arg-type]
    ],
    ids=["pose-flags", "pose-none", "int-overflow", "surrogate", "not-a-str"],
)
def test_a_message_that_cannot_be_encoded_is_a_message_error(codec: m.Codec, msg: object) -> None:
    with pytest.raises(m.MessageError, match=r"encode|fit"):
        codec.encode(msg)
