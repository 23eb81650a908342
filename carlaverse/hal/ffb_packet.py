"""The 40-byte force-feedback command (paper, table "UDP Payload Structure for FFB Commands").

Ten little-endian `int32`, no padding, in this order:

    byte  field                    range           meaning
    0-3   spring_stiffness         0 .. 10000      pull towards the spring offset
    4-7   spring_offset       -10000 .. 10000      spring centre, full left .. full right
    8-11  spring_deadband          0 .. 10000      zero-force zone width, 10000 = whole axis
    12-15 spring_saturation        0 .. 10000      spring force ceiling; 0 = no spring force
    16-19 constant_force      -10000 .. 10000      sustained force; sign as spring_offset
    20-23 damper                   0 .. 10000      viscous resistance (force ~ wheel speed)
    24-27 friction                 0 .. 10000      Coulomb friction (constant drag)
    28-31 inertia                  0 .. 10000      resistance to angular acceleration
    32-35 vibration_magnitude      0 .. 10000      sine vibration amplitude
    36-39 vibration_frequency_hz   0 .. 1000       [Hz]; 0 = no vibration

The paper fixes the first two ranges; the others are ours, chosen so every field shares the
same 0..10000 (= 0..100.00 %) scale. The frequency tops out at 1000 Hz because the Linux
periodic effect takes its period in whole milliseconds.

Sign: `constant_force` and `spring_offset` are positive toward the RIGHT (full left -10000 ..
full right 10000; `doctor --ffb` sends "constant force right" as +). Physics states steer
torques positive toward the LEFT, counter-clockwise like steer angle and yaw, so a producer
turns its torque into the wire's force with `constant_force(torque, full_scale)`: the minus
sign lives there, once.

Decoding network input raises only `FfbPacketError` (a ValueError) with a `reason`.
"""

from __future__ import annotations

import enum
import struct

import msgspec

DEFAULT_FFB_PORT = 45500  # our choice; the paper leaves the port to the command line
FFB_LAYOUT = struct.Struct("<10i")
FFB_PACKET_SIZE = FFB_LAYOUT.size  # 40 bytes

FULL_SCALE = 10000  # the value that means 100 %
MAX_VIBRATION_HZ = 1000  # [Hz] 1 ms period, the finest the Linux periodic effect takes


class FfbCommand(msgspec.Struct, frozen=True, kw_only=True):
    """One force-feedback command; every field in the unit given in the module table."""

    spring_stiffness: int = 0
    spring_offset: int = 0
    spring_deadband: int = 0
    spring_saturation: int = 0
    constant_force: int = 0
    damper: int = 0
    friction: int = 0
    inertia: int = 0
    vibration_magnitude: int = 0
    vibration_frequency_hz: int = 0  # [Hz]

    def is_zero(self) -> bool:
        """True when the command applies no force at all."""
        return not any(msgspec.structs.astuple(self))


ZERO_COMMAND = FfbCommand()


def constant_force(torque_left_nm: float, full_scale_nm: float) -> int:
    """The wire's constant_force for a bar torque [N·m] positive toward the LEFT, with
    `full_scale_nm` sent as 100 %: −τ/full_scale·10000, rounded and clamped to the range."""
    units = round(-torque_left_nm / full_scale_nm * FULL_SCALE)
    return max(-FULL_SCALE, min(FULL_SCALE, units))


# Inclusive bounds, in wire order.
FIELD_RANGES: tuple[tuple[str, int, int], ...] = (
    ("spring_stiffness", 0, FULL_SCALE),
    ("spring_offset", -FULL_SCALE, FULL_SCALE),
    ("spring_deadband", 0, FULL_SCALE),
    ("spring_saturation", 0, FULL_SCALE),
    ("constant_force", -FULL_SCALE, FULL_SCALE),
    ("damper", 0, FULL_SCALE),
    ("friction", 0, FULL_SCALE),
    ("inertia", 0, FULL_SCALE),
    ("vibration_magnitude", 0, FULL_SCALE),
    ("vibration_frequency_hz", 0, MAX_VIBRATION_HZ),
)


class FfbPacketReason(enum.Enum):
    WRONG_SIZE = "wrong size"
    OUT_OF_RANGE = "out of range"
    NOT_AN_INTEGER = "not an integer"


class FfbPacketError(ValueError):
    """A force-feedback packet or command that breaks the layout or a field range."""

    def __init__(self, reason: FfbPacketReason, message: str) -> None:
        super().__init__(message)
        self.reason = reason


def check(values: tuple[object, ...]) -> None:
    """Raise FfbPacketError naming the first field outside its range."""
    for value, (name, low, high) in zip(values, FIELD_RANGES, strict=True):
        if not isinstance(value, int):
            raise FfbPacketError(
                FfbPacketReason.NOT_AN_INTEGER, f"FFB field {name} = {value!r} is not an int"
            )
        if not low <= value <= high:
            raise FfbPacketError(
                FfbPacketReason.OUT_OF_RANGE,
                f"FFB field {name} = {value} is outside {low}..{high}",
            )


def encode(command: FfbCommand) -> bytes:
    """The 40-byte packet for `command`; FfbPacketError if a field is out of range."""
    values = msgspec.structs.astuple(command)
    check(values)
    return FFB_LAYOUT.pack(*values)


def decode(data: bytes | bytearray | memoryview) -> FfbCommand:
    """The command in a 40-byte packet; FfbPacketError on a wrong size or range."""
    if len(data) != FFB_PACKET_SIZE:
        raise FfbPacketError(
            FfbPacketReason.WRONG_SIZE,
            f"FFB packet is {len(data)} bytes, expected {FFB_PACKET_SIZE}",
        )
    values = FFB_LAYOUT.unpack(data)
    check(values)
    return FfbCommand(**dict(zip(FfbCommand.__struct_fields__, values, strict=True)))
