"""A vehicle's light bits (messages.LIGHT_*: NPC rows, an ego's EgoState) as OSI's LightState.

Position (parking) lights and low beams both light the tail lights; fog lights are front and
rear; both blinkers at once are the hazard warning. An ego's `EgoState.indicator` is folded
into the blinker bits first (`recorded_world.ego_bits`), so both sources read the same way.
"""

from __future__ import annotations

from typing import Any

from osi3.osi_object_pb2 import MovingObject

from carlaverse import messages as m

LightState = MovingObject.VehicleClassification.LightState  # a protobuf class (untyped)


def _on(bits: int, mask: int) -> int:
    return LightState.GENERIC_LIGHT_STATE_ON if bits & mask else LightState.GENERIC_LIGHT_STATE_OFF


def _indicator(bits: int) -> int:
    left, right = bits & m.LIGHT_LEFT_BLINKER, bits & m.LIGHT_RIGHT_BLINKER
    if left and right:
        return LightState.INDICATOR_STATE_WARNING
    if left or right:
        return LightState.INDICATOR_STATE_LEFT if left else LightState.INDICATOR_STATE_RIGHT
    return LightState.INDICATOR_STATE_OFF


def fill_light_state(out: Any, bits: int) -> None:
    """Set every field of `out` (a LightState) the bits say something about."""
    out.indicator_state = _indicator(bits)
    out.head_light = _on(bits, m.LIGHT_LOW_BEAM)
    out.high_beam = _on(bits, m.LIGHT_HIGH_BEAM)
    out.front_fog_light = out.rear_fog_light = _on(bits, m.LIGHT_FOG)
    out.reversing_light = _on(bits, m.LIGHT_REVERSE)
    out.tail_light = _on(bits, m.LIGHT_PARKING | m.LIGHT_LOW_BEAM)
    brake = bits & m.LIGHT_BRAKE
    out.brake_light_state = (
        LightState.BRAKE_LIGHT_STATE_NORMAL if brake else LightState.BRAKE_LIGHT_STATE_OFF
    )
