"""Touchscreen taps take the key path: `touch:<action>` buttons → Controls → the loop."""

from __future__ import annotations

from carlaverse_nodes.drive.touch import MAX_PENDING, TouchButtons

from carlaverse.hal import InputState
from carlaverse.messages import LIGHT_HIGH_BEAM, LIGHT_LOW_BEAM
from tests.drive.support import DT, IDLE, desktop_loop


def _tick(loop, touch: TouchButtons) -> int:  # type: ignore[no-untyped-def]
    """One loop tick with this tick's touch button; returns the lights bits."""
    buttons = touch.buttons() or {}
    return loop.step(DT, InputState(0.0, IDLE.axes, buttons)).lights


def test_taps_switch_the_low_and_high_beam_in_the_drive_loop() -> None:
    loop, touch = desktop_loop(), TouchButtons()
    assert not _tick(loop, touch) & LIGHT_LOW_BEAM
    touch.tap("low_beam")
    touch.tap("high_beam")  # queued: a separate rising edge after the first
    lights = [_tick(loop, touch) for _ in range(6)]
    assert lights[0] & LIGHT_LOW_BEAM and not lights[0] & LIGHT_HIGH_BEAM
    assert lights[-1] & LIGHT_LOW_BEAM and lights[-1] & LIGHT_HIGH_BEAM
    touch.tap("low_beam")  # low beam off: the latched high beam goes dark with it
    lights = [_tick(loop, touch) for _ in range(3)]
    assert not lights[-1] & (LIGHT_LOW_BEAM | LIGHT_HIGH_BEAM)


def test_two_taps_of_one_action_are_two_edges() -> None:
    touch = TouchButtons()
    touch.tap("lights_next")
    touch.tap("lights_next")
    held = [touch.buttons() for _ in range(5)]
    assert held == [{"touch:lights_next": True}, None, {"touch:lights_next": True}, None, None]


def test_a_flood_of_taps_is_bounded_and_counted() -> None:
    touch = TouchButtons()
    for _ in range(MAX_PENDING + 5):
        touch.tap("horn")
    assert touch.dropped == 5
