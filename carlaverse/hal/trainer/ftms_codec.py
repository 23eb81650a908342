"""Byte codecs of the Bluetooth Fitness Machine Service (FTMS, service 0x1826) for bikes.

Indoor Bike Data (characteristic 0x2AD2, notify): a little-endian uint16 of flags, then the
fields the flags announce, in this order (FTMS v1.0 §4.9):

    bit  field (present when the bit is 1, except bit 0)   type    resolution
    0    More Data — Instantaneous Speed present when 0    uint16  0.01 km/h
    1    Average Speed                                     uint16  0.01 km/h
    2    Instantaneous Cadence                             uint16  0.5 /min
    3    Average Cadence                                   uint16  0.5 /min
    4    Total Distance                                    uint24  1 m
    5    Resistance Level                                  sint16  1 (unitless)
    6    Instantaneous Power                               sint16  1 W
    7    Average Power                                     sint16  1 W
    8    Expended Energy: total, per hour, per minute      uint16, uint16, uint8  kcal
    9    Heart Rate                                        uint8   1 /min
    10   Metabolic Equivalent                              uint8   0.1
    11   Elapsed Time                                      uint16  1 s
    12   Remaining Time                                    uint16  1 s

Fitness Machine Control Point (0x2AD9, write + indicate): an op code and its parameters;
the machine answers 0x80, the request's op code and a result code. The op codes used here:

    0x00 Request Control                       —
    0x01 Reset                                 —
    0x04 Set Target Resistance Level           sint16, 0.1 (of the machine's level range;
                                               v1.0 machines send a uint8, also decoded)
    0x05 Set Target Power                      sint16, 1 W
    0x07 Start or Resume                       —
    0x11 Set Indoor Bike Simulation Parameters sint16 wind 0.001 m/s, sint16 grade 0.01 %,
                                               uint8 Crr 0.0001, uint8 Cw 0.01 kg/m

Decoding raises only `FtmsError` (a ValueError) with a `reason`: network input is checked,
never trusted.
"""

from __future__ import annotations

import enum
import struct
from typing import Any

import msgspec

FTMS_SERVICE = "00001826-0000-1000-8000-00805f9b34fb"
INDOOR_BIKE_DATA = "00002ad2-0000-1000-8000-00805f9b34fb"
CONTROL_POINT = "00002ad9-0000-1000-8000-00805f9b34fb"

RESPONSE_CODE = 0x80


class OpCode(enum.IntEnum):
    REQUEST_CONTROL = 0x00
    RESET = 0x01
    SET_TARGET_RESISTANCE = 0x04
    SET_TARGET_POWER = 0x05
    START_OR_RESUME = 0x07
    SET_SIMULATION = 0x11


class ResultCode(enum.IntEnum):
    SUCCESS = 0x01
    NOT_SUPPORTED = 0x02
    INVALID_PARAMETER = 0x03
    OPERATION_FAILED = 0x04
    CONTROL_NOT_PERMITTED = 0x05


class FtmsReason(enum.Enum):
    TRUNCATED = "truncated"
    TRAILING_BYTES = "trailing bytes"
    UNKNOWN_OP_CODE = "unknown op code"
    NOT_A_RESPONSE = "not a response"
    OUT_OF_RANGE = "out of range"


class FtmsError(ValueError):
    """A malformed or out-of-range FTMS payload."""

    def __init__(self, reason: FtmsReason, message: str) -> None:
        super().__init__(message)
        self.reason = reason


class IndoorBikeData(msgspec.Struct, frozen=True, kw_only=True):
    """One Indoor Bike Data notification; None where the flags leave a field out."""

    speed_kmh: float | None = None
    average_speed_kmh: float | None = None
    cadence_rpm: float | None = None
    average_cadence_rpm: float | None = None
    total_distance_m: int | None = None
    resistance_level: int | None = None
    power_w: int | None = None
    average_power_w: int | None = None
    energy_kcal: tuple[int, int, int] | None = None  # total, per hour, per minute
    heart_rate_bpm: int | None = None
    metabolic_equivalent: float | None = None
    elapsed_time_s: int | None = None
    remaining_time_s: int | None = None


# (flag bit, field, struct format, resolution); the uint24 distance is special-cased.
_FIELDS: tuple[tuple[int, str, str, float], ...] = (
    (0, "speed_kmh", "<H", 0.01),
    (1, "average_speed_kmh", "<H", 0.01),
    (2, "cadence_rpm", "<H", 0.5),
    (3, "average_cadence_rpm", "<H", 0.5),
    (4, "total_distance_m", "uint24", 1),
    (5, "resistance_level", "<h", 1),
    (6, "power_w", "<h", 1),
    (7, "average_power_w", "<h", 1),
    (8, "energy_kcal", "<HHB", 1),
    (9, "heart_rate_bpm", "<B", 1),
    (10, "metabolic_equivalent", "<B", 0.1),
    (11, "elapsed_time_s", "<H", 1),
    (12, "remaining_time_s", "<H", 1),
)


def _present(flags: int, bit: int) -> bool:
    return not flags & 1 if bit == 0 else bool(flags >> bit & 1)


def decode_bike_data(data: bytes | bytearray) -> IndoorBikeData:
    """Parse an Indoor Bike Data notification by its flags."""
    data = bytes(data)
    if len(data) < 2:
        raise FtmsError(FtmsReason.TRUNCATED, f"Indoor Bike Data of {len(data)} bytes")
    flags = int.from_bytes(data[:2], "little")
    at = 2
    values: dict[str, Any] = {}  # each field its own type (energy is a triple)
    for bit, name, fmt, resolution in _FIELDS:
        if not _present(flags, bit):
            continue
        size = 3 if fmt == "uint24" else struct.calcsize(fmt)
        if at + size > len(data):
            raise FtmsError(FtmsReason.TRUNCATED, f"Indoor Bike Data ends inside {name}")
        raw = data[at : at + size]
        at += size
        if fmt == "uint24":
            values[name] = int.from_bytes(raw, "little")
        elif name == "energy_kcal":
            values[name] = struct.unpack(fmt, raw)
        else:
            (value,) = struct.unpack(fmt, raw)
            values[name] = value * resolution if resolution != 1 else value
    if at != len(data):
        raise FtmsError(FtmsReason.TRAILING_BYTES, f"{len(data) - at} bytes after the last field")
    return IndoorBikeData(**values)


def encode_bike_data(sample: IndoorBikeData) -> bytes:
    """The notification bytes for `sample` (the simulated trainer speaks this)."""
    flags, body = 0, b""
    for bit, name, fmt, resolution in _FIELDS:
        value = getattr(sample, name)
        if value is None:
            flags |= 1 if bit == 0 else 0  # no speed: set "More Data"
            continue
        flags |= 0 if bit == 0 else 1 << bit
        if fmt == "uint24":
            body += _ranged(name, int(value), 0, 0xFFFFFF).to_bytes(3, "little")
        elif name == "energy_kcal":
            body += struct.pack(fmt, *value)
        else:
            body += _pack(name, fmt, round(value / resolution))
    return flags.to_bytes(2, "little") + body


def _pack(name: str, fmt: str, value: int) -> bytes:
    try:
        return struct.pack(fmt, value)
    except struct.error as exc:
        raise FtmsError(FtmsReason.OUT_OF_RANGE, f"{name} = {value} does not fit {fmt}") from exc


def _ranged(name: str, value: int, low: int, high: int) -> int:
    if not low <= value <= high:
        raise FtmsError(FtmsReason.OUT_OF_RANGE, f"{name} = {value} outside {low}..{high}")
    return value


# ------------------------------------------------------------------ control point requests


class Simulation(msgspec.Struct, frozen=True):
    """Indoor bike simulation parameters (op code 0x11)."""

    wind_mps: float = 0.0  # [m/s] positive: headwind (FTMS's sign)
    grade_percent: float = 0.0  # [%]
    crr: float = 0.004  # rolling-resistance coefficient [-]
    cw_kg_per_m: float = 0.51  # wind resistance coefficient ½·ρ·c_W·A [kg/m]


def request_control() -> bytes:
    return bytes([OpCode.REQUEST_CONTROL])


def start_or_resume() -> bytes:
    return bytes([OpCode.START_OR_RESUME])


def set_target_resistance(level: float) -> bytes:
    """Target resistance level (in the machine's level unit, here percent) at 0.1 resolution."""
    return bytes([OpCode.SET_TARGET_RESISTANCE]) + _pack("resistance", "<h", round(level * 10))


def set_target_power(power_w: float) -> bytes:
    return bytes([OpCode.SET_TARGET_POWER]) + _pack("power", "<h", round(power_w))


def set_simulation(sim: Simulation) -> bytes:
    return bytes([OpCode.SET_SIMULATION]) + _pack("wind", "<h", round(sim.wind_mps * 1000)) + \
        _pack("grade", "<h", round(sim.grade_percent * 100)) + \
        _pack("crr", "<B", round(sim.crr * 10000)) + \
        _pack("cw", "<B", round(sim.cw_kg_per_m * 100))  # fmt: skip


Request = tuple[OpCode, float | Simulation | None]

_PARAMETER_SIZES = {
    OpCode.REQUEST_CONTROL: (0,),
    OpCode.RESET: (0,),
    OpCode.START_OR_RESUME: (0,),
    OpCode.SET_TARGET_RESISTANCE: (1, 2),
    OpCode.SET_TARGET_POWER: (2,),
    OpCode.SET_SIMULATION: (6,),
}


def decode_request(data: bytes | bytearray) -> Request:
    """What a control-point write asks for (the simulated trainer's side)."""
    data = bytes(data)
    if not data:
        raise FtmsError(FtmsReason.TRUNCATED, "empty control-point write")
    try:
        op = OpCode(data[0])
    except ValueError as exc:
        raise FtmsError(FtmsReason.UNKNOWN_OP_CODE, f"op code 0x{data[0]:02x}") from exc
    params = data[1:]
    if len(params) not in _PARAMETER_SIZES[op]:
        raise FtmsError(FtmsReason.TRUNCATED, f"{op.name} with {len(params)} parameter bytes")
    if op == OpCode.SET_TARGET_RESISTANCE:
        raw = params[0] if len(params) == 1 else struct.unpack("<h", params)[0]
        return op, raw / 10
    if op == OpCode.SET_TARGET_POWER:
        return op, float(struct.unpack("<h", params)[0])
    if op == OpCode.SET_SIMULATION:
        wind, grade, crr, cw = struct.unpack("<hhBB", params)
        return op, Simulation(wind / 1000, grade / 100, crr / 10000, cw / 100)
    return op, None


# ------------------------------------------------------------------ control point responses


class Response(msgspec.Struct, frozen=True):
    op: int  # the request's op code
    result: ResultCode

    @property
    def ok(self) -> bool:
        return self.result == ResultCode.SUCCESS


def encode_response(op: int, result: ResultCode) -> bytes:
    return bytes([RESPONSE_CODE, op, result])


def decode_response(data: bytes | bytearray) -> Response:
    data = bytes(data)
    if len(data) < 3:
        raise FtmsError(FtmsReason.TRUNCATED, f"control-point response of {len(data)} bytes")
    if data[0] != RESPONSE_CODE:
        raise FtmsError(FtmsReason.NOT_A_RESPONSE, f"first byte 0x{data[0]:02x}, expected 0x80")
    try:
        result = ResultCode(data[2])
    except ValueError as exc:
        raise FtmsError(FtmsReason.OUT_OF_RANGE, f"result code 0x{data[2]:02x}") from exc
    return Response(data[1], result)
