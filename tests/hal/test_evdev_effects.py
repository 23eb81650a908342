"""FfbCommand -> Linux ff_effect mapping (pure), the evdev structs it builds, and — behind
--hardware — a real force-feedback device."""

from __future__ import annotations

import os

import pytest
from hypothesis import given
from hypothesis import strategies as st

from carlaverse.hal.diagnostics import ffb_test_sequence
from carlaverse.hal.ffb_packet import FIELD_RANGES, ZERO_COMMAND, FfbCommand
from carlaverse.hal.ffb_server import evdev_effects as fx

FULL = FfbCommand(
    spring_stiffness=10000, spring_offset=-5000, spring_deadband=10000, spring_saturation=5000,
    constant_force=2500, damper=10000, friction=5000, inertia=1, vibration_magnitude=10000,
    vibration_frequency_hz=40,
)  # fmt: skip


@pytest.mark.parametrize(
    ("value", "full", "expected"),
    [(0, 0x7FFF, 0), (10000, 0x7FFF, 32767), (-10000, 0x7FFF, -32767), (5000, 0x7FFF, 16384),
     (-5000, 0x7FFF, -16384), (1, 0x7FFF, 3), (10000, 0xFFFF, 65535), (5000, 0xFFFF, 32768)],
)  # fmt: skip
def test_scale(value: int, full: int, expected: int) -> None:
    assert fx.scale(value, full) == expected


@given(st.integers(-10000, 10000))
def test_scale_stays_in_the_kernel_range_and_keeps_sign(value: int) -> None:
    scaled = fx.scale(value, fx.S16_MAX)
    assert -fx.S16_MAX <= scaled <= fx.S16_MAX
    assert (scaled > 0) == (value > 0) and (scaled < 0) == (value < 0)


@pytest.mark.parametrize(("hz", "ms"), [(0, 0), (1, 1000), (3, 333), (40, 25), (999, 1), (1000, 1)])
def test_period(hz: int, ms: int) -> None:
    assert fx.period_ms(hz) == ms


def test_full_command_maps_every_field() -> None:
    p = fx.effect_params(FULL)
    assert list(p) == list(fx.EFFECT_NAMES)
    assert p["spring"].type == fx.FF_SPRING
    assert p["spring"].condition == fx.ConditionParams(
        coeff=32767, saturation=32768, deadband=65535, center=-16384
    )
    assert p["constant"].type == fx.FF_CONSTANT and p["constant"].level == 8192
    assert p["damper"].condition.coeff == 32767 and p["damper"].condition.saturation == 0xFFFF
    assert p["friction"].type == fx.FF_FRICTION and p["friction"].condition.coeff == 16384
    assert p["inertia"].type == fx.FF_INERTIA and p["inertia"].condition.coeff == 3
    assert p["vibration"].type == fx.FF_PERIODIC
    assert (p["vibration"].magnitude, p["vibration"].period_ms) == (32767, 25)
    assert all(e.direction == fx.DIRECTION_ALONG_AXIS for e in p.values())
    assert not any(e.silent for e in p.values())


def test_invert_flips_constant_force_and_spring_centre_only() -> None:
    normal, inverted = fx.effect_params(FULL), fx.effect_params(FULL, invert=True)
    assert inverted["constant"].level == -normal["constant"].level
    assert inverted["spring"].condition.center == -normal["spring"].condition.center
    assert inverted["spring"].condition.coeff == normal["spring"].condition.coeff
    assert inverted["vibration"] == normal["vibration"]


def test_zero_command_is_silent_everywhere() -> None:
    assert all(e.silent for e in fx.effect_params(ZERO_COMMAND).values())


def test_spring_without_saturation_or_vibration_without_frequency_is_silent() -> None:
    p = fx.effect_params(FfbCommand(spring_stiffness=5000, vibration_magnitude=5000))
    assert p["spring"].silent and p["vibration"].silent


@given(st.builds(FfbCommand, **{n: st.integers(lo, hi) for n, lo, hi in FIELD_RANGES}))
def test_every_valid_command_maps_into_kernel_ranges(command: FfbCommand) -> None:
    for params in fx.effect_params(command).values():
        assert -fx.S16_MAX <= params.level <= fx.S16_MAX
        assert 0 <= params.magnitude <= fx.S16_MAX and 0 <= params.period_ms <= fx.U16_MAX
        if params.condition:
            c = params.condition
            assert 0 <= c.coeff <= fx.S16_MAX and -fx.S16_MAX <= c.center <= fx.S16_MAX
            assert 0 <= c.saturation <= fx.U16_MAX and 0 <= c.deadband <= fx.U16_MAX


def test_gain() -> None:
    assert (fx.gain_value(100), fx.gain_value(0), fx.gain_value(50)) == (65535, 0, 32768)


# ---------------------------------------------------------------- with python-evdev


def test_codes_match_the_kernel_headers_evdev_ships() -> None:
    ecodes = pytest.importorskip("evdev.ecodes")
    assert (fx.EV_FF, fx.FF_PERIODIC, fx.FF_CONSTANT, fx.FF_SPRING) == (
        ecodes.EV_FF, ecodes.FF_PERIODIC, ecodes.FF_CONSTANT, ecodes.FF_SPRING,
    )  # fmt: skip
    assert (fx.FF_FRICTION, fx.FF_DAMPER, fx.FF_INERTIA, fx.FF_SINE) == (
        ecodes.FF_FRICTION, ecodes.FF_DAMPER, ecodes.FF_INERTIA, ecodes.FF_SINE,
    )  # fmt: skip
    assert (fx.FF_GAIN, fx.FF_AUTOCENTER) == (ecodes.FF_GAIN, ecodes.FF_AUTOCENTER)


def test_evdev_effect_structs_carry_the_parameters() -> None:
    ff = pytest.importorskip("evdev.ff")
    p = fx.effect_params(FULL)
    spring = fx.to_evdev(p["spring"], ff)
    assert (spring.type, spring.id, spring.direction) == (fx.FF_SPRING, -1, 0x4000)
    assert spring.ff_replay.length == fx.PLAY_UNTIL_STOPPED
    x = spring.u.ff_condition_effect[0]
    assert (x.right_coeff, x.left_coeff, x.center, x.deadband) == (32767, 32767, -16384, 65535)
    assert (x.right_saturation, x.left_saturation) == (32768, 32768)
    assert spring.u.ff_condition_effect[1].right_coeff == 0
    constant = fx.to_evdev(p["constant"], ff, effect_id=3)
    assert constant.id == 3 and constant.u.ff_constant_effect.level == 8192
    sine = fx.to_evdev(p["vibration"], ff).u.ff_periodic_effect
    assert (sine.waveform, sine.period, sine.magnitude) == (fx.FF_SINE, 25, 32767)
    damper = fx.to_evdev(p["damper"], ff).u.ff_condition_effect[0]
    assert damper.right_coeff == 32767 and damper.right_saturation == 0xFFFF
    assert len(bytes(spring)) == 48  # sizeof(struct ff_effect) on 64-bit Linux


def test_a_missing_device_is_a_device_error_naming_it() -> None:
    pytest.importorskip("evdev")
    from carlaverse.hal.errors import DeviceError
    from carlaverse.hal.ffb_server.evdev_actuator import EvdevActuator, EvdevOptions

    with pytest.raises(DeviceError, match="/dev/input/event999"):
        EvdevActuator(EvdevOptions(device="/dev/input/event999"))
    with pytest.raises(DeviceError, match="no force-feedback device matches"):
        EvdevActuator(EvdevOptions(device="no such wheel"))


def ffb_device_spec() -> str:
    """CARLAVERSE_FFB_DEVICE, else the first readable device with force feedback."""
    evdev = pytest.importorskip("evdev")
    if os.environ.get("CARLAVERSE_FFB_DEVICE"):
        return os.environ["CARLAVERSE_FFB_DEVICE"]
    for path in evdev.list_devices():
        if fx.EV_FF in evdev.InputDevice(path).capabilities():
            return path
    pytest.skip("no force-feedback device; set CARLAVERSE_FFB_DEVICE=/dev/input/eventN")


@pytest.mark.hardware
def test_real_device_plays_the_test_sequence_and_zeroes() -> None:
    from carlaverse.hal.ffb_server.evdev_actuator import EvdevActuator, EvdevOptions

    actuator = EvdevActuator(EvdevOptions(device=ffb_device_spec(), gain_percent=30))
    try:
        for _label, command in ffb_test_sequence(strength=0.1):
            actuator.apply(command)
            audible = {n for n, p in fx.effect_params(command).items() if not p.silent}
            supported = {n for n, p in fx.effect_params(command).items() if actuator._has(p)}
            assert actuator.playing == audible & supported
        actuator.apply(FfbCommand(constant_force=1000, damper=1000))
        actuator.zero()
        assert actuator.playing == set()
    finally:
        actuator.close()


@pytest.mark.hardware
def test_real_device_behind_the_server_is_zeroed_by_the_watchdog() -> None:
    from carlaverse.hal import ffb_packet
    from carlaverse.hal.ffb_server import FfbServer
    from carlaverse.hal.ffb_server.evdev_actuator import EvdevActuator, EvdevOptions
    from tests.hal.helpers import Sender
    from tests.support import wait_until

    actuator = EvdevActuator(EvdevOptions(device=ffb_device_spec(), gain_percent=30))
    with FfbServer(actuator, "127.0.0.1", 0, watchdog_s=0.1) as server:
        sender = Sender(server.address)
        sender.send(ffb_packet.encode(FfbCommand(constant_force=800)))
        wait_until(lambda: server.stats.applied == 1, 5, "packet applied")
        wait_until(lambda: server.stats.watchdog_trips == 1, 5, "watchdog")
        assert actuator.playing == set() and server.stats.device_errors == 0
        sender.close()
