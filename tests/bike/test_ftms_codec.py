"""FTMS byte codecs, field by field against hand-assembled bytes, and with Hypothesis."""

from __future__ import annotations

import struct

import pytest
from hypothesis import given
from hypothesis import strategies as st

from carlaverse.hal.trainer import ftms_codec as codec
from carlaverse.hal.trainer.ftms_codec import FtmsError, FtmsReason, IndoorBikeData, OpCode


def test_speed_cadence_power_as_a_kickr_sends_them() -> None:
    # flags 0x0044: bit 0 clear (speed present), bit 2 cadence, bit 6 power
    data = bytes([0x44, 0x00, 0xC4, 0x09, 0xAA, 0x00, 0xC8, 0x00])
    sample = codec.decode_bike_data(data)
    assert sample.speed_kmh == pytest.approx(25.0)  # 0x09C4 = 2500 × 0.01 km/h
    assert sample.cadence_rpm == pytest.approx(85.0)  # 0x00AA = 170 × 0.5 /min
    assert sample.power_w == 200
    assert sample.total_distance_m is None and sample.heart_rate_bpm is None
    assert codec.encode_bike_data(sample) == data


def test_every_field_in_spec_order() -> None:
    flags = 0x1FFE  # bits 1..12 set, bit 0 clear: all thirteen fields present
    body = (
        struct.pack("<HHHH", 3000, 2900, 180, 170)  # speed, avg speed, cadence, avg cadence
        + (123456).to_bytes(3, "little")  # total distance [m], uint24
        + struct.pack("<hhh", -3, -15, 210)  # resistance, power (negative: braking), avg power
        + struct.pack("<HHB", 55, 600, 10)  # energy total, per hour, per minute
        + struct.pack("<BBHH", 142, 85, 3600, 120)  # HR, MET ×10, elapsed, remaining
    )
    sample = codec.decode_bike_data(struct.pack("<H", flags) + body)
    assert sample == IndoorBikeData(
        speed_kmh=30.0, average_speed_kmh=29.0, cadence_rpm=90.0, average_cadence_rpm=85.0,
        total_distance_m=123456, resistance_level=-3, power_w=-15, average_power_w=210,
        energy_kcal=(55, 600, 10), heart_rate_bpm=142, metabolic_equivalent=pytest.approx(8.5),
        elapsed_time_s=3600, remaining_time_s=120,
    )  # fmt: skip


def test_more_data_flag_means_no_speed() -> None:
    sample = codec.decode_bike_data(bytes([0x41, 0x00, 0x64, 0x00]))  # bit 0 set + power
    assert sample.speed_kmh is None and sample.power_w == 100


@pytest.mark.parametrize(
    ("data", "reason"),
    [
        (b"\x44", FtmsReason.TRUNCATED),
        (bytes([0x44, 0x00, 0xC4, 0x09, 0xAA]), FtmsReason.TRUNCATED),
        (bytes([0x01, 0x00, 0xFF]), FtmsReason.TRAILING_BYTES),
    ],
)
def test_malformed_bike_data_is_an_ftms_error(data: bytes, reason: FtmsReason) -> None:
    with pytest.raises(FtmsError) as info:
        codec.decode_bike_data(data)
    assert info.value.reason == reason


def test_control_point_requests_byte_by_byte() -> None:
    assert codec.request_control() == b"\x00"
    assert codec.set_target_resistance(42.5) == b"\x04" + struct.pack("<h", 425)
    assert codec.set_target_power(250) == b"\x05\xfa\x00"
    sim = codec.Simulation(wind_mps=-1.5, grade_percent=4.25, crr=0.0040, cw_kg_per_m=0.51)
    # wind −1500 mm/s, grade 425 × 0.01 %, Crr 40 × 0.0001, Cw 51 × 0.01 kg/m
    assert codec.set_simulation(sim) == b"\x11" + struct.pack("<hhBB", -1500, 425, 40, 51)
    assert codec.decode_request(codec.set_simulation(sim)) == (OpCode.SET_SIMULATION, sim)
    assert codec.decode_request(b"\x04\x7f") == (OpCode.SET_TARGET_RESISTANCE, 12.7)  # v1.0 uint8
    assert codec.decode_request(b"\x00") == (OpCode.REQUEST_CONTROL, None)


def test_responses_and_bad_writes() -> None:
    assert codec.encode_response(0x04, codec.ResultCode.SUCCESS) == b"\x80\x04\x01"
    response = codec.decode_response(b"\x80\x00\x05")
    assert response.op == 0 and response.result == codec.ResultCode.CONTROL_NOT_PERMITTED
    assert not response.ok
    for bad, reason in [(b"\x81\x00\x01", FtmsReason.NOT_A_RESPONSE),
                        (b"\x80\x00", FtmsReason.TRUNCATED),
                        (b"\x80\x00\x09", FtmsReason.OUT_OF_RANGE)]:  # fmt: skip
        with pytest.raises(FtmsError) as info:
            codec.decode_response(bad)
        assert info.value.reason == reason
    with pytest.raises(FtmsError, match="op code 0x42"):
        codec.decode_request(b"\x42")
    with pytest.raises(FtmsError, match="SET_TARGET_POWER with 1"):
        codec.decode_request(b"\x05\x01")
    with pytest.raises(FtmsError, match="does not fit"):
        codec.set_target_power(40000)


optional = lambda s: st.none() | s  # noqa: E731
SAMPLES = st.builds(
    IndoorBikeData,
    speed_kmh=optional(st.integers(0, 65535).map(lambda v: v / 100)),
    average_speed_kmh=optional(st.integers(0, 65535).map(lambda v: v / 100)),
    cadence_rpm=optional(st.integers(0, 65535).map(lambda v: v / 2)),
    average_cadence_rpm=optional(st.integers(0, 65535).map(lambda v: v / 2)),
    total_distance_m=optional(st.integers(0, 2**24 - 1)),
    resistance_level=optional(st.integers(-32768, 32767)),
    power_w=optional(st.integers(-32768, 32767)),
    average_power_w=optional(st.integers(-32768, 32767)),
    energy_kcal=optional(
        st.tuples(st.integers(0, 65535), st.integers(0, 65535), st.integers(0, 255))
    ),
    heart_rate_bpm=optional(st.integers(0, 255)),
    metabolic_equivalent=optional(st.integers(0, 255).map(lambda v: v / 10)),
    elapsed_time_s=optional(st.integers(0, 65535)),
    remaining_time_s=optional(st.integers(0, 65535)),
)


@given(SAMPLES)
def test_bike_data_round_trips(sample: IndoorBikeData) -> None:
    decoded = codec.decode_bike_data(codec.encode_bike_data(sample))
    for name in IndoorBikeData.__struct_fields__:
        a, b = getattr(sample, name), getattr(decoded, name)
        assert (a is None) == (b is None), name
        if isinstance(a, float):
            assert b == pytest.approx(a, abs=1e-9), name
        else:
            assert a == b, name


@given(st.binary(max_size=40))
def test_any_bytes_decode_or_raise_ftms_error(data: bytes) -> None:
    for decode in (codec.decode_bike_data, codec.decode_request, codec.decode_response):
        try:
            decode(data)
        except FtmsError:
            pass


@given(st.integers(0, 1000).map(lambda v: v / 10))
def test_resistance_request_round_trips(level: float) -> None:
    op, value = codec.decode_request(codec.set_target_resistance(level))
    assert op == OpCode.SET_TARGET_RESISTANCE and value == pytest.approx(level)
