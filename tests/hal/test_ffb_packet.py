"""The 40-byte FFB packet: exact layout, ranges, and a decoder that only raises its own error."""

from __future__ import annotations

import struct

import msgspec
import pytest
from hypothesis import given
from hypothesis import strategies as st

from carlaverse.hal import ffb_packet
from carlaverse.hal.ffb_packet import (
    FFB_PACKET_SIZE,
    FIELD_RANGES,
    FfbCommand,
    FfbPacketError,
    FfbPacketReason,
)


def commands() -> st.SearchStrategy[FfbCommand]:
    fields = {name: st.integers(low, high) for name, low, high in FIELD_RANGES}
    return st.builds(FfbCommand, **fields)


def test_field_table_matches_the_struct_in_wire_order() -> None:
    assert tuple(name for name, _, _ in FIELD_RANGES) == FfbCommand.__struct_fields__
    assert FFB_PACKET_SIZE == 40


def test_known_values_give_exact_bytes() -> None:
    command = FfbCommand(
        spring_stiffness=10000, spring_offset=-10000, spring_deadband=1, spring_saturation=2,
        constant_force=-1, damper=3, friction=4, inertia=5, vibration_magnitude=6,
        vibration_frequency_hz=1000,
    )  # fmt: skip
    expected = bytes.fromhex(
        "10270000"  # 10000
        "f0d8ffff"  # -10000
        "01000000" "02000000"
        "ffffffff"  # -1
        "03000000" "04000000" "05000000" "06000000"
        "e8030000"  # 1000 Hz
    )  # fmt: skip
    assert ffb_packet.encode(command) == expected
    assert ffb_packet.decode(expected) == command


def test_zero_command_is_forty_zero_bytes() -> None:
    assert ffb_packet.encode(FfbCommand()) == bytes(40)
    assert ffb_packet.decode(bytes(40)).is_zero()


@given(commands())
def test_every_in_range_command_round_trips(command: FfbCommand) -> None:
    packet = ffb_packet.encode(command)
    assert len(packet) == 40
    assert ffb_packet.decode(packet) == command
    assert struct.unpack("<10i", packet) == msgspec.structs.astuple(command)


@pytest.mark.parametrize("index", range(10))
@given(data=st.data())
def test_each_field_outside_its_range_is_rejected(index: int, data: st.DataObject) -> None:
    name, low, high = FIELD_RANGES[index]
    bad = data.draw(st.integers(-(2**31), low - 1) | st.integers(high + 1, 2**31 - 1))
    values = [0] * 10
    values[index] = bad
    with pytest.raises(FfbPacketError) as info:
        ffb_packet.decode(struct.pack("<10i", *values))
    assert info.value.reason is FfbPacketReason.OUT_OF_RANGE
    assert name in str(info.value)
    with pytest.raises(FfbPacketError):
        ffb_packet.encode(FfbCommand(**{name: bad}))


@pytest.mark.parametrize("index", range(10))
@given(data=st.data())
def test_each_field_at_any_in_range_value_decodes(index: int, data: st.DataObject) -> None:
    name, low, high = FIELD_RANGES[index]
    value = data.draw(st.integers(low, high))
    values = [0] * 10
    values[index] = value
    assert getattr(ffb_packet.decode(struct.pack("<10i", *values)), name) == value


@given(st.binary(max_size=200))
def test_any_bytes_decode_or_raise_the_codec_error(data: bytes) -> None:
    try:
        command = ffb_packet.decode(data)
    except FfbPacketError as exc:
        assert isinstance(exc, ValueError)
        return
    assert ffb_packet.encode(command) == data


@given(st.binary(min_size=40, max_size=40))
def test_any_forty_bytes_decode_or_raise_out_of_range(data: bytes) -> None:
    try:
        ffb_packet.decode(data)
    except FfbPacketError as exc:
        assert exc.reason is FfbPacketReason.OUT_OF_RANGE


@pytest.mark.parametrize("size", [0, 1, 39, 41, 80])
def test_wrong_sizes_are_rejected(size: int) -> None:
    with pytest.raises(FfbPacketError) as info:
        ffb_packet.decode(bytes(size))
    assert info.value.reason is FfbPacketReason.WRONG_SIZE
    assert str(size) in str(info.value)


def test_decode_accepts_memoryview_and_bytearray() -> None:
    packet = ffb_packet.encode(FfbCommand(damper=7))
    assert ffb_packet.decode(memoryview(packet)).damper == 7
    assert ffb_packet.decode(bytearray(packet)).damper == 7


def test_encode_rejects_non_integers() -> None:
    with pytest.raises(FfbPacketError) as info:
        ffb_packet.encode(FfbCommand(damper=1.5))  # type: ignore[arg-type]
    assert info.value.reason is FfbPacketReason.NOT_AN_INTEGER


def test_a_torque_toward_the_left_is_a_negative_constant_force() -> None:
    """The wire's constant_force is positive toward the right; physics' torque toward the left.
    2 N·m left of an 8 N·m full scale is a quarter of full scale, to the left: −2500."""
    assert ffb_packet.constant_force(2.0, 8.0) == -2500
    assert ffb_packet.constant_force(-2.0, 8.0) == 2500
    assert ffb_packet.constant_force(-80.0, 8.0) == ffb_packet.FULL_SCALE  # clamped, not raised
    assert ffb_packet.constant_force(80.0, 8.0) == -ffb_packet.FULL_SCALE
