"""What a lab runs before a study: a test force sequence and a motion sweep, as schedules.

The schedules are pure data (label, duration, command), so tests check them and `carlaverse
doctor` plays them through the ordinary `udp` clients at a steady rate, which keeps the
servers' watchdogs fed for the whole test.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator
from typing import Annotated

import msgspec

from carlaverse.config import StrictStruct
from carlaverse.hal.ffb_packet import FULL_SCALE, ZERO_COMMAND, FfbCommand
from carlaverse.hal.motion_packet import NEUTRAL_FRAME, MotionFrame


class SweepAmplitudes(StrictStruct):
    roll_rad: Annotated[float, msgspec.Meta(ge=0)] = 0.08  # [rad]
    pitch_rad: Annotated[float, msgspec.Meta(ge=0)] = 0.08  # [rad]
    heave_m: Annotated[float, msgspec.Meta(ge=0)] = 0.02  # [m]
    rpm: Annotated[float, msgspec.Meta(ge=0)] = 5000.0  # [1/min] peak of the rev sweep
    torque_nm: Annotated[float, msgspec.Meta(ge=0)] = 200.0  # [N·m]


def ffb_test_sequence(strength: float = 0.3) -> list[tuple[str, FfbCommand]]:
    """Each effect alone, at `strength` (0..1) of full scale, then all forces off."""
    s = round(FULL_SCALE * min(1.0, max(0.0, strength)))
    spring = {"spring_stiffness": s, "spring_saturation": FULL_SCALE}
    return [
        ("spring to centre", FfbCommand(**spring)),
        ("spring centre left", FfbCommand(**spring, spring_offset=-s)),
        ("spring centre right", FfbCommand(**spring, spring_offset=s)),
        ("constant force left", FfbCommand(constant_force=-s)),
        ("constant force right", FfbCommand(constant_force=s)),
        ("damper", FfbCommand(damper=s)),
        ("friction", FfbCommand(friction=s)),
        ("inertia", FfbCommand(inertia=s)),
        ("vibration 20 Hz", FfbCommand(vibration_magnitude=s, vibration_frequency_hz=20)),
        ("all forces off", ZERO_COMMAND),
    ]


def motion_sweep(amplitudes: SweepAmplitudes) -> list[tuple[str, Callable[[float], MotionFrame]]]:
    """One sine period per degree of freedom, a rev sweep, then neutral; each step maps the
    phase 0..1 to a frame."""
    a = amplitudes

    def sine(u: float) -> float:
        return math.sin(2 * math.pi * u)

    return [
        ("roll", lambda u: MotionFrame(roll=a.roll_rad * sine(u))),
        ("pitch", lambda u: MotionFrame(pitch=a.pitch_rad * sine(u))),
        ("heave", lambda u: MotionFrame(heave=a.heave_m * sine(u))),
        ("engine", lambda u: MotionFrame(rpm=800 + (a.rpm - 800) * u, torque=a.torque_nm * u)),
        ("neutral", lambda u: NEUTRAL_FRAME),
    ]


def ticks(duration_s: float, rate_hz: float) -> Iterator[float]:
    """Phases 0..1 of the sends of one step at `rate_hz` (at least one send)."""
    count = max(1, round(duration_s * rate_hz))
    for i in range(count):
        yield i / count


def paced(step_s: float, rate_hz: float, send: Callable[[float], None]) -> None:
    """Call `send(phase)` at `rate_hz` for one step of `step_s` seconds, on a steady grid."""
    period = 1.0 / rate_hz
    next_t = time.monotonic()
    for phase in ticks(step_s, rate_hz):
        send(phase)
        next_t += period
        time.sleep(max(0.0, next_t - time.monotonic()))
