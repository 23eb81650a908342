"""The 21-byte motion-platform FRAME_UPDATE (paper, table "UDP Payload Structure for
FRAME_UPDATE Commands of the Motion Platform Server").

    byte   type     field
    0      uint8    command id, 0x04 = FRAME_UPDATE
    1-4    float32  roll     [rad]    washout-filtered platform roll, right side down positive
    5-8    float32  pitch    [rad]    washout-filtered platform pitch, nose up positive
    9-12   float32  heave    [m]      vertical displacement, up positive
    13-16  float32  rpm      [1/min]  engine speed, for vibration
    17-20  float32  torque   [N·m]    engine torque, for dynamic haptics

All little-endian, no padding. The paper names the quantities but not their units; the units
above are ours. Every value must be finite and within `MotionLimits` (configurable, defaults
generous enough for any rig): a packet that is not is rejected whole. A packet shorter than
21 bytes is the paper's safety case (`MotionPacketReason.SHORT`); a longer one is rejected too
(`LONG`) rather than guessed at.

Decoding network input raises only `MotionPacketError` (a ValueError) with a `reason`.
"""

from __future__ import annotations

import enum
import math
import struct
from typing import Annotated

import msgspec

from carlaverse.config import StrictStruct

DEFAULT_MOTION_PORT = 45501  # our choice; the paper leaves the port to the command line
FRAME_UPDATE = 0x04
FRAME_LAYOUT = struct.Struct("<B5f")
FRAME_SIZE = FRAME_LAYOUT.size  # 21 bytes
FLOAT32_MAX = 3.4028234663852886e38

Buffer = bytes | bytearray | memoryview

Positive = Annotated[float, msgspec.Meta(gt=0, le=FLOAT32_MAX)]


class MotionFrame(msgspec.Struct, frozen=True):
    """One FRAME_UPDATE: platform attitude and engine state."""

    roll: float = 0.0  # [rad]
    pitch: float = 0.0  # [rad]
    heave: float = 0.0  # [m]
    rpm: float = 0.0  # [1/min]
    torque: float = 0.0  # [N·m]


NEUTRAL_FRAME = MotionFrame()
FIELDS = MotionFrame.__struct_fields__


class MotionLimits(StrictStruct):
    """Largest magnitude accepted per field; |value| above it rejects the frame."""

    roll_rad: Positive = math.pi / 2  # [rad]
    pitch_rad: Positive = math.pi / 2  # [rad]
    heave_m: Positive = 1.0  # [m]
    rpm: Positive = 30000.0  # [1/min]
    torque_nm: Positive = 10000.0  # [N·m]

    def bounds(self) -> tuple[float, ...]:
        return (self.roll_rad, self.pitch_rad, self.heave_m, self.rpm, self.torque_nm)


DEFAULT_LIMITS = MotionLimits()


class MotionPacketReason(enum.Enum):
    SHORT = "short"
    LONG = "long"
    UNKNOWN_COMMAND = "unknown command"
    NOT_FINITE = "not finite"
    OUT_OF_RANGE = "out of range"


class MotionPacketError(ValueError):
    """A motion packet or frame that breaks the layout or a limit."""

    def __init__(self, reason: MotionPacketReason, message: str) -> None:
        super().__init__(message)
        self.reason = reason


def check(values: tuple[float, ...], limits: MotionLimits) -> None:
    """Raise MotionPacketError naming the first value that is not finite or over its limit."""
    for name, value, bound in zip(FIELDS, values, limits.bounds(), strict=True):
        if not math.isfinite(value):
            raise MotionPacketError(
                MotionPacketReason.NOT_FINITE, f"motion field {name} = {value} is not finite"
            )
        if abs(value) > bound:
            raise MotionPacketError(
                MotionPacketReason.OUT_OF_RANGE,
                f"motion field {name} = {value:g} exceeds its limit ±{bound:g}",
            )


def clip(frame: MotionFrame, limits: MotionLimits) -> tuple[MotionFrame, bool]:
    """`frame` within `limits` (a value beyond one is set to it, a value that is not finite to
    0, the neutral of every field), and whether anything had to change. For a sender that must
    not raise, such as a control loop."""
    values = msgspec.structs.astuple(frame)
    inside = tuple(
        max(-bound, min(bound, value)) if math.isfinite(value) else 0.0
        for value, bound in zip(values, limits.bounds(), strict=True)
    )
    if inside == values:
        return frame, False
    return MotionFrame(*inside), True


def encode(frame: MotionFrame, limits: MotionLimits = DEFAULT_LIMITS) -> bytes:
    """The 21-byte FRAME_UPDATE for `frame`; MotionPacketError if a value breaks a limit."""
    values = msgspec.structs.astuple(frame)
    check(values, limits)
    return FRAME_LAYOUT.pack(FRAME_UPDATE, *values)


def decode(data: Buffer, limits: MotionLimits = DEFAULT_LIMITS) -> MotionFrame:
    """The frame in a FRAME_UPDATE packet; MotionPacketError for anything else."""
    size = len(data)
    if size == 0:
        raise MotionPacketError(MotionPacketReason.SHORT, "empty motion packet")
    if data[0] != FRAME_UPDATE:
        raise MotionPacketError(
            MotionPacketReason.UNKNOWN_COMMAND,
            f"motion command id 0x{data[0]:02x} is not FRAME_UPDATE (0x04)",
        )
    if size != FRAME_SIZE:
        reason = MotionPacketReason.SHORT if size < FRAME_SIZE else MotionPacketReason.LONG
        raise MotionPacketError(
            reason, f"FRAME_UPDATE is {size} bytes, expected {FRAME_SIZE}; ignored"
        )
    _, *values = FRAME_LAYOUT.unpack(data)
    check(tuple(values), limits)
    return MotionFrame(*values)
