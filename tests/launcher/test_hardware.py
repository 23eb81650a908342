"""The launcher's hardware checks: simulated devices, a real SDL joystick, and one line when
the Bluetooth stack is missing."""

from __future__ import annotations

from pathlib import Path

import pytest

from carlaverse.hal.errors import HalError
from carlaverse.launcher import hardware


def test_ffb_pulses_end_with_all_forces_off_on_the_sim_device() -> None:
    lines: list[str] = []
    sent = hardware.ffb_pulses({"backend": "sim"}, lines.append, step_s=0.02, rate_hz=100)
    assert sent == 10 * 2  # ten steps of two commands
    assert lines[0] == "ffb: spring to centre" and lines[-2] == "ffb: all forces off"


def test_motion_neutral_and_trainer_scan_on_sim_devices() -> None:
    lines: list[str] = []
    assert hardware.motion_neutral({"backend": "sim"}, lines.append, step_s=0.05)
    found = hardware.trainer_scan({"backend": "ftms_sim"}, lines.append)
    assert len(found) == 1 and "ftms_sim answers; first sample" in found[0]
    assert lines[-1] == f"trainer: {found[0]}"


def test_sim_joystick_moves_and_unknown_backend_is_one_line() -> None:
    watch = hardware.JoystickWatch()
    try:
        first = watch.sample()
        assert set(first.axes) == {"steer", "throttle", "brake"}
        assert set(first.buttons) == {"a", "b"}
    finally:
        watch.close()
    with pytest.raises(HalError, match="backend 'wheel'") as info:
        hardware.JoystickWatch({"backend": "wheel"})
    assert "\n" not in str(info.value)


def test_a_real_sdl_joystick_is_listed_and_read_live(monkeypatch: pytest.MonkeyPatch) -> None:
    """Through SDL itself (a virtual device made by the SDL library pygame ships)."""
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    pytest.importorskip("pygame")
    from tests.hal.sdl import VirtualJoystick

    stick = VirtualJoystick(axes=2, buttons=3, hats=0)
    try:
        listed = hardware.list_joysticks()
        assert any("2 axes, 3 buttons" in row for row in listed), listed
        index = int(listed[-1].split(":", 1)[0])
        watch = hardware.JoystickWatch({"backend": "pygame", "options": {"index": index}})
        try:
            stick.axis(1, -0.5)
            stick.button(2, True)
            sample = watch.sample()
        finally:
            watch.close()
    finally:
        stick.detach()
    assert [round(v, 2) for v in sample.axes.values()] == [0.0, -0.5]
    assert [pressed for pressed in sample.buttons.values()] == [False, False, True]


@pytest.mark.skipif(
    any(
        Path(p).exists() for p in ("/run/dbus/system_bus_socket", "/var/run/dbus/system_bus_socket")
    ),
    reason="a D-Bus system bus is here: a Bluetooth scan may really run",
)
def test_a_bluetooth_scan_without_bluez_fails_in_one_line() -> None:
    with pytest.raises(HalError, match="Bluetooth scan failed") as info:
        hardware.trainer_scan({"backend": "ftms"}, lambda _line: None)
    assert "\n" not in str(info.value)
