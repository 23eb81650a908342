"""The 21-byte FRAME_UPDATE: exact layout, limits, and a decoder that only raises its error."""

from __future__ import annotations

import math
import struct

import msgspec
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from carlaverse.hal import motion_packet
from carlaverse.hal.motion_packet import (
    DEFAULT_LIMITS,
    FIELDS,
    FRAME_SIZE,
    MotionFrame,
    MotionLimits,
    MotionPacketError,
    MotionPacketReason,
)


def f32(x: float) -> float:
    return struct.unpack("<f", struct.pack("<f", x))[0]


def f32_below(bound: float) -> float:
    """The largest float32 not above `bound`."""
    x = np.float32(bound)
    return float(np.nextafter(x, np.float32(0)) if float(x) > bound else x)


def frames(limits: MotionLimits = DEFAULT_LIMITS) -> st.SearchStrategy[MotionFrame]:
    bounds = [f32_below(b) for b in limits.bounds()]
    values = [st.floats(-b, b, allow_nan=False, width=32) for b in bounds]
    return st.builds(MotionFrame, *values)


def test_known_frame_gives_exact_bytes() -> None:
    frame = MotionFrame(roll=0.5, pitch=-0.25, heave=0.125, rpm=3000.0, torque=-150.0)
    expected = bytes.fromhex("040000003f000080be0000003e00803b45000016c3")
    assert FRAME_SIZE == 21
    assert motion_packet.encode(frame) == expected
    assert motion_packet.decode(expected) == frame


def test_neutral_frame() -> None:
    assert motion_packet.encode(MotionFrame()) == b"\x04" + bytes(20)


@given(frames())
def test_float32_frames_round_trip_exactly(frame: MotionFrame) -> None:
    assert motion_packet.decode(motion_packet.encode(frame)) == frame


@given(st.floats(-1.5, 1.5, allow_nan=False))
def test_double_values_round_to_float32(roll: float) -> None:
    assert motion_packet.decode(motion_packet.encode(MotionFrame(roll=roll))).roll == f32(roll)


@pytest.mark.parametrize("index", range(5))
@given(data=st.data())
def test_each_field_over_its_limit_is_rejected(index: int, data: st.DataObject) -> None:
    bound = DEFAULT_LIMITS.bounds()[index]
    magnitude = data.draw(st.floats(bound * 1.01, 3e38))  # clear of float32 rounding
    sign = data.draw(st.sampled_from([-1.0, 1.0]))
    values = [0.0] * 5
    values[index] = sign * magnitude
    with pytest.raises(MotionPacketError) as info:
        motion_packet.decode(struct.pack("<B5f", 4, *values))
    assert info.value.reason is MotionPacketReason.OUT_OF_RANGE
    assert FIELDS[index] in str(info.value)
    with pytest.raises(MotionPacketError):
        motion_packet.encode(MotionFrame(*values))


@pytest.mark.parametrize("index", range(5))
@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_values_are_rejected(index: int, bad: float) -> None:
    values = [0.0] * 5
    values[index] = bad
    with pytest.raises(MotionPacketError) as info:
        motion_packet.decode(struct.pack("<B5f", 4, *values))
    assert info.value.reason is MotionPacketReason.NOT_FINITE


def test_limits_are_configurable() -> None:
    tight = MotionLimits(roll_rad=0.1)
    packet = motion_packet.encode(MotionFrame(roll=0.2))
    with pytest.raises(MotionPacketError):
        motion_packet.decode(packet, tight)
    with pytest.raises(MotionPacketError):
        motion_packet.encode(MotionFrame(roll=0.2), tight)
    with pytest.raises(msgspec.ValidationError):
        msgspec.convert({"roll_rad": -1}, MotionLimits)


SMALL = MotionLimits(roll_rad=0.1, pitch_rad=0.1, heave_m=0.02, rpm=3000.0, torque_nm=50.0)


@given(st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=5, max_size=5))
def test_clip_makes_any_frame_encodable_and_changes_only_what_it_must(values: list[float]) -> None:
    frame = MotionFrame(*values)
    inside, clipped = motion_packet.clip(frame, SMALL)
    motion_packet.encode(inside, SMALL)  # never raises: within every limit, all finite
    for before, after, bound in zip(values, msgspec.structs.astuple(inside), SMALL.bounds(),
                                    strict=True):  # fmt: skip
        if not math.isfinite(before):
            assert after == 0.0  # the field's neutral
        elif abs(before) <= bound:
            assert after == before  # a value within its limit passes untouched
        else:
            assert after == math.copysign(bound, before)  # the limit, on the value's side
    assert clipped == (inside != frame)


@pytest.mark.parametrize("size", range(1, 21))
def test_short_frames_are_rejected_as_short(size: int) -> None:
    with pytest.raises(MotionPacketError) as info:
        motion_packet.decode(b"\x04" + bytes(size - 1))
    assert info.value.reason is MotionPacketReason.SHORT


def test_empty_long_and_unknown_command() -> None:
    with pytest.raises(MotionPacketError) as info:
        motion_packet.decode(b"")
    assert info.value.reason is MotionPacketReason.SHORT
    with pytest.raises(MotionPacketError) as info:
        motion_packet.decode(b"\x04" + bytes(21))
    assert info.value.reason is MotionPacketReason.LONG
    with pytest.raises(MotionPacketError) as info:
        motion_packet.decode(b"\x05" + bytes(20))
    assert info.value.reason is MotionPacketReason.UNKNOWN_COMMAND
    assert "0x05" in str(info.value)


@given(st.binary(max_size=100))
def test_any_bytes_decode_or_raise_the_codec_error(data: bytes) -> None:
    try:
        frame = motion_packet.decode(data)
    except MotionPacketError as exc:
        assert isinstance(exc, ValueError)
        return
    assert len(data) == 21 and data[0] == 4
    assert motion_packet.decode(motion_packet.encode(frame)) == frame


@given(st.binary(min_size=20, max_size=20))
def test_any_frame_update_body_decodes_or_raises(body: bytes) -> None:
    try:
        frame = motion_packet.decode(b"\x04" + body)
    except MotionPacketError as exc:
        assert exc.reason in (MotionPacketReason.NOT_FINITE, MotionPacketReason.OUT_OF_RANGE)
        return
    assert all(math.isfinite(v) for v in msgspec.structs.astuple(frame))
