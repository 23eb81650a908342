"""Vehicle lights: the head-light switch, high beam and interior from the driver; brake and
reverse lights from the vehicle's state (paper, "Control and ADAS Interfaces").

The head-light switch is a rotary state machine OFF → PARKING → LOW_BEAM → FOG (fog lamps
need the low beam, as on most European cars); `lights_next`/`lights_prev` turn it one notch,
`lights_cycle` steps round for a single button, `fog` toggles fog on top of the low beam,
`low_beam` switches straight to the low beam or off again (a touchscreen's one button).
High beam is latched by `high_beam` and only lights with the low beam on; `flash` lights it
while held, whatever the switch. The output is the LIGHT_* bitmask of carlaverse.messages.
"""

from __future__ import annotations

import enum
from types import MappingProxyType

from carlaverse.messages import (
    LIGHT_BRAKE,
    LIGHT_FOG,
    LIGHT_HIGH_BEAM,
    LIGHT_INTERIOR,
    LIGHT_LOW_BEAM,
    LIGHT_PARKING,
    LIGHT_REVERSE,
)

BRAKE_LIGHT_PEDAL = 0.05  # brake command above which the brake lamps light [-]


class HeadlightMode(enum.Enum):
    OFF = "off"
    PARKING = "parking"
    LOW_BEAM = "low_beam"
    FOG = "fog"  # low beam + fog lamps


H = HeadlightMode

# (mode, action) → mode, for every switch action; a missing pair cannot happen.
HEADLIGHT_TRANSITIONS = MappingProxyType(
    {
        (H.OFF, "lights_next"): H.PARKING,
        (H.PARKING, "lights_next"): H.LOW_BEAM,
        (H.LOW_BEAM, "lights_next"): H.FOG,
        (H.FOG, "lights_next"): H.FOG,
        (H.OFF, "lights_prev"): H.OFF,
        (H.PARKING, "lights_prev"): H.OFF,
        (H.LOW_BEAM, "lights_prev"): H.PARKING,
        (H.FOG, "lights_prev"): H.LOW_BEAM,
        (H.OFF, "lights_cycle"): H.PARKING,
        (H.PARKING, "lights_cycle"): H.LOW_BEAM,
        (H.LOW_BEAM, "lights_cycle"): H.FOG,
        (H.FOG, "lights_cycle"): H.OFF,
        (H.OFF, "fog"): H.OFF,
        (H.PARKING, "fog"): H.PARKING,
        (H.LOW_BEAM, "fog"): H.FOG,
        (H.FOG, "fog"): H.LOW_BEAM,
        (H.OFF, "low_beam"): H.LOW_BEAM,
        (H.PARKING, "low_beam"): H.LOW_BEAM,
        (H.LOW_BEAM, "low_beam"): H.OFF,
        (H.FOG, "low_beam"): H.OFF,
    }
)
SWITCH_ACTIONS = ("lights_next", "lights_prev", "lights_cycle", "fog", "low_beam")

MODE_BITS = MappingProxyType(
    {
        H.OFF: 0,
        H.PARKING: LIGHT_PARKING,
        H.LOW_BEAM: LIGHT_PARKING | LIGHT_LOW_BEAM,
        H.FOG: LIGHT_PARKING | LIGHT_LOW_BEAM | LIGHT_FOG,
    }
)


class Lights:
    """Driver-switched lights plus state-driven brake and reverse lamps."""

    def __init__(self) -> None:
        self.mode = H.OFF
        self.high_beam_latched = False
        self.interior = False

    def handle(self, pressed: frozenset[str] | set[str]) -> None:
        """Apply this tick's rising edges (action names)."""
        if not pressed:
            return
        for action in SWITCH_ACTIONS:
            if action in pressed:
                self.mode = HEADLIGHT_TRANSITIONS[(self.mode, action)]
        if "high_beam" in pressed:
            self.high_beam_latched = not self.high_beam_latched
        if "interior" in pressed:
            self.interior = not self.interior

    def bits(self, flash_held: bool, brake: float, gear: int) -> int:
        """The LIGHT_* bitmask for this tick (blinker bits come from `Indicators`)."""
        bits = MODE_BITS[self.mode]
        low_beam_on = self.mode in (H.LOW_BEAM, H.FOG)
        if flash_held or (self.high_beam_latched and low_beam_on):
            bits |= LIGHT_HIGH_BEAM
        if self.interior:
            bits |= LIGHT_INTERIOR
        if brake > BRAKE_LIGHT_PEDAL:
            bits |= LIGHT_BRAKE
        if gear < 0:
            bits |= LIGHT_REVERSE
        return bits
