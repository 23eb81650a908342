"""The light switch machine and the state-driven lamps."""

from __future__ import annotations

import itertools

import pytest
from carlaverse_nodes.drive.lights import (
    HEADLIGHT_TRANSITIONS,
    SWITCH_ACTIONS,
    HeadlightMode,
    Lights,
)

from carlaverse.messages import (
    LIGHT_BRAKE,
    LIGHT_FOG,
    LIGHT_HIGH_BEAM,
    LIGHT_INTERIOR,
    LIGHT_LOW_BEAM,
    LIGHT_PARKING,
    LIGHT_REVERSE,
)

H = HeadlightMode


def test_switch_table_covers_every_mode_and_action() -> None:
    assert set(HEADLIGHT_TRANSITIONS) == set(itertools.product(H, SWITCH_ACTIONS))


@pytest.mark.parametrize(
    ("actions", "mode", "bits"),
    [
        (["lights_next"], H.PARKING, LIGHT_PARKING),
        (["lights_next"] * 2, H.LOW_BEAM, LIGHT_PARKING | LIGHT_LOW_BEAM),
        (["lights_next"] * 3, H.FOG, LIGHT_PARKING | LIGHT_LOW_BEAM | LIGHT_FOG),
        (["lights_next"] * 5, H.FOG, LIGHT_PARKING | LIGHT_LOW_BEAM | LIGHT_FOG),  # end stop
        (["lights_next", "lights_next", "lights_prev"], H.PARKING, LIGHT_PARKING),
        (["lights_cycle"] * 4, H.OFF, 0),  # one button steps round
        (["fog"], H.OFF, 0),  # fog lamps need the low beam
        (["lights_next", "lights_next", "fog"], H.FOG, LIGHT_PARKING | LIGHT_LOW_BEAM | LIGHT_FOG),
        (["lights_next", "lights_next", "fog", "fog"], H.LOW_BEAM, LIGHT_PARKING | LIGHT_LOW_BEAM),
    ],
)
def test_switch_sequences(actions: list[str], mode: HeadlightMode, bits: int) -> None:
    lights = Lights()
    for action in actions:
        lights.handle({action})
    assert lights.mode is mode
    assert lights.bits(flash_held=False, brake=0.0, gear=1) == bits


def test_high_beam_needs_low_beam_but_flash_always_works() -> None:
    lights = Lights()
    lights.handle({"high_beam"})
    assert not lights.bits(False, 0.0, 1) & LIGHT_HIGH_BEAM
    assert lights.bits(True, 0.0, 1) & LIGHT_HIGH_BEAM
    lights.handle({"lights_next"})
    lights.handle({"lights_next"})
    assert lights.bits(False, 0.0, 1) & LIGHT_HIGH_BEAM


def test_vehicle_state_lamps_and_interior() -> None:
    lights = Lights()
    assert lights.bits(False, 0.3, 1) == LIGHT_BRAKE
    assert lights.bits(False, 0.0, -1) == LIGHT_REVERSE
    assert lights.bits(False, 0.01, 0) == 0  # a resting foot does not light the brake lamps
    lights.handle({"interior"})
    assert lights.bits(False, 0.0, 0) == LIGHT_INTERIOR
